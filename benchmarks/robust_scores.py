"""What scoring each robot from K starts buys: the selection bias of the best-of-K winner.

    python benchmarks/robust_scores.py --runs RUN [RUN ...] [--starts 12] [--ks 1 2 3 5]
        [--draws 2000] [--workers 2] [--json out.json]
    python benchmarks/robust_scores.py --mutants 100 --nca BEST.npz [...] [--sigma 0.1]

A GA keeps the robot with the highest score it has seen; with a noisy score it keeps a lucky
one. The pool: every distinct best-of-generation robot of the given run folders (the
contenders of real evolutions, ``RUN/best/gen_*.npy``), or, with ``--mutants``, the distinct
robots of that many children (the GA's mutation, σ ``--sigma``, seed 0) of each NCA given: a
generation around a good parent, where contenders are alike. Each is walked from ``--starts``
symmetry-broken starts (seed 0, default physics). Then, ``--draws`` times, each robot's
starts are shuffled, its first K give its score and the others its validation; the winner
(highest score) is compared with its validation. Prints, per K: the mean selection bias
(winner's score - its validation, fitness units), how often the winner is the pool's true
best (highest mean over all starts), the mean shortfall of the winner's true mean against
the true best's, and the cost (K walks per robot).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.search.backends import make_backend
from mjregen.tasks.evaluation import RobotJob, evaluate_robot
from mjregen.tasks.fitness import UNSTABLE_FITNESS, VOXEL_COST


def distinct(named: list[tuple[str, np.ndarray]]) -> list[tuple[str, np.ndarray]]:
    """The first of each distinct non-empty 3D grid."""
    seen, found = set(), []
    for name, grid in named:
        if grid.ndim == 3 and grid.any() and grid.tobytes() not in seen:
            seen.add(grid.tobytes())
            found.append((name, grid))
    return found


def best_of_generations(runs: list[Path]) -> list[tuple[str, np.ndarray]]:
    """(name, grid) of every distinct best-of-generation robot of `runs`."""
    return distinct([(f"{run.parent.name}/{run.name}/{path.stem}",
                      np.asarray(Robot.load(path).grid))
                     for run in runs for path in sorted((run / "best").glob("gen_*.npy"))])


def mutants(ncas: list[Path], count: int, sigma: float) -> list[tuple[str, np.ndarray]]:
    """(name, grid) of the distinct robots of `count` children of each NCA (seed 0)."""
    from mjregen.growth.checkpoint import load_nca
    from mjregen.growth.nca import grow

    named = []
    for path in ncas:
        nca, _ = load_nca(path)
        rng = np.random.default_rng(0)
        genomes = nca.genome[None] + sigma * rng.standard_normal((count, nca.genome.size))
        grids = grow(nca.config, genomes.astype(np.float32)).grids
        named += [(f"{path.stem}/child_{i}", grid) for i, grid in enumerate(grids)]
    return distinct(named)


def start_fitness(grids: list[np.ndarray], starts: int, workers: int) -> np.ndarray:
    """``(robots, starts)`` each robot's fitness from each start (the unstable penalty where
    a start diverged)."""
    jobs = [RobotJob(grid, Physics(), None, starts, 0) for grid in grids]
    with make_backend("process", workers=workers) as backend:
        outcomes = backend.map(evaluate_robot, jobs)
    fitness = np.empty((len(grids), starts))
    for row, (grid, outcome) in enumerate(zip(grids, outcomes)):
        if not outcome.ok:
            raise RuntimeError(f"robot {row}: {outcome.error}")
        distances = np.array(outcome.value.distances)
        cost = VOXEL_COST * np.count_nonzero(grid)
        fitness[row] = np.where(np.isfinite(distances), distances - cost, UNSTABLE_FITNESS[3])
    return fitness


def selection(fitness: np.ndarray, k: int, draws: int, seed: int = 0) -> dict:
    """The winner-of-K-starts statistics (module docstring) over `draws` shuffles."""
    rng = np.random.default_rng(seed)
    robots, starts = fitness.shape
    truth = fitness.mean(axis=1)
    best = int(np.argmax(truth))
    bias, hits, shortfall = [], 0, []
    for _ in range(draws):
        order = np.argsort(rng.random((robots, starts)), axis=1)
        shuffled = np.take_along_axis(fitness, order, axis=1)
        score, check = shuffled[:, :k].mean(axis=1), shuffled[:, k:].mean(axis=1)
        winner = int(np.argmax(score))
        bias.append(score[winner] - check[winner])
        hits += winner == best
        shortfall.append(truth[best] - truth[winner])
    return {"k": k, "mean_bias": float(np.mean(bias)), "true_best_share": hits / draws,
            "mean_shortfall": float(np.mean(shortfall)), "walks_per_robot": k}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", nargs="+", type=Path, default=[])
    parser.add_argument("--nca", nargs="+", type=Path, default=[])
    parser.add_argument("--mutants", type=int, default=0)
    parser.add_argument("--sigma", type=float, default=0.1)
    parser.add_argument("--starts", type=int, default=12)
    parser.add_argument("--ks", type=int, nargs="+", default=[1, 2, 3, 5])
    parser.add_argument("--draws", type=int, default=2000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    robots = (mutants(args.nca, args.mutants, args.sigma) if args.mutants
              else best_of_generations(args.runs))
    fitness = start_fitness([grid for _, grid in robots], args.starts, args.workers)
    spread = fitness.std(axis=1)
    print(f"{len(robots)} robots x {args.starts} starts; per-robot spread of fitness over "
          f"starts: median {np.median(spread):.3g}, max {spread.max():.3g}")
    rows = [selection(fitness, k, args.draws) for k in args.ks if k < args.starts]
    print("| K | selection bias (fitness) | winner is the true best | shortfall of the winner "
          "| walks per robot |\n|---|---|---|---|---|")
    for row in rows:
        print(f"| {row['k']} | {row['mean_bias']:.3f} | {row['true_best_share']:.0%} | "
              f"{row['mean_shortfall']:.3f} | {row['walks_per_robot']} |")
    if args.json is not None:
        args.json.write_text(json.dumps({
            "robots": [name for name, _ in robots], "fitness": fitness.tolist(),
            "selection": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
