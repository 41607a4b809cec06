#!/usr/bin/env python3
"""Keep the records of results run folders in records/results/ (tracked in git).

A record holds what a resume needs of an unfinished run and what the results report needs of
a finished one. Of a GA run ``runs/results/<condition>/seed_<n>`` (an evolution, or a
regrowth ``regen_<walker>_<net>/seed_<n>``): config.json, metrics.csv, every generation's best
robot (best/gen_NNNN.npy), the best generation's NCA (best/gen_NNNN.npz), a regrowth's
recovery files (recovery.json, recovery.md, regrowth.npz, original/damaged/regrown.npy) and,
while the run is unfinished, checkpoint.npz. A finished run's record has no checkpoint:
resuming it returns its summary at once (`mjregen.search.runs.run_evolution`). Of the
regrowth experiment's walkers (``runs/results/walkers``): walkers.json and their NCAs and
robots. The copy replaces the earlier record.

Example: python scripts/snapshot_runs.py runs/results/3d_lstm/seed_0 runs/results/walkers
"""

from __future__ import annotations

import argparse
import shutil
import sys
from collections.abc import Callable
from pathlib import Path

from mjregen.experiments.paper import read_run

ROOT = Path(__file__).resolve().parents[1]
DESTINATION = ROOT / "records" / "results"
RECOVERY_FILES = ("recovery.json", "recovery.md", "regrowth.npz", "original.npy", "damaged.npy",
                  "regrown.npy")


def _replace(target: Path, fill: Callable[[Path], None]) -> Path:
    """Fill a staging folder beside `target`, then put it in `target`'s place."""
    staging = target.with_name(target.name + ".partial")
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir(parents=True)
    fill(staging)
    shutil.rmtree(target, ignore_errors=True)
    staging.rename(target)
    return target


def snapshot_walkers(folder: Path, destination: Path = DESTINATION) -> Path:
    """Copy the walkers folder (walkers.json, walker_<i>.npz/.npy) to destination/<its
    name>; returns it."""
    def fill(staging: Path) -> None:
        for path in sorted(folder.glob("walker*")):
            shutil.copy2(path, staging / path.name)
    return _replace(destination / folder.name, fill)


def snapshot(run: Path, destination: Path = DESTINATION) -> Path:
    """Copy the record of the GA run `run` to destination/<its parent's name>/<its name>;
    returns it.

    Raises:
      FileNotFoundError: `run` has no config.json or no generation done, or an unfinished
        run has no checkpoint.npz.
    """
    info = read_run(run)
    if not info.generations_done:
        raise FileNotFoundError(f"{run} has no generation in metrics.csv: nothing to keep")
    names = ["config.json", "metrics.csv"]
    if not info.complete:
        if not (run / "checkpoint.npz").is_file():
            raise FileNotFoundError(f"{run} has no checkpoint.npz: nothing to resume")
        names.append("checkpoint.npz")
    names += [name for name in RECOVERY_FILES if (run / name).is_file()]
    nca, _ = info.best_files()

    def fill(staging: Path) -> None:
        (staging / "best").mkdir()
        for name in names:
            shutil.copy2(run / name, staging / name)
        for robot in sorted((run / "best").glob("gen_*.npy")):
            shutil.copy2(robot, staging / "best" / robot.name)
        shutil.copy2(nca, staging / "best" / nca.name)
    return _replace(destination / run.parent.name / run.name, fill)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path,
                        help="run folders (or the walkers folder) to keep")
    args = parser.parse_args(argv)
    for run in args.runs:
        try:
            if (run / "walkers.json").is_file():
                print(f"{run} -> {snapshot_walkers(run).relative_to(ROOT)}")
                continue
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
