"""Run folders: files per generation, exact resume after a kill, no silent overwrite."""

import csv
import json

import numpy as np
import pytest

from mjregen.grid import Robot
from mjregen.growth.checkpoint import load_nca
from mjregen.growth.nca import NCAConfig, grow
from mjregen.search.backends import SerialBackend
from mjregen.search.ga import GAConfig
from mjregen.search.run_folder import read_progress
from mjregen.search.runs import RunFolderError, run_evolution
from mjregen.tasks.evaluation import PopulationEvaluation

GA = GAConfig(population=12, generations=6, truncation=4, elites=2, sigma=0.05)


class SphereTask:
    """Fitness = -|genome - 0.05|² (cheap, deterministic); robots grown for real (2D)."""

    nca = NCAConfig(dim=2, kind="ff")

    def to_config(self):
        return {"task": "sphere"}

    def evaluate(self, genomes, backend):
        fitness = -((genomes.astype(np.float64) - 0.05) ** 2).sum(axis=1)
        grids = grow(self.nca, genomes).grids
        return PopulationEvaluation(fitness=fitness, grids=grids,
                                    details={"voxels": np.count_nonzero(grids.reshape(len(grids), -1), axis=1)})


class Killed(Exception):
    pass


def run(out, **kwargs):
    return run_evolution(SphereTask(), GA, seed=3, out=out, backend=SerialBackend(),
                         progress=False, **kwargs)


def metrics(out):
    with open(out / "metrics.csv") as handle:
        return list(csv.DictReader(handle))


def test_run_folder_contents(tmp_path):
    out = tmp_path / "run"
    summary = run(out)
    rows = metrics(out)
    assert [int(r["generation"]) for r in rows] == list(range(6))
    best = [float(r["best"]) for r in rows]
    assert all(b2 >= b1 for b1, b2 in zip(best, best[1:]))  # elites kept, fitness deterministic
    assert summary.best_fitness == pytest.approx(best[-1], rel=1e-5)
    config = json.loads((out / "config.json").read_text())
    assert config["ga"]["population"] == 12 and config["seed"] == 3
    for g in range(6):
        nca, meta = load_nca(out / "best" / f"gen_{g:04d}.npz")
        assert meta["generation"] == g and meta["fitness"] == pytest.approx(best[g], rel=1e-5)
        assert Robot.load(out / "best" / f"gen_{g:04d}.npy") == nca.grow().robot()
    assert (out / "fitness.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "checkpoint.npz").is_file()


def test_a_runs_progress_is_its_listed_generations_and_their_wall_time(tmp_path):
    out = tmp_path / "run"
    run(out)
    listed = (out / "metrics.csv").read_text().splitlines()
    progress = read_progress(out)
    assert (progress.counter, progress.done, progress.planned, progress.complete) == (
        "generation", 6, 6, True)
    assert progress.elapsed == float(metrics(out)[-1]["elapsed"]) > 0
    (out / "metrics.csv").write_text("\n".join(listed + [listed[-1].replace("5,", "6,", 1)]))
    assert read_progress(out).done == 6  # a row beyond the plan is not a step done
    (out / "metrics.csv").write_text("\n".join(listed[:4]) + "\n")  # a killed run's
    progress = read_progress(out)
    assert (progress.done, progress.complete) == (3, False)
    assert progress.elapsed == float(metrics(out)[-1]["elapsed"])
    (out / "metrics.csv").unlink()
    assert (read_progress(out).done, read_progress(out).elapsed) == (0, 0.0)
    config = json.loads((out / "config.json").read_text())
    del config["ga"]
    (out / "config.json").write_text(json.dumps(config))
    with pytest.raises(RunFolderError, match="names no optimiser"):
        read_progress(out)
    with pytest.raises(RunFolderError, match="not a readable run configuration"):
        read_progress(tmp_path / "nothing")


def test_resume_after_a_kill_equals_an_uninterrupted_run(tmp_path):
    full = run(tmp_path / "full")

    def kill_after_generation_2(row):
        if row["generation"] == 2:
            raise Killed

    with pytest.raises(Killed):
        run(tmp_path / "killed", on_generation=kill_after_generation_2)
    assert len(metrics(tmp_path / "killed")) == 3
    resumed = run(tmp_path / "killed", resume=True)
    assert np.array_equal(resumed.best_genome, full.best_genome)
    keys = ("generation", "best", "mean", "median", "std")
    assert [[r[k] for k in keys] for r in metrics(tmp_path / "killed")] == \
           [[r[k] for k in keys] for r in metrics(tmp_path / "full")]
    for g in range(6):
        a = load_nca(tmp_path / "full" / "best" / f"gen_{g:04d}.npz")[0].genome
        b = load_nca(tmp_path / "killed" / "best" / f"gen_{g:04d}.npz")[0].genome
        assert np.array_equal(a, b)


def test_existing_runs_are_never_overwritten(tmp_path):
    out = tmp_path / "run"
    run(out)
    before = (out / "metrics.csv").read_bytes()
    with pytest.raises(RunFolderError, match="not empty"):
        run(out)
    assert (out / "metrics.csv").read_bytes() == before
    with pytest.raises(RunFolderError, match="different settings"):
        run_evolution(SphereTask(), GA, seed=4, out=out, backend=SerialBackend(),
                      progress=False, resume=True)
    with pytest.raises(RunFolderError, match="nothing to resume"):
        run(tmp_path / "empty", resume=True)
    run(out, force=True)
    assert len(metrics(out)) == 6
