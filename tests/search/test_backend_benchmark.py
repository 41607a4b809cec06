"""`benchmarks/evolution.py backends`: each timing simulates, whatever the task remembers."""

from __future__ import annotations

import numpy as np

from mjregen.growth.nca import NCAConfig
from mjregen.growth.networks import random_genomes
from mjregen.search.backends import make_backend
from mjregen.tasks.locomotion import LocomotionTask

from repo_modules import load_module

evolution = load_module("benchmarks/evolution.py")


def test_a_backend_timing_simulates_robots_the_task_already_scored():
    task = LocomotionTask(nca=NCAConfig(dim=3, kind="ff"), duration=0.01)
    genomes = random_genomes(task.nca, 3, seed=0)
    with make_backend("serial") as backend:
        first = task.evaluate(genomes, backend)  # the task now remembers these robots
    for name in ("serial", "thread"):
        sample, fitness = evolution._time_backend(task, genomes, name)
        assert np.array_equal(fitness, first.fitness)
        assert sample["simulation_cpu_s"] > 0 and sample["distinct_robots"] == first.n_distinct
        assert sample["workers"] == (1 if name == "serial" else 2)


def test_the_machines_busy_time_holds_this_process_cpu_time():
    """Other work = the machine's busy CPU less this process's: the first holds the second."""
    import time

    before = evolution._cpu_seconds()
    end = time.process_time() + 0.5
    while time.process_time() < end:  # 0.5 CPU s of this process
        pass
    busy, own, wall = (after - start for after, start in zip(evolution._cpu_seconds(), before))
    assert own >= 0.5 and busy >= 0.9 * own and wall > 0


def test_a_median_difference_is_claimed_only_when_one_backend_wins_every_round():
    def measured(process, thread):
        rows = [("serial", 1, [36.0, 35.0, 36.0]), ("process", 2, process), ("thread", 2, thread)]
        return {"other_work_cores": 0.4,
                "rows": [{"backend": b, "workers": w, "wall_s_rounds": rounds}
                         for b, w, rounds in rows]}

    mixed = evolution._backends_verdict(measured([28.8, 18.1, 36.3], [20.5, 18.8, 37.5]))
    assert "process 18.1 s (efficiency 0.97)" in mixed and "thread 18.8 s" in mixed
    assert "Neither was faster in every round (process in 2 of 3)" in mixed
    clear = evolution._backends_verdict(measured([20.0, 21.0, 22.0], [19.0, 20.0, 21.0]))
    assert "Thread was faster than process in every round (3)." in clear
