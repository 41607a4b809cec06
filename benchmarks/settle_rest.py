"""How much of a 2D walk's settle the settle's rest skips, and what it changes.

    python benchmarks/settle_rest.py [ROBOT.npy ...] [--robots 30] [--seed 11]
        [--threshold 1e-6] [--body grid|sheet] [--workers 1] [--evolution GENS --rounds 2]
        [--json out.json]

The paper settles a 2D robot for 1.0 s before its 0.25 s walk, so about 80 % of a 2D
evaluation's steps are settle. Robots of the NCAs' initial populations (feed-forward and LSTM,
`--robots` each, seeds `--seed` ..) and the 2D robots given (e.g. evolved walkers, reported
one by one) walk with the default physics twice: after the full settle (`Scene.settle_rest`
0) and with the settle ended at rest (`settle_rest` = `--threshold`: once every voxel has
moved slower than that many voxel lengths/s and turned slower than that many rad/s for 5 ms,
the plugin holds the robot still until the muscles start, and the native stepper skips the
held steps). For each robot: the share of the settle held, the distances walked, and the
simulations' CPU time. The rest is not a same-numbers lever: the walk starts from the rest
state without its residual motion, which a chaotic walk amplifies, like a start shift.
``--body sheet`` walks the patterns as the paper's 2D robots, laid flat on the floor and
walked in 3D (`mjregen.tasks.bodies`), whose default the rest is; with ``--evolution`` the
paper's 2D evolution runs its first generations with and without the rest, side by side.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import resource
import statistics
import subprocess
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from mjregen.grid import Robot
from mjregen.growth.nca import NCAConfig, grow
from mjregen.growth.networks import random_genomes
from mjregen.physics import Physics
from mjregen.physics.compile import compile_robot
from mjregen.physics.params import REST_WINDOW
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


def measure(item: tuple[Robot, Physics, float]) -> dict:
    """One robot: its distances and simulation CPU times after the full settle and with the
    settle ended at rest, and the settle's steps held."""
    robot, physics, threshold = item
    full = walk(compile_robot(robot, physics=physics.replace(settle_rest=0.0)))
    compiled = compile_robot(robot, physics=physics.replace(settle_rest=threshold))
    sim = simulation_of(compiled)
    rested = walk(compiled, sim=sim)
    settle, measured = compiled.physics.scene.timing(robot.dim)
    dt = compiled.timestep
    n_settle, n_measure = round(settle / dt), round(measured / dt)
    rest = sim.data.plugin_state[robot.n_voxels:]  # held, quiet, quiet since (s), ...
    held = n_settle - math.ceil((rest[2] + REST_WINDOW) / dt - 1e-9) if rest[0] else 0
    return {"voxels": robot.n_voxels, "settle_steps": n_settle, "measured_steps": n_measure,
            "skipped": max(held, 0), "full": full.distance, "early": rested.distance,
            "cpu_early": rested.cpu_time, "cpu_full": full.cpu_time}


def _evolution(settle_rest: float, gens: int, seed: int) -> dict:
    """A real paper-size 2D sheet evolution's first `gens` generations (`mjregen evolve --dim
    2 --body sheet --preset 2d`, serial) with the settle rest `settle_rest`: CPU s (the
    command's process), evaluations, and the best fitness of each generation."""
    with tempfile.TemporaryDirectory() as folder:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([sys.executable, "-m", "mjregen", "evolve", "--dim", "2", "--body",
                        "sheet", "--net", "ff", "--preset", "2d", "--gens", str(gens), "--seed",
                        str(seed), "--backend", "serial", "--settle-rest", repr(settle_rest),
                        "--quiet", "--out", str(Path(folder) / "run")],
                       check=True, stdout=subprocess.DEVNULL)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        with open(Path(folder) / "run" / "metrics.csv") as handle:
            rows = list(csv.DictReader(handle))
    return {"cpu_s": after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime,
            "evaluations": sum(int(r["evaluations"]) for r in rows),
            "best": [float(r["best"]) for r in rows]}


def evolution_cost(threshold: float, gens: int, rounds: int, seed: int) -> dict:
    """`_evolution` with the full settle and with the rest at `threshold`, interleaved,
    `rounds` times."""
    runs = {"full": [], "rest": []}
    for _ in range(rounds):
        for name, rest in (("full", 0.0), ("rest", threshold)):
            runs[name].append(_evolution(rest, gens, seed))
    return {"gens": gens, "rounds": rounds, "seed": seed, "runs": runs}


def _evolution_lines(cost: dict) -> list[str]:
    """The evolution's CPU per evaluation with and without the rest, projected to the
    paper's 2D run (population 300 x 500 generations) on 2 cores."""
    per_evaluation = {name: statistics.median(r["cpu_s"] / r["evaluations"] for r in runs)
                      for name, runs in cost["runs"].items()}
    bests = {name: runs[0]["best"] for name, runs in cost["runs"].items()}
    gap = max(abs(a - b) for a, b in zip(bests["full"], bests["rest"]))
    hours = {name: cpu * 300 * 500 / 2 / 3600 for name, cpu in per_evaluation.items()}
    return [
        f"- A real evolution: `mjregen evolve --dim 2 --body sheet --preset 2d --gens "
        f"{cost['gens']} --seed {cost['seed']} --backend serial` with `--settle-rest 0` and "
        f"with the default, interleaved, {cost['rounds']} rounds (medians; CPU s of the "
        f"whole command, growth, compile and start-up included): "
        f"{per_evaluation['full']:.4f} CPU s per evaluation with the full settle, "
        f"{per_evaluation['rest']:.4f} with the rest "
        f"({per_evaluation['full'] / per_evaluation['rest']:.1f} x); the paper's 2D run "
        f"(300 x 500 evaluations) at that cost on 2 cores: {hours['full']:.2f} h and "
        f"{hours['rest']:.2f} h. The best fitness of each generation differs between the two "
        f"by at most {gap:.1g}.",
    ]


def markdown_section(reports: list[dict]) -> list[str]:
    """docs/performance.md's section on ending the 2D settle at rest (`main` reports, one
    per body)."""
    lines = ["", "## The 2D settle ended at rest (the sheets' default)"]
    for report in reports:
        lines += _body_lines(report)
    lines += [
        "",
        "It moves results by the residual motion at rest (the differences above), which a "
        "chaotic walk can amplify like a start shift, so it is a physics option (`Scene.settle_rest`, `--settle-rest`), not a same-numbers lever. The plugin "
        "holds the robot in the model itself (its state keeps the rest; `compute` adds no "
        "force and `advance` undoes the held step's gravity), so the exported MJCF in plain "
        "MuJoCo holds it too, and the native stepper skips the held steps. It is the default "
        "of the paper's 2D robots (sheets, which the 2D experiments evolve); robots in the "
        "x-z plane and 3D robots (whose settle is 0.05 s) settle for the full time unless "
        "asked.",
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
        f"{report['seed']} --threshold {threshold:g} --body {body}"
        + (f" --evolution {report['evolution']['gens']} --rounds "
           f"{report['evolution']['rounds']}" if report.get("evolution") else "")
        + f"` ({', '.join(report['given']) or 'no robot files'}): a 2D robot "
        + ("as the paper's, a pattern laid flat and walked in 3D, "
           if body == "sheet" else "in the x-z plane ")
        + "settles 1.0 s before its 0.25 s walk, 80 % of its steps. "
        f"{len(rows)} robots of the 2D networks' initial populations, held from the step at "
        f"which every voxel has moved slower than {threshold:g} voxel lengths/s and turned "
        f"slower than {threshold:g} rad/s for {REST_WINDOW * 1e3:g} ms:", "",
        f"- The settle's share held: median {np.median(skipped):.2f}, mean "
        f"{skipped.mean():.2f} ({np.mean(skipped == 0):.2f} of the robots never at rest); of "
        f"all the evaluation's steps median {np.median(all_steps):.2f}, mean "
        f"{all_steps.mean():.2f}; the simulations' CPU time {cpu_full:.2f} s with the full "
        f"settle, {cpu_early:.2f} s ended at rest ({cpu_full / cpu_early:.1f} x).",
        f"- What it changes: the distances walked after a settle ended at rest against "
        f"the full settle differ by median {np.median(diff):.2g} voxel lengths (largest "
        f"{diff.max():.2g}); {moved} of {int(both.sum())} moved by more than 10 % (and 0.01 L).",
    ]
    for path, row in report["given"].items():
        lines.append(f"- {path}: settle skipped {row['skipped'] / row['settle_steps']:.2f}, "
                     f"distance {row['full']:.4f} (full settle) against {row['early']:.4f}.")
    if report.get("evolution"):
        lines += _evolution_lines(report["evolution"])
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*", type=Path, help="2D robots (.npy) to measure too")
    parser.add_argument("--robots", type=int, default=30, help="genomes per network")
    parser.add_argument("--seed", type=int, default=11, help="seed of the genomes")
    parser.add_argument("--threshold", type=float, default=1e-6,
                        help="voxel lengths/s and rad/s below which a robot is at rest")
    parser.add_argument("--body", choices=("grid", "sheet"), default="grid",
                        help="the 2D robots' body (mjregen.tasks.bodies; default grid)")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--evolution", type=int, default=0, metavar="GENS",
                        help="also run the paper's 2D evolution (sheets) for GENS generations "
                             "with and without the rest, interleaved (--body sheet)")
    parser.add_argument("--rounds", type=int, default=2, help="--evolution's rounds")
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
        rows = list(pool.map(measure, [(r, physics, args.threshold) for r in bodies]))
    report = {"threshold": args.threshold, "seed": args.seed,
              "body": args.body,
              "per_network": args.robots, "robots": rows[: len(robots)],
              "given": dict(zip(given, rows[len(robots):]))}
    if args.evolution:
        if args.body != "sheet":
            parser.error("--evolution runs the paper's 2D evolution: it needs --body sheet")
        report["evolution"] = evolution_cost(args.threshold, args.evolution, args.rounds,
                                             args.seed)
    print("\n".join(markdown_section([report])))
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
