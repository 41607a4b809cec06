"""Does a robot's walk transfer? mjregen from several starts and orientations, beside the
paper's engine.

    python benchmarks/transfer.py --voxelyze DIR [ROBOT ...] [--starts 10] [--assets assets]
        [--best-of ROOT] [--json out.json]

DIR holds the paper's engine with its runner ``vxa.py`` (``vxa.py ROBOT.npy`` prints
``{"distance": voxel lengths, ...}``). ROBOT: a robot file (.npy), or ``NAME=PATH`` to
name it. Each robot is walked in mjregen
  - from ``--starts`` starts of seed 0 (indices 0 ..; ``mjregen walk --starts N``): their
    mean is its distance,
  - from as many fresh starts (seed 1),
  - with its grid rotated by 90, 180 and 270 degrees about z (start 0 each; 2D: mirrored),
  - from the exact start (start shift 0: every voxel on its grid position, what every
    evolution scored before the start shift),
  - from the same ``--starts`` starts with half the physics' time step (a walk that the
    integration makes changes with the step; the same starts, so that the spread between
    starts is not taken for it),
and in the paper's engine for the same settle and walk (3D grids: a 2D run's robots are
sheets, 3D grids, walked for the 2D times; a 2D grid in the x-z plane is not run there), by
`mjregen.validation.transfer.measure_transfer`. ``--settle`` and ``--duration`` set the times of
the ROBOTs given (a sheet of a 2D run: ``--settle 1 --duration 0.25``); ``--best-of`` and
``--assets`` take each robot's own. A robot transfers (`TRANSFER_RULE`) when the
fresh starts, the rotations and the finer step keep >= 90 % of its distance on average and
the engine walks it >= 80 % as far.

``--best-of ROOT`` also measures each condition's best robot of the evolution runs under ROOT
(`mjregen.experiments.paper.best_robots`), named by its path relative to ROOT; written with
``--json ROOT/transfer.json``, scripts/results_report.py shows them beside each condition's
best run (``--best-of records/paper --json records/paper/transfer.json``).

``--each-run ROOT`` also measures the best robot of every finished run under ROOT
(`mjregen.experiments.paper.finished_runs_robots`), named the same way, leaving out those
already in the ``--json`` file: the report counts, per condition, the runs whose best robot
transfers. ``--json`` keeps the entries of the file for robots not measured again.

``--table1 ROOT`` also walks in the engine the original, damaged and regrown robot of every
finished regrowth run under ROOT/table1 not yet in ROOT/table1_engine.json, and adds them
there (`mjregen.experiments.table1.measure_in_engine`; scripts/results_report.py shows them
beside the runs' own distances).

``--grow-regrow ROOT`` also walks in the engine the grown robot of the best NCA of every
finished grow-regrow run (ROOT/grow_regrow_*) and 3D growth-only run (ROOT/3d_*), the
paper's cut of it and what the same NCA regrows from the cut, into
ROOT/grow_regrow_engine.json (`mjregen.experiments.self_regrowth.measure_in_engine`).

``--assets DIR`` also measures every evolved walker the package ships (``DIR/nca/
manifest.json``, ``DIR/robots/walkers/walkers.json``) and writes each one's measurements,
the rule and the verdict into its manifest entry as "transfer" (`tests/test_assets.py`
checks the mjregen side of them).
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict
from pathlib import Path

import numpy as np

from mjregen.cli.common import add_engine_robot_arguments, named_paths
from mjregen.errors import MjregenError
from mjregen.fileio import atomic_open
from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.tasks.bodies import body_physics
from mjregen.validation.engine import PaperEngine
from mjregen.validation.transfer import (FINER_STEP, Transfer, measure_transfer,
                                         read_measurements, transfer_record)


def _cell(value: float | None, digits: int = 2) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def _spread(values: list[float]) -> str:
    return f"{np.mean(values):.2f} ({min(values):.2f}-{max(values):.2f})"


def markdown(rows: list[Transfer], starts: int) -> str:
    """The table of docs/transfer.md."""
    lines = [f"| robot | voxels | mirror plane | distance: {starts} starts, mean (min-max) | "
             f"{starts} fresh starts | kept | rotated 90/180/270 | kept | exact start | "
             f"step × {FINER_STEP:g}, the same starts | kept | paper's engine | engine / distance | transfers |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r.name} | {r.voxels} | {', '.join(r.mirror_axes) or 'none'} | "
            f"{_spread(r.starts)} | {_spread(r.fresh)} | {r.fresh_kept:.0%} | "
            f"{' / '.join(f'{d:.2f}' for d in r.rotated)} | {r.rotated_kept:.0%} | "
            f"{r.exact:.2f} | {_spread(r.finer_step)} | {r.finer_step_kept:.0%} | "
            f"{_cell(r.engine)} | {_cell(r.engine_ratio)} | "
            f"{'yes' if r.transfers else 'no'} |")
    return "\n".join(lines)


def shipped_walkers(assets: Path) -> list[tuple[str, Path, Path, list, Physics]]:
    """(name, robot file, manifest file, path of the entry in the manifest, the physics it
    walks in: the default, for a sheet's times) of every evolved walker under `assets`
    (placeholders left out)."""
    found = []
    manifest = assets / "nca" / "manifest.json"
    for key, entry in json.loads(manifest.read_text()).items():
        if not entry.get("placeholder") and "robot_file" in entry:
            body = entry.get("evaluation", {}).get("body", "grid")
            found.append((Path(key).stem, manifest.parent / entry["robot_file"], manifest, [key],
                          body_physics(Physics(), body)))
    walkers = assets / "robots" / "walkers" / "walkers.json"
    for i, entry in enumerate(json.loads(walkers.read_text())["walkers"]):
        found.append((entry["name"], walkers.parent / entry["robot_file"], walkers,
                      ["walkers", i], Physics()))
    return found


def record(manifest: Path, where: list, row: Transfer, starts: int, physics: Physics) -> None:
    """Write `row` into the manifest entry at `where` as its "transfer" block."""
    from mjregen.fileio import atomic_open

    content = json.loads(manifest.read_text())
    entry = content
    for step in where:
        entry = entry[step]
    entry["transfer"] = {**transfer_record(row, starts, physics),
                         "command": "python benchmarks/transfer.py --voxelyze DIR --assets assets"}
    with atomic_open(manifest, "w", overwrite=True) as handle:
        json.dump(content, handle, indent=2)
        handle.write("\n")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_engine_robot_arguments(parser, nargs="*")
    parser.add_argument("--starts", type=int, default=10)
    parser.add_argument("--settle", type=float,
                        help="s of settle of the ROBOTS given (default: the paper's for their "
                             "dimension; a 2D run's sheet: 1)")
    parser.add_argument("--duration", type=float,
                        help="s of walking measured of the ROBOTS given (default: the "
                             "paper's; a 2D run's sheet: 0.25)")
    parser.add_argument("--assets", type=Path,
                        help="also measure the shipped walkers and record them (docstring)")
    parser.add_argument("--best-of", type=Path, metavar="ROOT",
                        help="also measure each condition's best robot of the runs under ROOT")
    parser.add_argument("--each-run", type=Path, metavar="ROOT",
                        help="also measure the best robot of every finished run under ROOT "
                             "not yet in --json")
    parser.add_argument("--table1", type=Path, metavar="ROOT",
                        help="also walk the robots of the regrowth runs under ROOT/table1 "
                             "in the engine, into ROOT/table1_engine.json")
    parser.add_argument("--grow-regrow", type=Path, metavar="ROOT",
                        help="also walk the grown, damaged and regrown robots of the best NCA "
                             "of every finished grow-regrow and 3D run under ROOT in the "
                             "engine, into ROOT/grow_regrow_engine.json")
    parser.add_argument("--json", type=Path,
                        help="write the measurements here (entries of other robots kept)")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        kept = read_measurements(args.json) if args.json is not None else {}
        given_robots = named_paths(args.robots)
    except ValueError as error:
        parser.error(str(error))
    given = Physics().replace(settle_time=args.settle, measured_time=args.duration)
    todo = [(name, path, None, None, given) for name, path in given_robots]
    from mjregen.experiments.paper import best_robots, finished_runs_robots

    for root, pick, new_only in ((args.best_of, best_robots, False),
                                 (args.each_run, finished_runs_robots, True)):
        if root is not None:  # --each-run leaves out the robots --json already holds
            found = pick(root)
            if not found:
                parser.error(f"{root}: no {'finished ' if new_only else ''}evolution runs there")
            named = {name for name, *_ in todo}
            todo += [(name, path, None, None, physics) for name, (path, physics) in found.items()
                     if name not in named and not (new_only and name in kept)]
    if args.assets is not None:
        todo += shipped_walkers(args.assets)
    try:
        engine = PaperEngine(args.voxelyze)
    except MjregenError as error:
        parser.error(str(error))
    from mjregen.experiments import self_regrowth, table1

    for root, measure in ((args.table1, table1.measure_in_engine),
                          (args.grow_regrow, self_regrowth.measure_in_engine)):
        if root is not None:
            measure(root, engine)
    rows = []
    for name, path, manifest, where, physics in todo:
        rows.append(measure_transfer(Robot.load(path), name=name, starts=args.starts,
                                     engine=engine, physics=physics))
        if manifest is not None:
            record(manifest, where, rows[-1], args.starts, physics)
        print(markdown(rows[-1:], args.starts).splitlines()[-1], flush=True)
    if rows:
        print(markdown(rows, args.starts))
    if args.json is not None:
        kept.update((r.name, asdict(r) | {"distance": r.distance, "transfers": r.transfers})
                    for r in rows)
        with atomic_open(args.json, "w") as handle:  # the kept entries survive a failure
            json.dump(list(kept.values()), handle, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
