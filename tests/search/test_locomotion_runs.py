"""A real (tiny) locomotion evolution from several symmetry-broken starts: the same on every
backend and across a kill and a resume; an older run's description still resumes."""

import csv
import json

import numpy as np
import pytest

from mjregen.growth.nca import NCAConfig
from mjregen.physics import Physics
from mjregen.search.backends import ProcessBackend, SerialBackend, ThreadBackend
from mjregen.search.ga import GAConfig
from mjregen.search.run_folder import prepare_folder
from mjregen.search.runs import run_evolution
from mjregen.tasks.locomotion import LocomotionTask

GA = GAConfig(population=6, generations=4, truncation=3, elites=1, sigma=0.3, init_std=0.5)
QUICK = Physics().replace(settle_time=0.01)


class Killed(Exception):
    pass


def evolve(out, backend, **kwargs):
    task = LocomotionTask(nca=NCAConfig(dim=2, kind="ff"), physics=QUICK, duration=0.02,
                          starts=2, start_seed=7)
    return run_evolution(task, GA, seed=7, out=out, backend=backend,
                         progress=False, **kwargs)


def rows(out):
    with open(out / "metrics.csv") as handle:
        return [{k: r[k] for k in ("generation", "best", "mean", "std", "best_distance_min",
                                   "best_distance_std")} for r in csv.DictReader(handle)]


def test_the_same_evolution_on_every_backend_and_across_a_kill(tmp_path):
    serial = evolve(tmp_path / "serial", SerialBackend())
    for name, backend in (("thread", ThreadBackend(2)), ("process", ProcessBackend(2))):
        with backend:
            other = evolve(tmp_path / name, backend)
        assert np.array_equal(other.best_genome, serial.best_genome), name
        assert rows(tmp_path / name) == rows(tmp_path / "serial"), name

    def kill_after_generation_1(row):
        if row["generation"] == 1:
            raise Killed

    with pytest.raises(Killed):
        evolve(tmp_path / "killed", SerialBackend(), on_generation=kill_after_generation_1)
    resumed = evolve(tmp_path / "killed", SerialBackend(), resume=True)
    assert np.array_equal(resumed.best_genome, serial.best_genome)
    assert rows(tmp_path / "killed") == rows(tmp_path / "serial")
    spread = [float(r["best_distance_std"]) for r in rows(tmp_path / "serial")]
    assert all(s >= 0.0 for s in spread) and any(s > 0.0 for s in spread)


def test_a_run_described_before_starts_resumes(tmp_path):
    """config.json written before the start shift (physics format 4, no starts): its task
    reads as one exact start, and a resume with that task is accepted."""
    task = LocomotionTask(nca=NCAConfig(dim=2, kind="ff"), physics=QUICK.replace(start_shift=0.0))
    stored = task.to_config()
    del stored["starts"], stored["start_seed"]
    del stored["physics"]["scene"]["start_shift"]
    stored["physics"]["format"] = 4
    (tmp_path / "config.json").write_text(json.dumps({"format": "x", "task": stored, "seed": 0}))
    config = {"format": "x", "task": task.to_config(), "seed": 0}
    assert prepare_folder(tmp_path, config, resume=True, force=False,
                          task_class=LocomotionTask) is False
    edited = {**config, "task": {**config["task"], "starts": 3}}
    with pytest.raises(Exception, match="different settings"):
        prepare_folder(tmp_path, edited, resume=True, force=False, task_class=LocomotionTask)
