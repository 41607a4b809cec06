"""Time NCA growth of a 3D population: batched vs one individual at a time.

    python benchmarks/growth.py [--population 100] [--repeats 7] [--threads N] [--load N]
        [--json out.json]

Prints, per network kind, the median wall and CPU seconds of growing the whole population
(10 steps + cleaning) in one batched call and as P separate calls. Random genomes
N(0, 0.1^2) from a fixed seed; every run grows the same robots.

`--load N` keeps N other processes busy meanwhile, as another run on the same cores or other
jobs on a cluster node do: growth runs its batches side by side on torch's thread count,
each on one thread, so that a thread that loses its core stalls no other.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import statistics
import time

import torch

from mjregen import __version__
from mjregen.growth.nca import NCAConfig, grow
from mjregen.growth.networks import random_genomes


def _time(fn, repeats: int) -> dict[str, float]:
    fn()  # warm-up
    walls, cpus = [], []
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        fn()
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
    return {"wall_s": statistics.median(walls), "cpu_s": statistics.median(cpus)}


def _busy() -> None:
    """A CPU-bound process: the load `--load` puts beside the growth."""
    while True:
        pass


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--population", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--threads", type=int, help="torch intra-op threads (default: torch's)")
    parser.add_argument("--load", type=int, default=0,
                        help="other busy processes during the timing (default 0)")
    parser.add_argument("--json", help="also write the results to this JSON file")
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    load = [multiprocessing.get_context("spawn").Process(target=_busy, daemon=True)
            for _ in range(args.load)]
    for process in load:
        process.start()
    results = {"mjregen": __version__, "population": args.population,
               "threads": torch.get_num_threads(), "load": args.load, "runs": []}
    print(f"3D growth of {args.population} robots, torch threads {torch.get_num_threads()}, "
          f"{args.load} busy processes beside it, median of {args.repeats}")
    print(f"{'net':5s} {'mode':14s} {'wall s':>8s} {'cpu s':>8s}")
    for kind in ("ff", "lstm"):
        config = NCAConfig(dim=3, kind=kind)
        genomes = random_genomes(config, args.population, seed=0)
        modes = {
            "batched": lambda: grow(config, genomes),
            "one-at-a-time": lambda: [grow(config, g) for g in genomes],
        }
        for mode, fn in modes.items():
            timing = _time(fn, args.repeats)
            results["runs"].append({"net": kind, "mode": mode, **timing})
            print(f"{kind:5s} {mode:14s} {timing['wall_s']:8.3f} {timing['cpu_s']:8.3f}")
    for process in load:
        process.terminate()
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)


if __name__ == "__main__":
    main()
