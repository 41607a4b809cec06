#!/usr/bin/env python3
"""Keep the records of GA run folders in records/results/ (tracked in git).

A record holds what a resume needs of an unfinished run and what the results report needs of
a finished one.

What is copied of a run ``runs/results/<condition>/seed_<n>``: config.json, metrics.csv,
every generation's best robot (best/gen_NNNN.npy), the best generation's NCA
(best/gen_NNNN.npz) and, while the run is unfinished, checkpoint.npz. A finished run's
record has no checkpoint: resuming it returns its summary at once
(`mjregen.search.runs.run_evolution`). The copy replaces the run's earlier record.

Example: python scripts/snapshot_runs.py runs/results/3d_lstm/seed_0 runs/results/3d_ff/seed_0
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

from mjregen.experiments.paper import read_run

ROOT = Path(__file__).resolve().parents[1]
DESTINATION = ROOT / "records" / "results"


def snapshot(run: Path, destination: Path = DESTINATION) -> Path:
    """Copy the record of `run` to destination/<condition>/<seed folder>; returns it.

    Raises:
      FileNotFoundError: `run` has no config.json, an unfinished run has no checkpoint.npz,
        or a finished run has no generation done.
    """
    info = read_run(run)
    if not info.generations_done:
        raise FileNotFoundError(f"{run} has no generation in metrics.csv: nothing to keep")
    names = ["config.json", "metrics.csv"]
    if not info.complete:
        if not (run / "checkpoint.npz").is_file():
            raise FileNotFoundError(f"{run} has no checkpoint.npz: nothing to resume")
        names.append("checkpoint.npz")
    target = destination / run.parent.name / run.name
    staging = target.with_name(target.name + ".partial")
    shutil.rmtree(staging, ignore_errors=True)
    (staging / "best").mkdir(parents=True)
    for name in names:
        shutil.copy2(run / name, staging / name)
    for robot in sorted((run / "best").glob("gen_*.npy")):
        shutil.copy2(robot, staging / "best" / robot.name)
    nca, _ = info.best_files()
    shutil.copy2(nca, staging / "best" / nca.name)
    shutil.rmtree(target, ignore_errors=True)
    staging.rename(target)
    return target


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run folders to keep")
    args = parser.parse_args(argv)
    for run in args.runs:
        try:
            target = snapshot(run)
        except FileNotFoundError as error:
            print(f"error: {error}", file=sys.stderr)
            return 2
        info = read_run(target)
        state = "finished" if info.complete else "resumable"
        print(f"{run} -> {target.relative_to(ROOT)} ({state}): {info.generations_done} of "
              f"{info.generations_planned} generations, best {info.best_fitness:.4g} "
              f"(generation {info.best_generation})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
