#!/usr/bin/env python3
"""Copy what a resume needs of unfinished GA run folders into resume/results/ (tracked in git).

What is copied of a run ``runs/results/<condition>/seed_<n>``: config.json, checkpoint.npz,
metrics.csv, every generation's best robot (best/gen_NNNN.npy) and the best generation's NCA
(best/gen_NNNN.npz). The copy replaces the run's earlier snapshot. A finished run is refused:
ship its results instead (scripts/ship_assets.py).

Example: python scripts/snapshot_runs.py runs/results/3d_lstm/seed_0
"""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

from mjregen.experiments.paper import read_run

ROOT = Path(__file__).resolve().parents[1]
DESTINATION = ROOT / "resume" / "results"


def snapshot(run: Path, destination: Path = DESTINATION) -> Path:
    """Copy the resumable state of `run` to destination/<condition>/<seed folder>; returns it.

    Raises:
      FileNotFoundError: `run` has no config.json or no checkpoint.npz.
      ValueError: the run is finished.
    """
    info = read_run(run)
    if not (run / "checkpoint.npz").is_file():
        raise FileNotFoundError(f"{run} has no checkpoint.npz: nothing to resume")
    if info.complete:
        raise ValueError(f"{run} is finished ({info.generations_done} generations): ship it "
                         "with scripts/ship_assets.py instead of keeping its state")
    target = destination / run.parent.name / run.name
    staging = target.with_name(target.name + ".partial")
    shutil.rmtree(staging, ignore_errors=True)
    (staging / "best").mkdir(parents=True)
    for name in ("config.json", "checkpoint.npz", "metrics.csv"):
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
    parser.add_argument("runs", nargs="+", type=Path, help="run folders to snapshot")
    args = parser.parse_args(argv)
    for run in args.runs:
        try:
            target = snapshot(run)
        except (FileNotFoundError, ValueError) as error:
            print(f"error: {error}", file=sys.stderr)
            return 2
        info = read_run(target)
        print(f"{run} -> {target.relative_to(ROOT)}: {info.generations_done} of "
              f"{info.generations_planned} generations, best {info.best_fitness:.4g} "
              f"(generation {info.best_generation})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
