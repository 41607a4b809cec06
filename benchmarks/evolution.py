"""Evaluation throughput of the 3D locomotion pipeline on each backend, and a real short
evolution.

    python benchmarks/evolution.py backends [--pop 20] [--seed 0] [--bonds beam|tendons]
        [--scene stepper=mujoco --scene timestep_rule=stiffest_bond]
        [--scene pipeline=mujoco --scene contact_shape=point]
        [--backends serial process thread] [--json out.json]
    python benchmarks/evolution.py short-run [--dim 3] [--pop 100] [--gens 5]
        [--out runs/short3d] [--json out.json]
    python benchmarks/evolution.py profile [--pop 12] [--seed 0] [--json out.json]

`backends` grows one 3D population (the paper's initial genes, so most robots are large
blocks) and evaluates it serially, on 2 worker processes and on 2 threads: wall and CPU
time, evaluations per second, parallel efficiency, and the projected wall time of a
paper-size 3D run (100 x 300) at that rate. `short-run` runs a real evolution with the
paper's 3D GA (generations reduced) on 2 worker processes: evaluations per second, the best
fitness per generation and the projected wall time of the paper's 300 generations
(`benchmarks/speed.py --evolution` puts it into docs/performance.md). `profile` evaluates
one 3D population serially under cProfile: the share of its CPU time in the steps, in
`compile_robot` and in compile's parts (docs/gpu.md).
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import time
from dataclasses import dataclass, field

import numpy as np

from mjregen.growth.nca import NCAConfig
from mjregen.growth.networks import random_genomes
from mjregen.physics import Physics
from mjregen.search.backends import Backend, make_backend
from mjregen.search.ga import PRESETS
from mjregen.search.runs import run_evolution
from mjregen.tasks.evaluation import PopulationEvaluation
from mjregen.tasks.locomotion import LocomotionTask


def backends(args: argparse.Namespace) -> dict:
    overrides = dict(item.split("=", 1) for item in args.scene)
    physics = Physics().replace(**overrides)  # `pipeline=mujoco` switches pipeline first
    if args.bonds is not None:
        physics = physics.replace(bond_element=args.bonds)  # the voxel pipeline's
    bonds = getattr(physics.pipeline, "bond_element", "tendons")  # MuJoCo's: 8 tendons
    task = LocomotionTask(nca=NCAConfig(dim=3, kind="ff"), physics=physics)
    genomes = random_genomes(task.nca, args.pop, seed=args.seed)
    rows, reference = [], None
    for name in args.backends:
        workers = 1 if name == "serial" else 2
        with make_backend(name, workers=workers) as backend:
            wall, cpu = time.perf_counter(), time.process_time()
            result = task.evaluate(genomes, backend)
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        if reference is None:
            reference = result.fitness
        rows.append({
            "backend": name, "workers": workers, "wall_s": wall,
            "driver_cpu_s": cpu, "simulation_cpu_s": result.sim_cpu_time,
            "evals_per_s": args.pop / wall, "distinct_robots": result.n_distinct,
            "same_fitness_as_first_backend": bool(np.array_equal(result.fitness, reference)),
        })
    serial = next((row["wall_s"] for row in rows if row["backend"] == "serial"), None)
    for row in rows:
        row["parallel_efficiency"] = (serial / row["wall_s"] / row["workers"]
                                      if serial is not None else None)
        row["projected_paper_run_h"] = 100 * 300 / row["evals_per_s"] / 3600
    print(f"3D ff, population {args.pop} (seed {args.seed}), {physics.pipeline.name} "
          f"pipeline, {bonds} bonds, overrides {overrides or 'none'}, "
          f"{rows[0]['distinct_robots']} distinct robots")
    print(f"{'backend':8s} {'wall s':>8s} {'sim cpu s':>9s} {'evals/s':>8s} {'efficiency':>10s} "
          f"{'paper run h':>11s}")
    for r in rows:
        efficiency = r["parallel_efficiency"]
        print(f"{r['backend']:8s} {r['wall_s']:8.1f} {r['simulation_cpu_s']:9.1f} {r['evals_per_s']:8.3f} "
              f"{'—' if efficiency is None else f'{efficiency:.2f}':>10s} "
              f"{r['projected_paper_run_h']:11.1f}")
    return {"population": args.pop, "seed": args.seed, "pipeline": physics.pipeline.name,
            "bonds": bonds, "scene": overrides, "rows": rows}


@dataclass(frozen=True)
class SizeRecordingTask(LocomotionTask):
    """The locomotion task, recording each generation's mean robot size (voxels, the
    population's, empty robots included): a generation's cost grows with its robots."""

    sizes: list = field(default_factory=list, compare=False, repr=False)

    def evaluate(self, genomes: np.ndarray, backend: Backend) -> PopulationEvaluation:
        result = super().evaluate(genomes, backend)
        self.sizes.append(float(np.mean(result.details["voxels"])))
        return result


def short_run(args: argparse.Namespace) -> dict:
    """A real evolution (3D, or 2D with ``--dim 2``) with the paper's GA (population `--pop`,
    its truncation and elites shares) on 2 worker processes; its throughput and the
    projected wall time of the paper's generations (3D 300, 2D 500) at the measured mean
    time per generation."""
    preset = PRESETS[f"{args.dim}d"]
    ga = preset.scaled(args.pop).with_overrides(generations=args.gens)
    task = SizeRecordingTask(nca=NCAConfig(dim=args.dim, kind="ff"))
    rows = []
    wall = time.perf_counter()
    with make_backend("process", workers=2) as backend:
        run_evolution(task, ga, seed=args.seed, out=args.out, backend=backend, force=True,
                      on_generation=lambda row: rows.append(dict(row)))
    wall = time.perf_counter() - wall
    per_generation = [float(row["wall_time"]) for row in rows]
    evaluations = sum(int(row["evaluations"]) for row in rows)
    result = {"ga": ga.to_dict(), "seed": args.seed, "workers": 2,
              "best": [float(row["best"]) for row in rows],
              "generation_wall_s": per_generation,
              "evaluations_per_generation": [int(row["evaluations"]) for row in rows],
              "distinct_per_generation": [int(row["distinct"]) for row in rows],
              "mean_voxels_per_generation": task.sizes,
              "evaluations": evaluations, "wall_s": wall,
              "evaluations_per_s": evaluations / sum(per_generation),
              "projected_paper_run_h": float(np.mean(per_generation)) * preset.generations / 3600,
              "dim": args.dim}
    print(f"{evaluations} evaluations in {sum(per_generation):.1f} s "
          f"({result['evaluations_per_s']:.2f} per s); best per generation: "
          + " ".join(f"{b:.3f}" for b in result["best"])
          + f"; {preset.generations} generations at this pace: "
          f"{result['projected_paper_run_h']:.2f} h")
    return result


PROFILED = {  # what `profile` reports: (file name end, function name)
    "native steps": ("stepper.py", "step"),
    "compile_robot": ("compile.py", "compile_robot"),
    "compile: MuJoCo's spec.compile": ("~", "<built-in method mujoco._specs.compile>"),
    "compile: network time step (Lanczos)": ("timestep.py", "largest_eigenvalue"),
    "compile: the MjSpec's bodies": ("mjcf.py", "voxel_bodies"),
    "compile: bond arrays": ("model.py", "bond_tables"),
    "growth": ("nca.py", "grow"),
}


def profile(args: argparse.Namespace) -> dict:
    """CPU shares of one 3D population's serial evaluation (the paper's initial genes)."""
    task = LocomotionTask(nca=NCAConfig(dim=3, kind="ff"))
    genomes = random_genomes(task.nca, args.pop, seed=args.seed)
    profiler = cProfile.Profile()
    cpu = time.process_time()
    profiler.enable()
    result = task.evaluate(genomes, make_backend("serial"))
    profiler.disable()
    cpu = time.process_time() - cpu
    stats = pstats.Stats(profiler).stats
    shares = {}
    for label, (file_end, function) in PROFILED.items():
        cumulative = sum(entry[3] for (path, _, name), entry in stats.items()
                         if path.endswith(file_end) and name == function)
        shares[label] = cumulative / cpu
    voxels = result.details["voxels"]
    print(f"3D ff population of {args.pop} (seed {args.seed}): {voxels.min():.0f}-"
          f"{voxels.max():.0f} voxels, {cpu / args.pop:.3f} CPU s per robot")
    for label, share in shares.items():
        print(f"  {label}: {100 * share:.1f} %")
    return {"population": args.pop, "seed": args.seed, "cpu_s_per_robot": cpu / args.pop,
            "shares": shares}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("mode", choices=("backends", "short-run", "profile"))
    parser.add_argument("--pop", type=int, default=None,
                        help="population (default: backends 20, profile 12, short-run the "
                             "paper's 100)")
    parser.add_argument("--gens", type=int, default=5)
    parser.add_argument("--dim", type=int, choices=(2, 3), default=3,
                        help="short-run: the robots' dimension (the paper's GA of that "
                             "dimension)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="runs/short3d")
    parser.add_argument("--bonds", choices=("beam", "tendons"), default=None,
                        help="the voxel pipeline's bond element (backends mode; default: "
                             "beam)")
    parser.add_argument("--scene", action="append", default=[], metavar="KEY=VALUE",
                        help="a string field of the scene or the pipeline (backends mode), "
                             "e.g. stepper=mujoco, or pipeline=mujoco to switch pipeline")
    parser.add_argument("--backends", nargs="+", default=["serial", "process", "thread"],
                        choices=("serial", "process", "thread"),
                        help="backends to time (efficiency is relative to serial, if timed)")
    parser.add_argument("--json", help="also write the results here")
    args = parser.parse_args()
    if args.pop is None:
        args.pop = {"backends": 20, "profile": 12}.get(args.mode,
                                                       PRESETS[f"{args.dim}d"].population)
    modes = {"backends": backends, "short-run": short_run, "profile": profile}
    results = modes[args.mode](args)
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(results, handle, indent=2)


if __name__ == "__main__":
    main()
