"""Time one locomotion evaluation (`mjregen.simulate`) for three reference robots.

For each robot: µs per step, steps, wall and CPU seconds per evaluation (median of
`--repeats` runs, compile included), and µs per step of bare `mj_step` in C (no Python per
step, no muscle drive) on the same model, to show the loop's overhead. The fuller report
with both bond backends, paper robots and worker throughput is `benchmarks/speed.py`.

    /work/venv/bin/python benchmarks/simulate_speed.py [--repeats 3] [--out speed.json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import mujoco
import numpy as np

from mjregen.compile import compile_robot
from mjregen.grid import Robot
from mjregen.simulate import simulate


def reference_robots() -> dict[str, Robot]:
    """5×5 2D mixed robot, 112-voxel 3D slab with muscles, 7×7×7 soft/muscle block."""
    rng = np.random.default_rng(0)
    sheet = rng.choice([1, 2, 3, 4], size=(5, 5)).astype(np.int8)
    slab = np.ones((7, 4, 4), dtype=np.int8)
    slab[:, :, 0] = np.where(np.arange(7)[:, None] % 2 == 0, 3, 4)  # legs layer: red/green
    slab[:, :, 3] = 4
    block = rng.choice([1, 3, 4], size=(7, 7, 7)).astype(np.int8)
    return {"sheet_2d_5x5": Robot.from_body(sheet), "slab_3d_112": Robot.from_body(slab),
            "block_3d_7x7x7": Robot.from_body(block)}


def bare_step_us(robot: Robot, steps: int = 2000) -> float:
    """µs per `mj_step` run in C for `steps` steps on the robot's model (passive)."""
    compiled = compile_robot(robot)
    data = mujoco.MjData(compiled.model)
    start = time.perf_counter()
    mujoco.mj_step(compiled.model, data, nstep=steps)
    return (time.perf_counter() - start) / steps * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", help="also write the numbers to this JSON file")
    args = parser.parse_args()
    rows = {}
    for name, robot in reference_robots().items():
        runs = [simulate(robot) for _ in range(args.repeats)]
        wall = statistics.median(r.wall_time for r in runs)
        cpu = statistics.median(r.cpu_time for r in runs)
        rows[name] = {
            "voxels": robot.n_voxels, "steps": runs[0].steps, "timestep_s": runs[0].timestep,
            "sim_time_s": runs[0].sim_time, "us_per_step": wall / runs[0].steps * 1e6,
            "wall_s": wall, "cpu_s": cpu, "bare_mj_step_us": bare_step_us(robot),
            "distance": runs[0].distance, "stable": runs[0].stable,
            "identical_repeats": len({r.distance for r in runs}) == 1,
        }
        print(name, json.dumps(rows[name]), flush=True)
    if args.out:
        with open(args.out, "w") as file:
            json.dump({"mujoco": mujoco.__version__, "repeats": args.repeats, "robots": rows},
                      file, indent=2)


if __name__ == "__main__":
    main()
