"""Evaluation throughput of the 3D locomotion pipeline on each backend, and a real short
evolution.

    python benchmarks/evolution.py backends [--pop 20] [--seed 0] [--rounds 2] [--bonds beam|tendons]
        [--scene stepper=mujoco --scene timestep_rule=stiffest_bond]
        [--scene pipeline=mujoco --scene contact_shape=point]
        [--backends serial process thread] [--json out.json]
    python benchmarks/evolution.py short-run [--dim 3] [--body grid] [--pop 100] [--gens 5]
        [--out runs/short3d] [--json out.json]
    python benchmarks/evolution.py profile [--pop 12] [--seed 0] [--json out.json]
    python benchmarks/evolution.py compare --before DIR [--rounds 2] [--gens 3]
        [--json throughput.json]
    python benchmarks/evolution.py starts [--ks 1 3] [--rounds 3] [--json starts.json]

`backends` grows one 3D population (the paper's initial genes, so most robots are large
blocks) and evaluates it serially, on 2 worker processes and on 2 threads: wall and CPU
time, evaluations per second, parallel efficiency, and the projected wall time of a
paper-size 3D run (100 x 300) at that rate. `short-run` runs a real evolution with the
paper's 3D GA (generations reduced) on 2 worker processes: evaluations per second, the best
fitness per generation and the projected wall time of the paper's 300 generations
(`benchmarks/speed.py --evolution` puts it into docs/performance.md). `profile` evaluates
one 3D population serially under cProfile: the share of its CPU time in the steps, in
`compile_robot` and in compile's parts (docs/gpu.md). `compare` measures the code of this
checkout beside an earlier one (`--before DIR`, e.g. made by `git worktree add DIR <commit>`),
interleaved round by round: a real evolution in 3D (population 100) and 2D (population 300)
of `--gens` generations on 2 worker processes, run as `mjregen evolve` by each checkout's own
code, and `profile` of each; `benchmarks/speed.py --throughput` puts it into
docs/performance.md. `starts` measures the CPU cost of a robust score from K starts
(`simulate_starts`, one compile for all) against one start, and how much of it the compile is.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from mjregen.grid import Robot
from mjregen.growth.nca import NCAConfig
from mjregen.growth.networks import random_genomes
from mjregen.physics import Physics
from mjregen.resources import asset
from mjregen.search.backends import Backend, make_backend
from mjregen.search.ga import PRESETS
from mjregen.search.runs import run_evolution
from mjregen.tasks.evaluation import PopulationEvaluation
from mjregen.tasks.locomotion import LocomotionTask


def _cpu_seconds() -> tuple[float, float, float]:
    """(CPU s the whole machine has been busy, CPU s of this process and its waited-for
    children, wall s): their differences over a measurement give the cores other work
    used meanwhile."""
    with open("/proc/stat") as handle:
        ticks = [int(v) for v in handle.readline().split()[1:]]
    busy = sum(ticks[:3]) + sum(ticks[5:8])  # user nice system, irq softirq steal
    own = sum(getattr(resource.getrusage(who), kind) for who in
              (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN) for kind in ("ru_utime", "ru_stime"))
    return busy / os.sysconf("SC_CLK_TCK"), own, time.perf_counter()


def _time_backend(task: LocomotionTask, genomes: np.ndarray, name: str) -> tuple[dict, np.ndarray]:
    """One evaluation of `genomes` on backend `name` (serial: 1 worker, else 2) as in a run,
    whose backend lives for all its generations: the backend is started and warmed up (its
    workers evaluate one genome each, timed as ``start_s``) before the timed evaluation, by
    a copy of `task` with an empty cache (the task keeps its robots' results between
    evaluations). Returns (times in s, the fitnesses)."""
    workers = 1 if name == "serial" else 2
    started = time.perf_counter()
    with make_backend(name, workers=workers) as backend:
        replace(task).evaluate(genomes[:workers], backend)
        start = time.perf_counter() - started
        wall, cpu = time.perf_counter(), time.process_time()
        result = replace(task).evaluate(genomes, backend)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    return ({"workers": workers, "start_s": start, "wall_s": wall, "driver_cpu_s": cpu,
             "simulation_cpu_s": result.sim_cpu_time, "distinct_robots": result.n_distinct},
            result.fitness)


def backends(args: argparse.Namespace) -> dict:
    """Each backend's evaluation of one 3D population, `args.rounds` interleaved rounds,
    medians (wall, the driver's CPU and the simulations' CPU, s)."""
    overrides = dict(item.split("=", 1) for item in args.scene)
    physics = Physics().replace(**overrides)  # `pipeline=mujoco` switches pipeline first
    if args.bonds is not None:
        physics = physics.replace(bond_element=args.bonds)  # the voxel pipeline's
    bonds = getattr(physics.pipeline, "bond_element", "tendons")  # MuJoCo's: 8 tendons
    task = LocomotionTask(nca=NCAConfig(dim=3, kind="ff"), physics=physics)
    genomes = random_genomes(task.nca, args.pop, seed=args.seed)
    before = _cpu_seconds()
    samples: dict[str, list[dict]] = {name: [] for name in args.backends}
    reference = None
    for _ in range(args.rounds):  # interleaved, so that the machine's noise falls on all
        for name in args.backends:
            sample, fitness = _time_backend(task, genomes, name)
            reference = fitness if reference is None else reference
            samples[name].append(sample | {"same": bool(np.array_equal(fitness, reference))})
    busy, own, elapsed = (after - start for after, start in zip(_cpu_seconds(), before))
    rows = []
    for name, runs in samples.items():
        wall = statistics.median(r["wall_s"] for r in runs)
        rows.append({
            "backend": name, "workers": runs[0]["workers"], "wall_s": wall,
            "wall_s_rounds": [r["wall_s"] for r in runs],
            "start_s": statistics.median(r["start_s"] for r in runs),
            "driver_cpu_s": statistics.median(r["driver_cpu_s"] for r in runs),
            "simulation_cpu_s": statistics.median(r["simulation_cpu_s"] for r in runs),
            "evals_per_s": args.pop / wall, "distinct_robots": runs[0]["distinct_robots"],
            "same_fitness_as_first_backend": all(r["same"] for r in runs),
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
    return {"population": args.pop, "seed": args.seed, "rounds": args.rounds,
            "other_work_cores": (busy - own) / elapsed,
            "pipeline": physics.pipeline.name, "bonds": bonds, "scene": overrides, "rows": rows}


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
    task = SizeRecordingTask(nca=NCAConfig(dim=args.dim, kind="ff"), body=args.body)
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
              "dim": args.dim, "body": args.body}
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
    "compile: bond arrays": ("model.py", "robot_bonds"),
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
        # the largest: a function of that name may call another of the same name (a
        # stepper's step wrapping the native one), whose time the outer one holds
        cumulative = max((entry[3] for (path, _, name), entry in stats.items()
                          if path.endswith(file_end) and name == function), default=0.0)
        shares[label] = cumulative / cpu
    voxels = result.details["voxels"]
    print(f"3D ff population of {args.pop} (seed {args.seed}): {voxels.min():.0f}-"
          f"{voxels.max():.0f} voxels, {cpu / args.pop:.3f} CPU s per robot")
    for label, share in shares.items():
        print(f"  {label}: {100 * share:.1f} %")
    return {"population": args.pop, "seed": args.seed, "cpu_s_per_robot": cpu / args.pop,
            "shares": shares}


COMPARED = {3: 100, 2: 300}  # `compare`: dimension -> population (the paper's)


def _commit(checkout: Path) -> str:
    return subprocess.run(["git", "-C", str(checkout), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True, check=True).stdout.strip()


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _run_in(checkout: Path, argv: list[str]) -> tuple[float, float]:
    """Run ``python argv`` with `checkout`'s package first on the path; (wall, CPU) s of it
    and its worker processes."""
    environment = {**os.environ, "PYTHONPATH": str(checkout)}
    wall, cpu = time.perf_counter(), _children_cpu()
    subprocess.run([sys.executable, *argv], cwd=checkout, env=environment, check=True,
                   stdout=subprocess.DEVNULL)
    return time.perf_counter() - wall, _children_cpu() - cpu


def _evolution_in(checkout: Path, dim: int, gens: int, seed: int) -> dict:
    """A real evolution by `checkout`'s `mjregen evolve` (the paper's GA of `dim`, its
    population, 2 worker processes): wall and CPU s, and its metrics per generation."""
    with tempfile.TemporaryDirectory() as folder:
        wall, cpu = _run_in(checkout, [
            "-m", "mjregen", "evolve", "--dim", str(dim), "--net", "ff", "--preset", f"{dim}d",
            "--pop", str(COMPARED[dim]), "--gens", str(gens), "--seed", str(seed),
            "--workers", "2", "--quiet", "--out", str(Path(folder) / "run")])
        with open(Path(folder) / "run" / "metrics.csv") as handle:
            header, *rows = [line.strip().split(",") for line in handle if line.strip()]
    rows = [dict(zip(header, row)) for row in rows]
    return {"wall_s": wall, "cpu_s": cpu,
            "generation_wall_s": [float(r["wall_time"]) for r in rows],
            "evaluations": sum(int(r["evaluations"]) for r in rows),
            "distinct": [int(r["distinct"]) for r in rows]}


def compare(args: argparse.Namespace) -> dict:
    """This checkout beside `args.before`, interleaved: evolutions (`COMPARED`) and
    `profile` of each, `args.rounds` rounds."""
    sides = {"before": Path(args.before).resolve(), "after": Path(__file__).resolve().parents[1]}
    runs = {f"{side} {dim}d": [] for side in sides for dim in COMPARED}
    for round_ in range(args.rounds):
        for dim in COMPARED:
            for side, checkout in sides.items():
                run = _evolution_in(checkout, dim, args.gens, args.seed)
                runs[f"{side} {dim}d"].append(run)
                print(f"round {round_}: {side} {dim}D {run['evaluations']} evaluations in "
                      f"{sum(run['generation_wall_s']):.1f} s", flush=True)
    profiles = {}
    for side, checkout in sides.items():
        with tempfile.TemporaryDirectory() as folder:
            out = Path(folder) / "profile.json"
            _run_in(checkout, [str(Path(__file__).resolve()), "profile", "--pop", str(args.pop),
                               "--seed", str(args.seed), "--json", str(out)])
            profiles[side] = json.loads(out.read_text())
    return {"commits": {side: _commit(checkout) for side, checkout in sides.items()},
            "gens": args.gens, "seed": args.seed, "rounds": args.rounds,
            "populations": {str(dim): pop for dim, pop in COMPARED.items()}, "runs": runs, "profiles": profiles}


def starts_cost(args: argparse.Namespace) -> dict:
    """CPU s of `simulate_starts` with each of `args.ks` starts, and of its compile, per
    robot (medians of `args.rounds`)."""
    # imported here: `compare` runs this script's `profile` against earlier checkouts
    from mjregen.physics import compile_robot
    from mjregen.physics.simulation import simulate_starts

    names = {name: asset("robots", "paper", f"{name}.npy")
             for name in ("tripod", "biped", "multiped")}
    result = {}
    for name, path in names.items():
        robot = Robot.load(path)
        samples = {k: [] for k in args.ks}
        compiles = {k: [] for k in args.ks}
        for _ in range(args.rounds):
            for k in args.ks:
                cpu = time.process_time()
                compile_robot(robot, starts=range(k))
                compiles[k].append(time.process_time() - cpu)
                cpu = time.process_time()
                simulate_starts(robot, starts=range(k))
                samples[k].append(time.process_time() - cpu)
        one = statistics.median(samples[args.ks[0]])
        result[name] = {"voxels": robot.n_voxels,
                        "cpu_s": {str(k): statistics.median(v) for k, v in samples.items()},
                        "compile_cpu_s": {str(k): statistics.median(v)
                                          for k, v in compiles.items()},
                        "x_first": {str(k): statistics.median(v) / one
                                    for k, v in samples.items()}}
        print(name, {k: f"{x:.2f}" for k, x in result[name]["x_first"].items()}, flush=True)
    return {"ks": args.ks, "rounds": args.rounds, "robots": result}


def _run_rate(runs: list[dict]) -> tuple[float, float, float]:
    """(evaluations per wall s of the generations, CPU s per evaluation, wall s per
    generation): medians over the runs."""
    rate = statistics.median(r["evaluations"] / sum(r["generation_wall_s"]) for r in runs)
    cpu = statistics.median(r["cpu_s"] / r["evaluations"] for r in runs)
    per_generation = statistics.median(statistics.mean(r["generation_wall_s"]) for r in runs)
    return rate, cpu, per_generation


def backends_section(measured: dict) -> list[str]:
    """docs/performance.md's section on the backends (`backends` results): processes
    against threads and one evaluation at a time."""
    lines = [
        "", "## Processes or threads", "",
        f"`python benchmarks/evolution.py backends --pop {measured['population']} --rounds "
        f"{measured['rounds']}`: one 3D population (the paper's initial genes, seed "
        f"{measured['seed']}, {measured['rows'][0]['distinct_robots']} distinct robots, "
        f"{measured['pipeline']} pipeline, {measured['bonds']} bonds) evaluated on each "
        "backend as in a run, whose backend lives for all its generations: started and warmed "
        "up first (its workers evaluate one genome each: start s), then timed, with an empty "
        "cache each time; the backends interleave round by round, medians of the rounds; other work "
        f"used {measured['other_work_cores']:.2f} of the machine's cores on average meanwhile "
        "(/proc/stat less this process's CPU). Driver CPU: the evaluating process's "
        "(the threads' simulations included, not the worker processes'); simulation CPU: "
        "the simulations' own, wherever they ran. Efficiency: serial wall time / (wall time x "
        "workers).", "",
        "| backend | workers | start s | wall s (rounds) | driver CPU s | simulation CPU s | "
        "evaluations / s | efficiency | the same fitnesses as serial |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in measured["rows"]:
        efficiency = r["parallel_efficiency"]
        lines.append(
            f"| {r['backend']} | {r['workers']} | {r['start_s']:.1f} | {r['wall_s']:.1f} "
            f"({', '.join(f'{w:.1f}' for w in r['wall_s_rounds'])}) | {r['driver_cpu_s']:.1f} | "
            f"{r['simulation_cpu_s']:.1f} | {r['evals_per_s']:.2f} | "
            f"{'–' if efficiency is None else f'{efficiency:.2f}'} | "
            f"{'yes' if r['same_fitness_as_first_backend'] else 'no'} |")
    return lines + ["", _backends_verdict(measured)]


def _backends_verdict(measured: dict) -> str:
    """What the rounds show about the parallel backends: each one's best round (the least
    disturbed by other work) and who was faster round by round; a median is called a
    difference only when one backend was faster in every round."""
    rows = {r["backend"]: r for r in measured["rows"]}
    serial = min(rows["serial"]["wall_s_rounds"]) if "serial" in rows else None
    parallel = [r for r in measured["rows"] if r["workers"] > 1]
    best = "; ".join(
        f"{r['backend']} {min(r['wall_s_rounds']):.1f} s"
        + (f" (efficiency {serial / (min(r['wall_s_rounds']) * r['workers']):.2f})"
           if serial else "") for r in parallel)
    text = (f"Best rounds, the least disturbed by other work: serial {serial:.1f} s; {best}."
            if serial else f"Best rounds: {best}.")
    if len(parallel) != 2:
        return text
    first, second = parallel
    wins = sum(a < b for a, b in zip(first["wall_s_rounds"], second["wall_s_rounds"]))
    rounds = len(first["wall_s_rounds"])
    if wins in (0, rounds):
        faster, slower = (first, second) if wins else (second, first)
        return (f"{text} {faster['backend'].capitalize()} was faster than {slower['backend']} "
                f"in every round ({rounds}).")
    return (f"{text} Neither was faster in every round ({first['backend']} in {wins} of "
            f"{rounds}): the difference of the medians is the other work's "
            f"({measured['other_work_cores']:.2f} cores on average), not the backends'; a "
            "difference needs a measurement on an idle machine.")


def throughput_section(compared: dict, starts: dict | None) -> list[str]:
    """docs/performance.md's section on evolutions before and after, the compile profile and
    the K-start cost (`compare` and `starts` results)."""
    commits = compared["commits"]
    lines = [
        "", "## Evolutions before and after", "",
        f"`python benchmarks/evolution.py compare --before DIR --rounds {compared['rounds']} "
        f"--gens {compared['gens']}` (DIR: `git worktree add DIR {commits['before']}`): the "
        f"code at {commits['before']} and at {commits['after']} each run a real evolution with "
        f"`mjregen evolve` (the paper's GA, seed {compared['seed']}, {compared['gens']} "
        "generations, 2 worker processes), interleaved round by round; medians of the rounds. "
        "CPU s include the worker processes. The projection is the paper's generations at the "
        "measured seconds per generation: the first generations grow the largest robots, so it "
        "is pessimistic (the finished paper-size runs below took 1.1-2.6 h in 3D). The code "
        f"after draws each walk's start shifted by 1e-4 voxel lengths (the robust fitness), "
        "which changes which robots later generations hold; generation 0 is the same "
        "population on both sides.", "",
        "| run | code | evaluations / s | CPU s per evaluation | s per generation | "
        "paper's generations at that pace (h) | goal (h) |",
        "|---|---|---|---|---|---|---|",
    ]
    for dim, generations, goal in ((3, 300, 1.0), (2, 500, 0.5)):
        for side in ("before", "after"):
            rate, cpu, per_generation = _run_rate(compared["runs"][f"{side} {dim}d"])
            lines.append(
                f"| {dim}D pop {compared['populations'][str(dim)]} × {generations} | "
                f"{commits[side]} | {rate:.2f} | {cpu:.3f} | {per_generation:.1f} | "
                f"{per_generation * generations / 3600:.2f} | {goal:g} |")
    profiles = compared["profiles"]
    labels = list(profiles["after"]["shares"])
    lines += [
        "", "Where one 3D population's CPU time goes (`evolution.py profile`, "
        f"{profiles['after']['population']} robots of the paper's initial genes, seed "
        f"{profiles['after']['seed']}, serial, cProfile; shares of the CPU time):", "",
        f"| part | {commits['before']} | {commits['after']} |", "|---|---|---|",
        *(f"| {label} | {100 * profiles['before']['shares'].get(label, 0.0):.1f} % | "
          f"{100 * profiles['after']['shares'][label]:.1f} % |" for label in labels),
        f"| CPU s per robot (under the profiler) | {profiles['before']['cpu_s_per_robot']:.3f} | "
        f"{profiles['after']['cpu_s_per_robot']:.3f} |",
    ]
    if starts is not None:
        lines += _starts_lines(starts)
    return lines


def _starts_lines(starts: dict) -> list[str]:
    ks = [str(k) for k in starts["ks"]]
    lines = [
        "", "### A robust score from K starts", "",
        f"`python benchmarks/evolution.py starts --ks {' '.join(ks)} --rounds "
        f"{starts['rounds']}`: CPU s of `simulate_starts` (one compile for all K starts) "
        "against one start, medians. Each start is shifted before the settle, so what K "
        "starts can share is the compile alone: the last column is the cost that sharing it "
        "gives, from the compile's share of one start (`compile_robot` timed alone), the "
        "rest paid once per start. The measured cost is that, to the rounds' noise: the "
        "walks from the K starts are the cost, and no reuse of the model reduces them.", "",
        "| robot | voxels | " + " | ".join(f"K = {k}: CPU s (× K = 1, of K)" for k in ks)
        + " | compile, share of one start | the compile shared, at K = " + ks[-1]
        + " (of K) |",
        "|---|---|" + "---|" * len(ks) + "---|---|",
    ]
    for name, row in starts["robots"].items():
        one = row["cpu_s"][ks[0]]
        compile_share = row["compile_cpu_s"][ks[0]] / one
        k = int(ks[-1])
        floor = (1 + (k - 1) * (1 - compile_share)) / k
        cells = [f"{row['cpu_s'][key]:.3f} ({row['x_first'][key]:.2f}×, "
                 f"{row['x_first'][key] / int(key):.2f})" for key in ks]
        lines.append(f"| {name} | {row['voxels']} | " + " | ".join(cells)
                     + f" | {100 * compile_share:.0f} % | {floor:.2f} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("mode", choices=("backends", "short-run", "profile", "compare", "starts"))
    parser.add_argument("--pop", type=int, default=None,
                        help="population (default: backends 20, profile 12, short-run the "
                             "paper's 100)")
    parser.add_argument("--gens", type=int, default=None,
                        help="generations (default: short-run 5, compare 3)")
    parser.add_argument("--dim", type=int, choices=(2, 3), default=3,
                        help="short-run: the robots' dimension (the paper's GA of that "
                             "dimension)")
    parser.add_argument("--body", choices=("grid", "sheet"), default="grid",
                        help="short-run: how a grown grid becomes the robot (--dim 2 sheet: "
                             "the paper's 2D robots; mjregen.tasks.bodies)")
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
    parser.add_argument("--before", type=Path,
                        help="compare: a checkout of the earlier code (git worktree add DIR "
                             "COMMIT)")
    parser.add_argument("--rounds", type=int, default=2,
                        help="backends, compare and starts: interleaved rounds (medians)")
    parser.add_argument("--ks", type=int, nargs="+", default=[1, 3],
                        help="starts: numbers of starts (the first is the reference)")
    parser.add_argument("--json", help="also write the results here")
    args = parser.parse_args()
    if args.pop is None:
        args.pop = {"backends": 20, "profile": 12}.get(args.mode,
                                                       PRESETS[f"{args.dim}d"].population)
    if args.mode == "compare" and args.before is None:
        parser.error("compare needs --before DIR")
    if args.gens is None:
        args.gens = 3 if args.mode == "compare" else 5
    modes = {"backends": backends, "short-run": short_run, "profile": profile,
             "compare": compare, "starts": starts_cost}
    results = modes[args.mode](args)
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(results, handle, indent=2)


if __name__ == "__main__":
    main()
