"""How much of a 2D walk's settle is spent at rest, and what ending the settle there changes.

    python benchmarks/settle_rest.py [ROBOT.npy ...] [--robots 30] [--seed 11]
        [--threshold 1e-6] [--check 0.005] [--body grid|sheet] [--workers 1] [--json out.json]

The paper settles a 2D robot for 1.0 s before its 0.25 s walk, so about 80 % of a 2D
evaluation's steps are settle. Robots of the NCAs' initial populations (feed-forward and LSTM,
`--robots` each, seeds `--seed` ..) settle with the default physics, and so do the 2D robots given
(e.g. evolved walkers, reported one by one); every `--check` s the
largest linear voxel speed (voxel lengths/s) and angular speed (rad/s) are read. A robot is at
rest from the first check after which both stay below `--threshold`. For each robot: the
share of the settle after rest (steps an early end would skip), and its distance walked
after the full settle against after a settle ended at the first check below the threshold
(the clock then jumps to the settle's end, so the muscles start at the same phase). Ending
the settle early is not a same-numbers lever: the state it leaves differs from the full
settle's by the residual motion, which a chaotic walk amplifies, like a start shift.
``--body sheet`` settles the patterns as the paper's 2D robots, laid flat on the floor and
walked in 3D (`mjregen.tasks.bodies`).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from mjregen.grid import Robot
from mjregen.growth.nca import NCAConfig, grow
from mjregen.growth.networks import random_genomes
from mjregen.physics import Physics
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import simulation_of, walk
from mjregen.tasks.bodies import body_physics, body_robot


def initial_patterns(count: int, seed: int) -> list[tuple[str, np.ndarray]]:
    """("<network> <index>", grid) of the non-empty patterns of `count` initial genomes of
    each 2D network (seed `seed`)."""
    found = []
    for kind in ("ff", "lstm"):
        config = NCAConfig(dim=2, kind=kind)
        grids = grow(config, random_genomes(config, count, seed=seed)).grids
        found += [(f"{kind} {i}", grid) for i, grid in enumerate(grids) if np.any(grid)]
    return found


def max_speeds(qvel: np.ndarray, voxel_size: float, dim: int) -> tuple[float, float]:
    """(largest linear speed in voxel lengths/s, largest angular speed in rad/s) of a
    robot's ``qvel``: 2D (x, z, angle per voxel) or 3D (3 linear, 3 angular per voxel)."""
    linear = dim if dim == 3 else 2
    rates = qvel.reshape(-1, linear + (3 if dim == 3 else 1))
    return (float(np.abs(rates[:, :linear]).max()) / voxel_size,
            float(np.abs(rates[:, linear:]).max()))


def measure(item: tuple[Robot, Physics, float, float]) -> dict:
    """One robot: the settle's share after rest, and its distances after the full settle and
    after the settle ended at rest."""
    robot, physics, threshold, check = item
    compiled = compile_robot(robot, physics=physics)
    full = walk(compiled)
    settle, measured = compiled.physics.scene.timing(robot.dim)
    dt = compiled.timestep
    n_settle, n_measure = round(settle / dt), round(measured / dt)
    chunk = max(1, round(check / dt))
    sim = simulation_of(compiled)
    cpu = time.process_time()
    done, rest_at, reason = 0, None, ""
    speeds = []
    while done < n_settle and not reason:
        steps = min(chunk, n_settle - done)
        reason = sim.run(steps)
        done += steps
        speeds.append(max(max_speeds(sim.data.qvel, compiled.physics.scene.voxel_size,
                                     robot.dim)))
        if rest_at is None and speeds[-1] < threshold:
            rest_at = done
            sim.data.time = n_settle * dt  # the muscles start at the full settle's phase
            break
    if reason or rest_at is None:
        early = full.distance if not reason else float("nan")
        skipped = 0
    else:
        begin = sim.com()
        reason = sim.run(n_measure)
        end = sim.com()
        moved = end[:2] - begin[:2] if robot.dim == 3 else end[:1] - begin[:1]
        early = (float(np.linalg.norm(moved)) / compiled.physics.scene.voxel_size
                 if not reason else float("nan"))
        skipped = n_settle - rest_at
    return {"voxels": robot.n_voxels, "settle_steps": n_settle, "measured_steps": n_measure,
            "skipped": skipped, "full": full.distance, "early": early,
            "cpu_early": time.process_time() - cpu, "cpu_full": full.cpu_time}


def markdown_section(reports: list[dict]) -> list[str]:
    """docs/performance.md's section on ending the 2D settle at rest (`main` reports, one
    per body)."""
    lines = ["", "## Ending the 2D settle at rest (a lever that moves results, not taken)"]
    for report in reports:
        lines += _body_lines(report)
    lines += [
        "",
        "It is not taken: it moves results (by the residual motion, which a chaotic walk can "
        "amplify like a start shift), and it would make `simulate` run a protocol the "
        "exported MJCF does not hold (plain MuJoCo stepping the model settles for the full "
        "time; the model would need the rest test too). Taking it is a decision about the "
        "physics, best made before the 2D runs at the paper's scale start.",
    ]
    return lines


def _body_lines(report: dict) -> list[str]:
    """One report's paragraph and findings."""
    rows, threshold = report["robots"], report["threshold"]
    body = report.get("body", "grid")
    skipped = np.array([r["skipped"] / r["settle_steps"] for r in rows])
    all_steps = np.array([r["skipped"] / (r["settle_steps"] + r["measured_steps"])
                          for r in rows])
    full = np.array([r["full"] for r in rows])
    early = np.array([r["early"] for r in rows])
    both = np.isfinite(full) & np.isfinite(early)
    diff = np.abs(early - full)[both]
    moved = int(np.sum(diff > np.maximum(0.1 * full[both], 0.01)))
    cpu_full = sum(r["cpu_full"] for r in rows)
    cpu_early = sum(r["cpu_early"] for r in rows)
    lines = [
        "",
        f"`python benchmarks/settle_rest.py --robots {report['per_network']} --seed "
        f"{report['seed']} --threshold {threshold:g} --check {report['check']:g} --body "
        f"{body}` ({', '.join(report['given']) or 'no robot files'}): a 2D robot "
        + ("as the paper's, a pattern laid flat and walked in 3D, "
           if body == "sheet" else "in the x-z plane ")
        + "settles 1.0 s before its 0.25 s walk, 80 % of its steps. "
        f"{len(rows)} robots of the 2D networks' initial populations, at rest from the first "
        f"check (every {report['check'] * 1e3:g} ms) at which every voxel moves slower than "
        f"{threshold:g} voxel lengths/s and turns slower than {threshold:g} rad/s:", "",
        f"- The settle's share after rest: median {np.median(skipped):.2f}, mean "
        f"{skipped.mean():.2f} ({np.mean(skipped == 0):.2f} of the robots never at rest); of "
        f"all the evaluation's steps median {np.median(all_steps):.2f}, mean "
        f"{all_steps.mean():.2f}; the simulations' CPU time {cpu_full:.2f} s with the full "
        f"settle, {cpu_early:.2f} s ended at rest ({cpu_full / cpu_early:.1f} x).",
        f"- What it changes: the distances walked after a settle ended at rest (the clock "
        "jumped to the settle's end, so that the muscles start at the same phase) against "
        f"the full settle differ by median {np.median(diff):.2g} voxel lengths (largest "
        f"{diff.max():.2g}); {moved} of {int(both.sum())} moved by more than 10 % (and 0.01 L).",
    ]
    for path, row in report["given"].items():
        lines.append(f"- {path}: settle skipped {row['skipped'] / row['settle_steps']:.2f}, "
                     f"distance {row['full']:.4f} (full settle) against {row['early']:.4f}.")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*", type=Path, help="2D robots (.npy) to measure too")
    parser.add_argument("--robots", type=int, default=30, help="genomes per network")
    parser.add_argument("--seed", type=int, default=11, help="seed of the genomes")
    parser.add_argument("--threshold", type=float, default=1e-6,
                        help="voxel lengths/s and rad/s below which a robot is at rest")
    parser.add_argument("--check", type=float, default=0.005, help="s between speed checks")
    parser.add_argument("--body", choices=("grid", "sheet"), default="grid",
                        help="the 2D robots' body (mjregen.tasks.bodies; default grid)")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--json", type=Path, help="write the report here (speed.py --doc "
                                                  "--settle-rest reads one per body)")
    args = parser.parse_args(argv)
    given = {str(path): Robot.load(path) for path in args.files}
    if any(robot.dim != 2 for robot in given.values()):
        parser.error("the robots given must be 2D (the 3D settle is 0.05 s)")
    robots = [Robot(grid) for _, grid in initial_patterns(args.robots, args.seed)]
    physics = body_physics(Physics(), args.body)
    bodies = [body_robot(r, args.body) for r in [*robots, *given.values()]]
    with ProcessPoolExecutor(args.workers) as pool:
        rows = list(pool.map(measure, [(r, physics, args.threshold, args.check)
                                       for r in bodies]))
    report = {"threshold": args.threshold, "check": args.check, "seed": args.seed,
              "body": args.body,
              "per_network": args.robots, "robots": rows[: len(robots)],
              "given": dict(zip(given, rows[len(robots):]))}
    print("\n".join(markdown_section([report])))
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
