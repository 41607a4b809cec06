"""How much of a 3D robot's walk is self-collision, in mjregen and in the paper's engine.

    python benchmarks/self_collision.py --voxelyze DIR ROBOT.npy|NAME=ROBOT.npy ...

Each robot walks the paper's 3D window (settle 0.05 s, walk 0.5 s) four ways: mjregen with
the default physics and with self-collision off (`collision_radius` 0), and the paper's
engine (DIR: its folder with `vxa.py`) with its settings and with `SelfColEnabled` 0. Where
the two simulators agree without self-collision but not with it, their difference is the
self-collision model's (docs/transfer.md).

``--contacts`` also follows mjregen's walk (every 2nd step) and counts the samples of pairs
touching (centres closer than 1.5 L) that the engine's collision candidates would not hold:
the engine lists the surface pairs more than 3 bonds apart within 2 L of each other, and
lists them again only once its fastest voxel has moved 0.5 L (its horizon 2, halved less
one half).
"""

from __future__ import annotations

import argparse
import sys
from collections import deque
from pathlib import Path

import mujoco
import numpy as np

from mjregen.errors import MjregenError
from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.physics.compile import compile_robot
from mjregen.physics.model import RobotLayout, robot_layout
from mjregen.physics.simulation import simulate, simulation_of
from mjregen.validation.engine import PAPER_DT_FRACTION, PaperEngine


def measure(robot: Robot, engine: PaperEngine) -> dict[str, float]:
    """The four distances (voxel lengths) of `robot` (a 3D grid)."""
    physics = Physics()
    settle, walk = physics.scene.timing(3)

    def in_engine(self_collision: int) -> float:
        return engine.run_window(robot.grid, dt_fraction=PAPER_DT_FRACTION, stop=settle + walk,
                                 measure_from=settle,
                                 settings={"SelfColEnabled": self_collision})["distance"]

    return {"mjregen": simulate(robot, physics=physics).distance,
            "mjregen_off": simulate(robot, physics=physics.replace(collision_radius=0.0)).distance,
            "engine": in_engine(1), "engine_off": in_engine(0)}


def collision_pairs(layout: RobotLayout, hops: int = 3) -> np.ndarray:
    """The pairs (k, 2) of the robot's surface voxels (`RobotLayout.surface`, in body order)
    more than `hops` face bonds apart: those that may collide, in both simulators."""
    neighbours: list[list[int]] = [[] for _ in layout.voxels]
    for i, j, _ in layout.bonds:
        neighbours[i].append(j)
        neighbours[j].append(i)

    def within(start: int) -> set[int]:
        depth, queue = {start: 0}, deque([start])
        while queue:
            u = queue.popleft()
            for v in neighbours[u] if depth[u] < hops else ():
                if v not in depth:
                    depth[v] = depth[u] + 1
                    queue.append(v)
        return set(depth)

    surface = np.flatnonzero(layout.surface).tolist()
    near = {i: within(i) for i in surface}
    pairs = [(a, b) for k, a in enumerate(surface) for b in surface[k + 1:] if b not in near[a]]
    return np.array(pairs, dtype=int).reshape(-1, 2)


def missed_contacts(robot: Robot, every: int = 2) -> tuple[int, int]:
    """(samples of touching pairs in mjregen's walk, of them outside the engine's candidates)."""
    compiled = compile_robot(robot)
    pairs = collision_pairs(robot_layout(robot, compiled.physics, set(), 0.0))
    sim = simulation_of(compiled)
    model, data, bodies = sim.model, sim.data, compiled.body_ids
    size = compiled.physics.scene.voxel_size
    steps = round(sum(compiled.physics.scene.timing(3)) / compiled.timestep)
    previous, moved, candidates, touching, missed = None, np.inf, None, 0, 0
    for _ in range(0, steps, every):
        sim.run(every)
        mujoco.mj_kinematics(model, data)
        x = data.xpos[bodies] / size
        moved += 0.0 if previous is None else float(np.max(np.linalg.norm(x - previous, axis=1)))
        previous = x.copy()
        distance = np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1)
        if moved > 0.5:
            candidates, moved = distance < 2.0, 0.0
        touching += int(np.count_nonzero(distance < 1.5))
        missed += int(np.count_nonzero((distance < 1.5) & ~candidates))
    return touching, missed


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
    parser.add_argument("--contacts", action="store_true",
                        help="also count mjregen's contacts outside the engine's candidates")
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
            if args.contacts:
                touching, missed = missed_contacts(robot)
                print(f"  touching pair-samples {touching:,}, outside the engine's candidates "
                      f"{missed:,}", flush=True)
    except (MjregenError, OSError, ValueError) as error:
        parser.error(str(error))
    print(markdown(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
