#!/usr/bin/env python3
"""Keep the records of results run folders in records/ (tracked in git).

A record holds what a resume needs of an unfinished run and what the results report needs of
a finished one. Of a GA run ``runs/results/<condition>/seed_<n>`` (an evolution, or a
regrowth ``regen_<walker>_<net>/seed_<n>``): config.json, metrics.csv, every generation's best
robot (best/gen_NNNN.npy), the best generation's NCA (best/gen_NNNN.npz; `best_ncas`), a
regrowth's recovery files (recovery.json, recovery.md, regrowth.npz, original/damaged/
regrown.npy) and, while the run is unfinished, checkpoint.npz and the last finished
generation's NCA (a resume checks that it is there). A finished run's record has no
checkpoint: resuming it returns its summary at once (`mjregen.search.runs.run_evolution`). Of
the regrowth experiment's walkers (``runs/results/walkers``): walkers.json and their NCAs and
robots. Of a quality-diversity comparison's run (``runs/qd/<method>/seed_<n>``, a folder with
``evaluations/``), into records/qd/: a GA run as above, a MAP-Elites run with its
config.json, metrics.csv, best.npz/.npy and, while unfinished, checkpoint.npz
(`mjregen.search.qd_runs.run_map_elites` resumes a finished record to its summary), each
with every recorded evaluation, from which the comparison's report places its archive
(the archive.npz of a run, every elite's genome, megabytes, is left out). The copy
replaces the earlier record. ``--into`` keeps runs of another results root elsewhere (the
runs of ``runs/paper``: ``--into records/paper``). ``--keep-after S`` leaves out the
unfinished runs whose steps so far took less than S seconds, and those not started: a young
run's checkpoint (up to 22 MB) costs git more than running its steps again.

Examples:
  python scripts/snapshot_runs.py runs/results/3d_lstm/seed_0 runs/results/walkers
  python scripts/snapshot_runs.py --into records/paper --keep-after 1800 runs/paper/3d_ff/seed_*
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

from mjregen.experiments.paper import RunInfo, read_run
from mjregen.growth.checkpoint import load_nca
from mjregen.search.run_folder import RunFolderError, read_progress

ROOT = Path(__file__).resolve().parents[1]
DESTINATION = ROOT / "records" / "results"
QD_DESTINATION = ROOT / "records" / "qd"
RECOVERY_FILES = ("recovery.json", "recovery.md", "regrowth.npz", "original.npy", "damaged.npy",
                  "regrown.npy")
MAP_ELITES_FILES = ("config.json", "metrics.csv", "best.npz", "best.npy")


def _replace(target: Path, fill: Callable[[Path], None]) -> Path:
    """Fill a staging folder beside `target`, then put it in `target`'s place by renames:
    until the new record is complete the earlier one is untouched, and at every moment one
    of them is whole on disk (the earlier one, moved aside, is deleted last)."""
    staging = target.with_name(target.name + ".partial")
    previous = target.with_name(target.name + ".previous")
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir(parents=True)
    fill(staging)
    if previous.exists() and target.exists():
        shutil.rmtree(previous)  # left by an interrupted swap whose new record is in place
    if target.exists():
        target.rename(previous)
    staging.rename(target)
    shutil.rmtree(previous, ignore_errors=True)
    return target


def snapshot_walkers(folder: Path, destination: Path = DESTINATION) -> Path:
    """Copy the walkers folder (walkers.json, walker_<i>.npz/.npy) to destination/<its
    name>; returns it."""
    def fill(staging: Path) -> None:
        for path in sorted(folder.glob("walker*")):
            shutil.copy2(path, staging / path.name)
    return _replace(destination / folder.name, fill)


def _copy_evaluations(run: Path, staging: Path) -> None:
    """A quality-diversity run's recorded evaluations (evaluations/NNNN.npz), if any."""
    if (run / "evaluations").is_dir():
        shutil.copytree(run / "evaluations", staging / "evaluations")


def is_map_elites(run: Path) -> bool:
    """Does `run` hold a MAP-Elites run (its config.json has "map_elites")?"""
    path = run / "config.json"
    return path.is_file() and "map_elites" in json.loads(path.read_text())


def snapshot_map_elites(run: Path, destination: Path = QD_DESTINATION) -> Path:
    """Copy the record of the MAP-Elites run `run` (`MAP_ELITES_FILES`, evaluations/ and,
    while unfinished, checkpoint.npz) to destination/<its parent's name>/<its name>; returns
    it.

    Raises:
      FileNotFoundError: `run` lacks one of `MAP_ELITES_FILES`, or is unfinished without
        its checkpoint.
    """
    missing = [name for name in MAP_ELITES_FILES if not (run / name).is_file()]
    if missing:
        raise FileNotFoundError(f"{run} has no {', '.join(missing)}: not a MAP-Elites run "
                                "with an iteration done")
    names = list(MAP_ELITES_FILES)
    if not read_progress(run).complete:
        if not (run / "checkpoint.npz").is_file():
            raise FileNotFoundError(f"{run} has no checkpoint.npz: nothing to resume")
        names.append("checkpoint.npz")

    def fill(staging: Path) -> None:
        for name in names:
            shutil.copy2(run / name, staging / name)
        _copy_evaluations(run, staging)
    return _replace(destination / run.parent.name / run.name, fill)


def best_ncas(info: RunInfo) -> list[Path]:
    """The NCA files a record keeps: the first generation's listed with the highest fitness
    (the report's best) and, where a later one of those (metrics.csv rounds to 6 digits) has a
    higher fitness in its file, the first with the highest (the run's best, which a resume of
    the finished record reads).

    A run resumed from its record lacks the NCA files that the record left out: those of the
    later generations tied with the first are skipped (none beat it, or the record would
    have kept it); the first generation's file must be there.

    Raises:
      FileNotFoundError: the first best generation's NCA file is missing.
    """
    kept, top = [], -math.inf
    for index, generation in enumerate(np.flatnonzero(info.best == info.best.max())):
        path, _ = info.best_files(int(generation))
        if index and not path.is_file():
            continue
        fitness = float(load_nca(path)[1]["fitness"])
        if fitness > top:
            kept.append(path)
            top = fitness
    return kept[:1] + kept[-1:] if len(kept) > 1 else kept


def snapshot(run: Path, destination: Path = DESTINATION) -> Path:
    """Copy the record of the GA run `run` (with evaluations/ if it has them) to
    destination/<its parent's name>/<its name>; returns it.

    Raises:
      FileNotFoundError: `run` has no config.json or no generation done, or an unfinished
        run has no checkpoint.npz.
    """
    info = read_run(run)
    if not info.generations_done:
        raise FileNotFoundError(f"{run} has no generation in metrics.csv: nothing to keep")
    names = ["config.json", "metrics.csv"]
    ncas = best_ncas(info)
    if not info.complete:
        if not (run / "checkpoint.npz").is_file():
            raise FileNotFoundError(f"{run} has no checkpoint.npz: nothing to resume")
        names.append("checkpoint.npz")
        last, _ = info.best_files(info.generations_done - 1)  # a resume checks it is there
        ncas = sorted({*ncas, last})
    names += [name for name in RECOVERY_FILES if (run / name).is_file()]

    def fill(staging: Path) -> None:
        (staging / "best").mkdir()
        for name in names:
            shutil.copy2(run / name, staging / name)
        for robot in sorted((run / "best").glob("gen_*.npy")):
            shutil.copy2(robot, staging / "best" / robot.name)
        for nca in ncas:
            shutil.copy2(nca, staging / "best" / nca.name)
        _copy_evaluations(run, staging)
    return _replace(destination / run.parent.name / run.name, fill)


def _too_young(run: Path, keep_after: float) -> bool:
    """Is `run` unfinished with its steps so far taking less than `keep_after` s (says so)?"""
    progress = read_progress(run)
    if progress.complete or progress.elapsed >= keep_after:
        return False
    print(f"{run}: left out, {progress.done} of {progress.planned} {progress.counter}s in "
          f"{progress.elapsed:.0f} s (--keep-after {keep_after:g})")
    return True


def _shown(path: Path) -> Path:
    """`path` relative to the repository when inside it."""
    return path.relative_to(ROOT) if path.is_relative_to(ROOT) else path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path,
                        help="run folders (or the walkers folder) to keep")
    parser.add_argument("--into", type=Path,
                        help=f"records folder (default: {DESTINATION.relative_to(ROOT)}, and "
                             f"{QD_DESTINATION.relative_to(ROOT)} for quality-diversity runs)")
    parser.add_argument("--keep-after", type=float, metavar="S",
                        help="leave out unfinished runs whose steps took less than S seconds "
                             "of wall time, and runs not started (default: keep every run)")
    args = parser.parse_args(argv)
    into = None if args.into is None else args.into.resolve()
    for run in args.runs:
        try:
            if (run / "walkers.json").is_file():
                print(f"{run} -> {_shown(snapshot_walkers(run, into or DESTINATION))}")
                continue
            if args.keep_after is not None and _too_young(run, args.keep_after):
                continue
            if is_map_elites(run):
                print(f"{run} -> {_shown(snapshot_map_elites(run, into or QD_DESTINATION))}")
                continue
            target = snapshot(run, into or (QD_DESTINATION if (run / "evaluations").is_dir()
                                            else DESTINATION))
        except (FileNotFoundError, RunFolderError) as error:
            print(f"error: {error}", file=sys.stderr)
            return 2
        info = read_run(target)
        state = "finished" if info.complete else "resumable"
        print(f"{run} -> {_shown(target)} ({state}): {info.generations_done} of "
              f"{info.generations_planned} generations, best {info.best_fitness:.4g} "
              f"(generation {info.best_generation})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
