"""How large a start shift: robots walked from starts shifted by each of several sizes.

    python benchmarks/start_shift.py NAME=ROBOT.npy [...] [--shifts 0 1e-6 1e-5 1e-4 1e-3 1e-2]
        [--starts 5] [--workers 2]

For each robot and each size (voxel lengths; 0 = the exact start), the distances (voxel
lengths) and headings (degrees) of ``--starts`` starts (seeds 0, 1, ...) with the default
physics otherwise: the exact start's state with every position moved by normal offsets of that
size, unrounded (finer than a start's keyframe keeps, so that sizes below the smallest
`Scene.start_shift` can be compared), and, in the last column, the default start itself
(keyframes of 1e-4 L, starts 0 ..). The size to choose: large enough that bodies balancing on an exact
symmetry (one-voxel plates on an edge) fall as in the paper's engine, small enough that the
paper's robots move by less than their time step's effect (docs/accuracy.md).
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import simulate_starts, simulation_of, walk
from mjregen.physics.start_state import translational_coordinates

DEFAULT = -1.0  # the "size" of the default start's column


def shifted_walk(robot: Robot, shift: float, seed: int) -> tuple[float, float]:
    """(distance, heading) from the exact start with positions moved by N(0, shift²) voxel
    lengths (seed `seed`), unrounded."""
    compiled = compile_robot(robot, physics=Physics().replace(start_shift=0.0))
    sim = simulation_of(compiled)
    positions = translational_coordinates(compiled.model)
    sim.data.qpos[positions] += np.random.default_rng(seed).normal(
        0.0, shift * compiled.physics.scene.voxel_size, int(positions.sum()))
    result = walk(compiled, sim=sim)
    return result.distance, result.heading


def walks(job: tuple[str, float, int]) -> list[tuple[float, float]]:
    """(distance, heading) of each start of robot file `job[0]` at shift `job[1]`."""
    path, shift, starts = job
    robot = Robot.load(path)
    if shift == DEFAULT:
        return [(r.distance, r.heading) for r in simulate_starts(robot, starts=range(starts))]
    return [shifted_walk(robot, shift, seed) for seed in range(starts if shift else 1)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("robots", nargs="+", help="NAME=ROBOT.npy")
    parser.add_argument("--shifts", type=float, nargs="+",
                        default=[0.0, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2])
    parser.add_argument("--starts", type=int, default=5)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    named = [item.partition("=")[::2] for item in args.robots]
    shifts = [*args.shifts, DEFAULT]
    jobs = [(path, shift, args.starts) for _, path in named for shift in shifts]
    with ProcessPoolExecutor(args.workers) as pool:
        results = list(pool.map(walks, jobs))
    print("| robot | " + " | ".join(f"shift {s:g} L" for s in args.shifts)
          + " | default start (keyframes) |")
    print("|---|" + "---|" * len(shifts))
    for i, (name, _) in enumerate(named):
        cells = []
        for j in range(len(shifts)):
            distances, headings = np.array(results[i * len(shifts) + j]).T
            cells.append(f"{distances.mean():.2f} ({distances.min():.2f}-{distances.max():.2f}), "
                         f"{np.nanmin(headings):.0f} to {np.nanmax(headings):.0f} deg"
                         if len(distances) > 1 else
                         f"{distances[0]:.2f}, {headings[0]:.0f} deg")
        print(f"| {name} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
