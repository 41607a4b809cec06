"""Why a robot does not transfer: its walk in mjregen and in the paper's engine at finer time
steps and without self-collision, side by side.

    python benchmarks/transfer_causes.py --voxelyze DIR ROBOT.npy [...] [--starts 5]
        [--json out.json]

For each 3D robot (a .npy grid, or NAME=PATH), with the paper's 3D times (0.05 s settle, 0.5 s
measured), distances in voxel lengths:
  - mjregen, the mean over starts 0 .. ``--starts`` - 1 of seed 0, at the default time step
    and at 1/2 and 1/4 of it (`Scene.timestep_safety`), with self-collision and without it
    (`collision_radius` 0);
  - the paper's engine, one run each, at its step fractions 0.9 (the paper's), 0.45 and
    0.225, with its self-collision and without it (``SelfColEnabled`` 0).
A walk that changes with the step in one simulator is an integration artefact there; one that
two simulators agree on without self-collision but not with it depends on how each computes
self-collision. The default step and the engine's 0.9 with self-collision are what the
transfer check compares (`mjregen.validation.transfer`).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from mjregen.grid import Robot
from mjregen.physics import PAPER_TIMES, Physics
from mjregen.physics.simulation import simulate_starts
from mjregen.validation.engine import PAPER_DT_FRACTION, PaperEngine

STEP_FACTORS = (1.0, 0.5, 0.25)  # of mjregen's default time step
DT_FRACTIONS = (PAPER_DT_FRACTION, 0.45, 0.225)  # of the engine's own stability rule


def mjregen_walks(robot: Robot, starts: int) -> dict[str, float]:
    """{"<factor>" / "<factor> no-col": mean distance over the starts} (NaN if any start is
    unstable)."""
    base = Physics()
    out = {}
    for collision in (True, False):
        for factor in STEP_FACTORS:
            physics = base.replace(timestep_safety=factor * base.scene.timestep_safety,
                                   **({} if collision else {"collision_radius": 0.0}))
            walks = simulate_starts(robot, physics=physics, starts=range(starts))
            out[f"{factor:g}" + ("" if collision else " no-col")] = (
                float(np.mean([w.distance for w in walks]))
                if all(w.stable for w in walks) else float("nan"))
    return out


def engine_walks(robot: Robot, engine: PaperEngine) -> dict[str, float]:
    """{"<fraction>" / "<fraction> no-col": the engine's distance}."""
    settle, measured = PAPER_TIMES[3]
    return {f"{fraction:g}" + ("" if collision else " no-col"): engine.run_window(
                robot.grid, dt_fraction=fraction, stop=settle + measured, measure_from=settle,
                settings={"SelfColEnabled": int(collision)})["distance"]
            for collision in (True, False) for fraction in DT_FRACTIONS}


def markdown(rows: list[dict]) -> str:
    """The two tables, mjregen's and the engine's, one row per robot."""
    lines = []
    for simulator, label in (("mjregen", "mjregen, step ×"), ("engine", "engine, DtFrac")):
        keys = list(rows[0][simulator])
        lines += ["", f"| robot | voxels | {' | '.join(f'{label} {k}' for k in keys)} |",
                  "|---|---|" + "---|" * len(keys)]
        lines += [f"| {r['name']} | {r['voxels']} | "
                  + " | ".join(f"{r[simulator][k]:.2f}" for k in keys) + " |" for r in rows]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--voxelyze", type=Path, required=True,
                        help="folder of the paper's engine and its vxa.py")
    parser.add_argument("robots", nargs="+", help="3D robot files (.npy) or NAME=PATH")
    parser.add_argument("--starts", type=int, default=5, help="mjregen starts per cell")
    parser.add_argument("--json", type=Path, help="write the measurements here")
    args = parser.parse_args(argv)
    engine = PaperEngine(args.voxelyze)
    rows = []
    for item in args.robots:
        name, _, path = item.rpartition("=")
        robot = Robot.load(path)
        if robot.dim != 3:
            parser.error(f"{path}: the engine runs 3D robots only")
        rows.append({"name": name or Path(path).stem, "voxels": robot.n_voxels,
                     "mjregen": mjregen_walks(robot, args.starts),
                     "engine": engine_walks(robot, engine)})
        print(rows[-1], flush=True)
    print(markdown(rows))
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
