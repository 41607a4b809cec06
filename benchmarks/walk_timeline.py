"""Where a robot's walks in mjregen and in the paper's engine part: distance, its y component
and voxels on the floor at several times, side by side.

    python benchmarks/walk_timeline.py --voxelyze DIR ROBOT.npy|NAME=ROBOT.npy ...
        [--times 0.1 0.2 0.3 0.4 0.55] [--start-shift S] [--json out.json]

(the robots before --times, which takes every number after it)

Times are seconds from the start, the paper's 3D settle (0.05 s) included; distances in
voxel lengths from the centre of mass at the end of the settle, as the fitness measures
them (`mjregen.validation.timeline`). mjregen walks from its exact start by default, as the
engine does (``--start-shift`` gives the scene's shift, e.g. 0.01, the fitness's start 0).
A robot whose voxels on the floor jump at some time fell over then: if the two simulators
agree until then and part after, the distance is decided by how it falls.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mjregen.cli.common import add_engine_robot_arguments, named_paths
from mjregen.errors import MjregenError
from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.validation.engine import PaperEngine
from mjregen.validation.timeline import engine_timeline, mjregen_timeline


def markdown(name: str, mine: list, theirs: list) -> str:
    """One robot's table: a row per time, mjregen's columns then the engine's."""
    lines = [f"\n{name}\n", "| t (s) | mjregen distance | dy | on floor | COM height "
             "| engine distance | dy | on floor |", "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {a.time:g} | {a.distance:.2f} | {a.dy:.2f} | {a.on_floor} | {a.height:.2f} "
              f"| {b.distance:.2f} | {b.dy:.2f} | {b.on_floor} |" for a, b in zip(mine, theirs)]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_engine_robot_arguments(parser, robots_help="3D robot files (.npy) or NAME=PATH")
    parser.add_argument("--times", type=float, nargs="+", default=[0.1, 0.2, 0.3, 0.4, 0.55],
                        help="s from the start, after the 0.05 s settle, increasing")
    parser.add_argument("--start-shift", type=float, default=0.0,
                        help="mjregen's start shift in voxel lengths (default 0: the exact "
                             "start, as the engine's)")
    parser.add_argument("--json", type=Path, help="write the timelines here")
    args = parser.parse_args(argv)
    rows = []
    try:
        engine = PaperEngine(args.voxelyze)
        physics = Physics().replace(start_shift=args.start_shift)
        for name, path in named_paths(args.robots):
            robot = Robot.load(path)
            mine = mjregen_timeline(robot, args.times, physics=physics)
            theirs = engine_timeline(engine, robot, args.times)
            print(markdown(name, mine, theirs), flush=True)
            rows.append({"name": name, "path": str(path), "mjregen": [p.to_json() for p in mine],
                         "engine": [p.to_json() for p in theirs]})
    except (MjregenError, OSError, ValueError) as error:
        parser.error(str(error))
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
