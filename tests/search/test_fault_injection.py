"""A run killed (SIGKILL) at random moments, writes included, and resumed each time ends
exactly as the uninterrupted run does."""

import multiprocessing
import os
import signal
import time

import numpy as np
from test_runs import GA, SphereTask, metrics  # the same tiny task

from mjregen.growth.checkpoint import load_nca
from mjregen.search.backends import SerialBackend
from mjregen.search.run_folder import WRITE_DEBRIS
from mjregen.search.runs import run_evolution

KILLS = 20
COLUMNS = ("generation", "best", "mean", "median", "std")
LONGER = GA.with_overrides(generations=12)


def run(out, **kwargs):
    return run_evolution(SphereTask(), LONGER, seed=3, out=out, backend=SerialBackend(),
                         progress=False, **kwargs)


def _slow_writes_then_run(out: str, resume: bool, force: bool) -> None:
    """The child: every atomic write's rename waits 3 ms (so kills land inside writes too),
    then the run."""
    replace = os.replace

    def slow_replace(source, target):
        time.sleep(0.003)
        replace(source, target)

    os.replace = slow_replace
    run(out, resume=resume, force=force)


# Children come from a fork server: a fresh interpreter with mjregen imported and no threads,
# instead of forks of this test process, which by then holds the threads that earlier tests
# started (8 OS threads after tests/experiments, faces and growth): a fork copies their
# locks and state but not the threads. The server imports mjregen's modules once, before
# any child (and pytest, which the children's import of this module needs).
FORK_SERVER = multiprocessing.get_context("forkserver")
FORK_SERVER.set_forkserver_preload(["pytest", "mjregen.grid", "mjregen.growth.checkpoint",
                                    "mjregen.search.backends", "mjregen.search.runs"])


def start(out) -> multiprocessing.Process:
    resume = (out / "config.json").is_file()
    force = not resume and out.exists()  # killed before config.json was ever written
    process = FORK_SERVER.Process(
        target=_slow_writes_then_run, args=(str(out), resume, force))
    process.start()
    return process


def finish(out) -> None:
    process = start(out)
    process.join(timeout=300)
    assert process.exitcode == 0


def same_run(out, full) -> bool:
    final = LONGER.generations - 1
    return ([[r[k] for k in COLUMNS] for r in metrics(out)]
            == [[r[k] for k in COLUMNS] for r in metrics(full)]
            and np.array_equal(load_nca(out / "best" / f"gen_{final:04d}.npz")[0].genome,
                               load_nca(full / "best" / f"gen_{final:04d}.npz")[0].genome))


def test_twenty_random_kills_each_resumed_give_the_uninterrupted_run(tmp_path):
    full = tmp_path / "full"
    warm_up = FORK_SERVER.Process(target=int)  # the server starts outside the timed run
    warm_up.start()
    warm_up.join()
    began = time.perf_counter()
    finish(full)
    duration = time.perf_counter() - began
    rng = np.random.default_rng(0)
    killed = []
    for trial in range(KILLS):
        out = tmp_path / f"trial_{trial}"
        process = start(out)
        process.join(timeout=rng.uniform(0.0, duration))
        if process.exitcode is None:
            os.kill(process.pid, signal.SIGKILL)
            process.join()
            killed.append(len(metrics(out)) if (out / "metrics.csv").is_file() else 0)
        finish(out)
        assert same_run(out, full), f"trial {trial}"
        leftovers = [p.name for p in (*out.iterdir(), *(out / "best").iterdir())
                     if WRITE_DEBRIS.match(p.name)]
        assert not leftovers, f"trial {trial}: {leftovers}"  # a resume clears killed writes
    assert len(killed) >= KILLS // 2 and len(set(killed)) >= 3  # at several points of the run
