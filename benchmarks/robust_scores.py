"""What scoring each robot from K starts costs and buys: the selection bias of real runs.

    python benchmarks/robust_scores.py [--starts 1 3] [--seeds 0 1] [--pop 24] [--gens 15]
        [--fresh 10] [--root runs/robust_scores] [--json docs/robust_scores.json]

For each K and seed, a real 3D feed-forward evolution (the paper's GA settings, population
and generations reduced; every robot scored by the mean of K starts, `mjregen evolve
--starts K`) on 2 worker processes. Then every generation's best robot is walked again from
`--fresh` starts the run never saw (another start seed), and its fitness from them is set
against the fitness the run recorded for it: the difference is the selection bias (a GA
that keeps the best of many noisy scores keeps lucky ones). Prints, per K: the mean bias
over generations and runs, the share of generations whose best keeps >= 90 % of its
recorded distance from fresh starts, the best fresh fitness reached, and the CPU time per
evaluation. A finished run folder is reused (delete --root to measure again).
"""

from __future__ import annotations

import argparse
import csv
import json
import time
from pathlib import Path

import numpy as np

from mjregen.experiments.locomotion import evolve_locomotion
from mjregen.grid import Robot
from mjregen.growth.checkpoint import load_nca
from mjregen.growth.nca import NCAConfig
from mjregen.physics import Physics
from mjregen.search.backends import make_backend
from mjregen.search.ga import PRESETS
from mjregen.tasks.evaluation import RobotJob, evaluate_robot

FRESH_SEED = 1_000_000  # + the run's seed: start seeds no run of this benchmark uses


def run(root: Path, starts: int, seed: int, pop: int, gens: int) -> tuple[Path, float]:
    """The run folder of (K, seed), evolved unless finished; (folder, wall s of evolving)."""
    out = root / f"k{starts}_seed{seed}"
    ga = PRESETS["3d"].with_overrides(population=pop, generations=gens)
    wall = time.perf_counter()
    with make_backend("process", workers=2) as backend:
        evolve_locomotion(out=out, nca=NCAConfig(dim=3, kind="ff"), ga=ga, seed=seed,
                          backend=backend, starts=starts, resume=(out / "config.json").is_file(),
                          progress=False)
    return out, time.perf_counter() - wall


def rewalk(out: Path, seed: int, fresh: int) -> list[dict]:
    """Each generation's best robot of run `out`: recorded fitness and distance, and from
    `fresh` unseen starts."""
    with (out / "metrics.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    meta = json.loads((out / "config.json").read_text())["task"]
    physics = Physics.from_dict(meta["physics"])
    found = []
    for row in rows:
        generation = int(row["generation"])
        grid = np.asarray(Robot.load(out / "best" / f"gen_{generation:04d}.npy").grid)
        again = evaluate_robot(RobotJob(grid, physics, meta["duration"], fresh,
                                        FRESH_SEED + seed))
        _, metadata = load_nca(out / "best" / f"gen_{generation:04d}.npz")
        found.append({"generation": generation, "recorded_fitness": float(row["best"]),
                      "recorded_distance": metadata["distance"],
                      "fresh_fitness": again.fitness, "fresh_distance": again.distance,
                      "fresh_min": again.distance_min})
    return found


def summary(starts: int, rows: list[dict], walls: list[float], evaluations: int) -> dict:
    """The K's line of the report."""
    bias = [r["recorded_fitness"] - r["fresh_fitness"] for r in rows]
    kept = [r["fresh_distance"] / r["recorded_distance"] >= 0.9 for r in rows
            if r["recorded_distance"] > 1.0]
    finals = [r["fresh_fitness"] for r in rows]
    return {"starts": starts, "generations": len(rows), "mean_bias": float(np.mean(bias)),
            "max_bias": float(np.max(bias)), "kept_90": float(np.mean(kept)) if kept else None,
            "best_fresh_fitness": float(np.max(finals)),
            "wall_s_per_evaluation": float(np.sum(walls) / evaluations)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--starts", type=int, nargs="+", default=[1, 3])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--pop", type=int, default=24)
    parser.add_argument("--gens", type=int, default=15)
    parser.add_argument("--fresh", type=int, default=10)
    parser.add_argument("--root", type=Path, default=Path("runs/robust_scores"))
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    report = []
    for starts in args.starts:
        rows, walls = [], []
        for seed in args.seeds:
            out, wall = run(args.root, starts, seed, args.pop, args.gens)
            walls.append(wall)
            rows += rewalk(out, seed, args.fresh)
        line = summary(starts, rows, walls, len(args.seeds) * args.pop * args.gens)
        line["rows"] = rows
        report.append(line)
        print(json.dumps({k: v for k, v in line.items() if k != "rows"}), flush=True)
    if args.json is not None:
        args.json.write_text(json.dumps({"settings": vars(args) | {"root": str(args.root),
                                                                     "json": str(args.json)},
                                         "results": report}, indent=1))


if __name__ == "__main__":
    main()
