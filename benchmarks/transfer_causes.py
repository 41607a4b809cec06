"""Why a robot does not transfer: its walk in mjregen and in the paper's engine at finer time
steps and without self-collision, side by side.

    python benchmarks/transfer_causes.py --voxelyze DIR ROBOT.npy|NAME=ROBOT.npy ...
        [--starts 5] [--steps 1 0.5 0.25] [--horizons 2 2.5] [--json out.json]

(the robots before --steps or --horizons, which take every number after them)

For each 3D robot, with the paper's 3D times (0.05 s settle, 0.5 s measured), distances in
voxel lengths:
  - mjregen, the mean over starts 0 .. ``--starts`` - 1 of seed 0 (1: the default start), at
    each ``--steps`` factor of the default time step (`Scene.timestep_safety`), with
    self-collision and without it (`collision_radius` 0);
  - the paper's engine, one run each, at the same factors of its step fraction 0.9 (the
    paper's), with its self-collision and without it (``SelfColEnabled`` 0);
  - at the default step (factor 1, when listed), the engine / mjregen ratios with and without
    self-collision.
A walk that changes with the step in one simulator is an integration artefact there; one that
two simulators agree on without self-collision but not with it depends on how each computes
self-collision. The default step and the engine's 0.9 with self-collision are what the
transfer check compares (`mjregen.validation.transfer`).

``--horizons H ...`` also walks each robot in the engine at its paper step with its
self-collision and ``CollisionHorizon`` H (the paper's: 2). The engine lists its candidate
pairs (surface voxels more than int(1.5 H) bonds apart, 3 for H in [2, 2.67)) within H times
the first voxel's current size of each other (`CVX_Sim::CalcL1Bonds`) and lists them again
once the fastest voxel's speed times the step, summed over the steps since, exceeds
(H - 1) / 2 L (`UpdateCollisions`); a pair that closes faster is missed until then. A larger H
(keeping 3 bonds) misses fewer: a walk that changes with H depended on contacts the paper's
list missed.
mjregen's list never misses one (`plugin/forces.c`, `self_collision`).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from mjregen.cli.common import add_engine_robot_arguments, named_paths
from mjregen.errors import MjregenError
from mjregen.grid import Robot
from mjregen.physics import PAPER_TIMES, Physics
from mjregen.physics.simulation import simulate_starts
from mjregen.validation.engine import PAPER_DT_FRACTION, PaperEngine

NO_COLLISION = " no-col"  # the suffix of a column walked without self-collision


def _column(factor: float, collision: bool) -> str:
    return f"{factor:g}" + ("" if collision else NO_COLLISION)


def mjregen_walks(robot: Robot, starts: int, factors: list[float]) -> dict[str, float]:
    """{"<factor>" / "<factor> no-col": mean distance over the starts} (NaN if any start is
    unstable)."""
    base = Physics()
    out = {}
    for collision in (True, False):
        for factor in factors:
            physics = base.replace(timestep_safety=factor * base.scene.timestep_safety,
                                   **({} if collision else {"collision_radius": 0.0}))
            walks = simulate_starts(robot, physics=physics, starts=range(starts))
            out[_column(factor, collision)] = (
                float(np.mean([w.distance for w in walks]))
                if all(w.stable for w in walks) else float("nan"))
    return out


def engine_distance(robot: Robot, engine: PaperEngine, dt_fraction: float,
                    settings: dict[str, float]) -> float:
    """The engine's distance over the paper's 3D window at `dt_fraction`, with `settings`
    changed from the paper's."""
    settle, measured = PAPER_TIMES[3]
    return engine.run_window(robot.grid, dt_fraction=dt_fraction, stop=settle + measured,
                             measure_from=settle, settings=settings)["distance"]


def engine_walks(robot: Robot, engine: PaperEngine, factors: list[float]) -> dict[str, float]:
    """{"<fraction>" / "<fraction> no-col": the engine's distance} at each factor of the
    paper's step fraction."""
    return {_column(factor * PAPER_DT_FRACTION, collision): engine_distance(
                robot, engine, factor * PAPER_DT_FRACTION, {"SelfColEnabled": int(collision)})
            for collision in (True, False) for factor in factors}


def horizon_walks(robot: Robot, engine: PaperEngine, horizons: list[float]) -> dict[str, float]:
    """{"<H>": the engine's distance with CollisionHorizon H}, at the paper's step with its
    self-collision."""
    return {f"{h:g}": engine_distance(robot, engine, PAPER_DT_FRACTION, {"CollisionHorizon": h})
            for h in horizons}


def _ratios(row: dict) -> dict[str, float] | None:
    """Engine / mjregen at the default step, with and without self-collision (None when the
    default step was not walked)."""
    mine, theirs = row["mjregen"], row["engine"]
    default = _column(PAPER_DT_FRACTION, True)
    if "1" not in mine or default not in theirs:
        return None
    return {"with": _ratio(theirs[default], mine["1"]),
            NO_COLLISION.strip(): _ratio(theirs[default + NO_COLLISION], mine["1" + NO_COLLISION])}


def _ratio(engine: float, mine: float) -> float:
    return engine / mine if mine != 0.0 else float("nan")


def markdown(rows: list[dict]) -> str:
    """mjregen's table, the engine's and, with the default step, their ratios: a row per
    robot."""
    tables = [("mjregen", "mjregen, step ×"), ("engine", "engine, DtFrac")]
    if all(_ratios(r) is not None for r in rows):
        for row in rows:
            row["ratio"] = _ratios(row)
        tables.append(("ratio", "engine / mjregen"))
    if all("horizons" in r for r in rows):
        tables.append(("horizons", "engine, CollisionHorizon"))
    lines = []
    for simulator, label in tables:
        keys = list(rows[0][simulator])
        lines += ["", f"| robot | voxels | {' | '.join(f'{label} {k}' for k in keys)} |",
                  "|---|---|" + "---|" * len(keys)]
        lines += [f"| {r['name']} | {r['voxels']} | "
                  + " | ".join(f"{r[simulator][k]:.2f}" for k in keys) + " |" for r in rows]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_engine_robot_arguments(parser, robots_help="3D robot files (.npy) or NAME=PATH")
    parser.add_argument("--starts", type=int, default=5, help="mjregen starts per cell")
    parser.add_argument("--steps", type=float, nargs="+", default=[1.0, 0.5, 0.25],
                        help="factors of both simulators' default time step")
    parser.add_argument("--horizons", type=float, nargs="+", metavar="H",
                        help="also walk the engine with these CollisionHorizon values "
                             "(the paper's: 2; 2 to 2.66 keep its 3 bonds)")
    parser.add_argument("--json", type=Path, help="write the measurements here")
    args = parser.parse_args(argv)
    if args.starts < 1 or not all(0.0 < f <= 1.0 for f in args.steps):
        parser.error("--starts must be >= 1 and each --steps factor in (0, 1]")
    if args.horizons and not all(h >= 1.0 for h in args.horizons):
        parser.error("each --horizons value must be >= 1 (voxel sizes)")
    try:
        engine = PaperEngine(args.voxelyze)
        rows = []
        for name, path in named_paths(args.robots):
            robot = Robot.load(path)
            if robot.dim != 3:
                parser.error(f"{path}: a {robot.dim}D robot; the engine runs 3D grids")
            rows.append({"name": name, "voxels": robot.n_voxels,
                         "mjregen": mjregen_walks(robot, args.starts, args.steps),
                         "engine": engine_walks(robot, engine, args.steps)})
            if args.horizons:
                rows[-1]["horizons"] = horizon_walks(robot, engine, args.horizons)
            print(rows[-1], flush=True)
    except (MjregenError, OSError, ValueError) as error:
        parser.error(str(error))
    print(markdown(rows))
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
