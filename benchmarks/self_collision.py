"""How much of a 3D robot's walk is self-collision, in mjregen and in the paper's engine.

    python benchmarks/self_collision.py --voxelyze DIR ROBOT.npy|NAME=ROBOT.npy ...

Each robot walks the paper's 3D window (settle 0.05 s, walk 0.5 s) four ways: mjregen with
the default physics and with self-collision off (`collision_radius` 0), and the paper's
engine (DIR: its folder with `vxa.py`) with its settings and with `SelfColEnabled` 0. Where
the two simulators agree without self-collision but not with it, their difference is the
self-collision model's (docs/transfer.md).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

from mjregen.errors import MjregenError
from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.physics.simulation import simulate
from mjregen.validation.engine import PAPER_DT_FRACTION, PaperEngine


def without_self_collision(physics: Physics) -> Physics:
    """`physics` with the voxel pipeline's self-collision off."""
    return dataclasses.replace(physics, pipeline=dataclasses.replace(physics.pipeline,
                                                                     collision_radius=0.0))


def measure(robot: Robot, engine: PaperEngine) -> dict[str, float]:
    """The four distances (voxel lengths) of `robot` (a 3D grid)."""
    physics = Physics()
    settle, walk = physics.scene.timing(3)

    def in_engine(self_collision: int) -> float:
        return engine.run_window(robot.grid, dt_fraction=PAPER_DT_FRACTION, stop=settle + walk,
                                 measure_from=settle,
                                 settings={"SelfColEnabled": self_collision})["distance"]

    return {"mjregen": simulate(robot, physics=physics).distance,
            "mjregen_off": simulate(robot, physics=without_self_collision(physics)).distance,
            "engine": in_engine(1), "engine_off": in_engine(0)}


def markdown(rows: dict[str, tuple[int, dict[str, float]]]) -> str:
    """The table: per robot its voxels, the four distances and the engine / mjregen ratios."""
    lines = ["| robot | voxels | mjregen | mjregen, no self-collision | engine | engine, no "
             "self-collision | engine / mjregen | the same, no self-collision |",
             "|---|---|---|---|---|---|---|---|"]
    for name, (voxels, d) in rows.items():
        lines.append(f"| {name} | {voxels} | {d['mjregen']:.2f} | {d['mjregen_off']:.2f} | "
                     f"{d['engine']:.2f} | {d['engine_off']:.2f} | "
                     f"{d['engine'] / d['mjregen']:.2f} | "
                     f"{d['engine_off'] / d['mjregen_off']:.2f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--voxelyze", type=Path, required=True,
                        help="folder of the paper's engine and its vxa.py")
    parser.add_argument("robots", nargs="+", help="3D robot files (.npy) or NAME=PATH")
    args = parser.parse_args(argv)
    try:
        engine = PaperEngine(args.voxelyze)
        rows = {}
        for name, _, path in (item.rpartition("=") for item in args.robots):
            robot = Robot.load(path)
            if robot.dim != 3:
                parser.error(f"{path}: a {robot.dim}D robot; the engine runs 3D grids")
            rows[name or Path(path).stem] = (robot.n_voxels, measure(robot, engine))
            print(markdown({k: rows[k] for k in list(rows)[-1:]}).splitlines()[-1], flush=True)
    except (MjregenError, OSError, ValueError) as error:
        parser.error(str(error))
    print(markdown(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
