"""CPU and wall time of one locomotion evaluation, side by side with the paper's engine.

For each robot (the paper's tripod, biped and multiped, 7×7×7 blocks all soft and soft with
muscles, a 112-voxel slab, a 2D sheet, the shipped evolved 3D walkers) and each model of
`MODELS`, `--rounds` interleaved rounds of: the paper's engine on the same grid (optional,
``--voxelyze DIR``: a folder with ``vxa.py`` whose ``run(grid)`` returns the engine
process's CPU seconds), then one `simulate` call per model in this warm process (compile
included). Reported: medians of CPU and wall seconds, steps, µs per voxel-step, and the
ratio of CPU seconds to the engine's (< 1: faster). CPU time, because machines are shared.

    python benchmarks/speed.py --voxelyze PATH/TO/voxelyze [--rounds 5]
        [--models default mj-step] [--robots paper_tripod ...] [--json out.json]
        [--doc docs/performance.md [--evolution evolution.json]]

``--doc`` also measures the start-up of ``mjregen walk`` (a fresh process), the time-step
analysis of each robot and the tripod's sensitivity to its initial state, and writes the
whole report (the table of `speed_before.json` as the before; ``--evolution``: the JSON of
``benchmarks/evolution.py short-run``).
"""

from __future__ import annotations

import argparse
import csv
import datetime
import importlib.util
import json
import math
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

from mjregen.experiments.paper import list_runs
from mjregen.grid import Robot
from mjregen.physics import Physics, timestep
from mjregen.physics.compile import CompiledRobot, compile_robot, network_rule_rates
from mjregen.physics.model import robot_layout
from mjregen.physics.simulation import simulate, simulation_of
from mjregen.physics.plugin_cache import FLAGS, cpu_features
from mjregen.validation.engine import PaperEngine

ROOT = Path(__file__).resolve().parents[1]
MODELS = {
    "default": {},  # the voxel plugin, its fast path of mj_step, the network time step
    "mj-step": {"stepper": "mujoco"},  # the same model stepped by mj_step
    "tendon-bonds": {"bond_element": "tendons"},  # the plugin with 8 tendons per bond
    "stiffest-bond": {"timestep_rule": "stiffest_bond"},  # the step of the stiffest block
    # the pure-MuJoCo pipeline nearest the default: MuJoCo tendons, point contacts with the
    # engine floor's constants, collision spheres, viscosity, the network time step
    "pure-mujoco": {"pipeline": "mujoco", "contact_shape": "point", "bond_model": "euler_bernoulli",
                    "contact_damping": 0.8, "collision_radius": 0.625, "timestep_rule": "network"},
}


def robots() -> dict[str, Robot]:
    rng = np.random.default_rng(0)
    out = {}
    for name in ("tripod", "biped", "multiped"):
        out[f"paper_{name}"] = Robot.load(ROOT / "assets" / "robots" / "paper" / f"{name}.npy")
    out["block_7x7x7_soft"] = Robot.box((7, 7, 7))
    out["block_7x7x7_muscle"] = Robot.from_body(
        rng.choice([1, 3, 4], size=(7, 7, 7)).astype(np.int8))
    slab = np.ones((7, 4, 4), dtype=np.int8)
    slab[:, :, 0] = np.where(np.arange(7)[:, None] % 2 == 0, 3, 4)  # legs: red/green
    slab[:, :, 3] = 4
    out["slab_3d_112"] = Robot.from_body(slab)
    out["square_2d_5x5"] = Robot.from_body(rng.choice([1, 2, 3, 4], size=(5, 5)).astype(np.int8))
    for path in sorted((ROOT / "assets" / "nca").glob("walker_3d_*.npy")):
        out[f"evolved_{path.stem}"] = Robot.load(path)
    for i, robot in enumerate(initial_population(RANDOM_ROBOTS)):
        out[f"random_3d_{i}"] = robot
    return out


def initial_population(count: int, seed: int = 0) -> list[Robot]:
    """The first `count` distinct non-empty robots of the paper's 3D GA's first generation
    (seed `seed`): what the start of a 3D evolution simulates."""
    from mjregen.growth.nca import NCAConfig, grow
    from mjregen.search.ga import PRESETS, GeneticAlgorithm

    config = NCAConfig(dim=3, kind="ff")
    genomes = GeneticAlgorithm(PRESETS["3d"], config.genome_size, seed=seed).ask()
    robots, seen = [], set()
    for grid in grow(config, genomes).grids:
        if grid.any() and grid.tobytes() not in seen:
            seen.add(grid.tobytes())
            robots.append(Robot(grid))
    return robots[:count]


def evaluate(robot: Robot, physics: Physics) -> dict:
    wall, cpu = time.perf_counter(), time.process_time()
    result = simulate(robot, physics=physics)
    return {"cpu_s": time.process_time() - cpu, "wall_s": time.perf_counter() - wall,
            "steps": result.steps, "distance": result.distance, "stable": result.stable}


def measure(names: list[str], models: list[str], rounds: int, engine) -> dict:
    """{robot: {model or "voxelyze": [per-round dicts]}}, rounds interleaved."""
    table = robots()
    physics = {m: Physics().replace(**MODELS[m]) for m in models}
    samples = {name: {key: [] for key in ["voxelyze", *models]} for name in names}
    for name in names:  # warm up: library build, imports, first compile
        evaluate(table[name], physics[models[0]])
    for k in range(rounds):
        for name in names:
            robot = table[name]
            if engine is not None and robot.dim == 3:
                samples[name]["voxelyze"].append(engine(robot.grid))
            for model in models:
                samples[name][model].append(evaluate(robot, physics[model]))
        print(f"round {k + 1}/{rounds} done", flush=True)
    return samples


def summary(samples: dict, robots_by_name: dict[str, Robot]) -> dict:
    out = {}
    for name, runs in samples.items():
        n = robots_by_name[name].n_voxels
        engine = statistics.median(r["cpu_s"] for r in runs["voxelyze"]) if runs["voxelyze"] \
            else None
        row = {"voxels": n, "voxelyze_cpu_s": engine}
        for model, values in runs.items():
            if model == "voxelyze" or not values:
                continue
            cpu = statistics.median(v["cpu_s"] for v in values)
            steps = values[0]["steps"]
            row[model] = {"cpu_s": cpu, "wall_s": statistics.median(v["wall_s"] for v in values),
                          "steps": steps, "us_per_voxel_step": 1e6 * cpu / (steps * n),
                          "distance": values[0]["distance"],
                          "ratio_to_voxelyze": None if engine is None else cpu / engine}
        out[name] = row
    return out


def markdown(report: dict, models: list[str]) -> str:
    head = ("| robot | N | Voxelyze -O3 CPU s | "
            + " | ".join(f"{m} CPU s | {m} / Voxelyze" for m in models) + " | steps |")
    lines = [head, "|" + "---|" * (4 + 2 * len(models))]
    for name, row in report.items():
        engine = row["voxelyze_cpu_s"]
        cells = []
        for model in models:
            r = row[model]
            ratio = "" if r["ratio_to_voxelyze"] is None else f"{r['ratio_to_voxelyze']:.2f}"
            cells.append(f"{r['cpu_s']:.3f} | {ratio}")
        lines.append(f"| {name} | {row['voxels']} | "
                     f"{'' if engine is None else f'{engine:.3f}'} | " + " | ".join(cells)
                     + f" | {row[models[0]]['steps']} |")
    return "\n".join(lines)


RANDOM_ROBOTS = 6  # robots of a random initial 3D population in the report
DOC_ROBOTS = {"paper_tripod": "tripod", "paper_biped": "biped", "paper_multiped": "multiped",
              "block_7x7x7_soft": "7×7×7 all soft", "block_7x7x7_muscle": "7×7×7 soft and muscle",
              "slab_3d_112": "112-voxel slab, no hard", "square_2d_5x5": "2D 5×5 square (x-z plane)",
              **{f"random_3d_{i}": f"random initial robot {i}" for i in range(RANDOM_ROBOTS)}}
ENGINE_DT_FRACTION = 0.9  # the paper's DtFrac: step = 0.9 / (2π sqrt(k/m)), k = E L


def engine_steps(robot: Robot, physics: Physics, duration: float = 0.55) -> int:
    """Steps of the paper's engine in `duration` s: its rule takes the stiffest material
    present, k = E L over the voxel mass."""
    length = physics.scene.voxel_size
    rate = max(physics.materials[m].youngs_modulus * length / physics.voxel_mass(m)
               for _, m in robot.voxels())
    return round(duration / (ENGINE_DT_FRACTION / (2.0 * math.pi * math.sqrt(rate))))


def step_analysis(robots_by_name: dict[str, Robot]) -> dict:
    """Per robot: the network rule's λ, μ, the fastest mode's damping ratio μ / (2√λ), our
    steps, the engine's, the step ratio that the damping costs (undamped / damped
    stability limit), the median over the voxels' sliding dofs of h C_ii / m (the mass
    a step taking each dof's own damping implicitly would add, relatively) and the limit
    with the voxels' rotations held (infinite rotational inertia) over the limit."""
    physics = Physics()
    out = {}
    for name, robot in robots_by_name.items():
        compiled = compile_robot(robot, physics=physics)
        settle, measured = physics.scene.timing(robot.dim)
        row = {"steps": round(settle / compiled.timestep) + round(measured / compiled.timestep),
               "engine_steps": engine_steps(robot, physics) if robot.dim == 3 else None}
        if compiled.network_rates is not None:
            stiffness, damping = compiled.network_rates
            own = timestep.own_damping_rates(compiled.model, voxel_size=physics.scene.voxel_size,
                                             instance=compiled.plugin_instance)
            rotational = timestep.rotational_dofs(compiled.model)
            row.update(stiffness_rate=stiffness, damping_rate=damping,
                       zeta=damping / (2.0 * math.sqrt(stiffness)),
                       damping_cost=timestep.stable_step(stiffness, 0.0)
                       / timestep.stable_step(stiffness, damping),
                       own_damping_step=float(np.median(own[~rotational])) * compiled.timestep,
                       damping_step=damping * compiled.timestep,
                       rotations_held=timestep.stable_step(*held_rates(compiled, rotational))
                       / timestep.stable_step(stiffness, damping))
        out[name] = row
    return out


def held_rates(compiled: CompiledRobot, held: np.ndarray) -> tuple[float, float]:
    """(λ s⁻², μ s⁻¹) of the network rule of an unclamped `compiled` robot with the dofs
    `held` still."""
    layout = robot_layout(compiled.robot, compiled.physics, set(), 0.0)
    return network_rule_rates(compiled.model, layout, compiled.physics, compiled.bonds,
                              held=held)


def chaos(robot: Robot, runs: int = 6, size: float = 1e-13) -> dict:
    """Distances (voxel lengths) of `robot` after moving every voxel by `size` m at random
    (N(0, size²) per axis) before the settle: how much a rounding-level change alters it."""
    physics = Physics()
    settle, measured = physics.scene.timing(robot.dim)
    distances = []
    for seed in range(runs):
        compiled = compile_robot(robot, physics=physics)
        sim = simulation_of(compiled)
        rng = np.random.default_rng(seed)
        positions = sim.data.qpos.reshape(-1, 7)
        positions[:, :3] += size * rng.standard_normal((len(positions), 3))
        dt = compiled.timestep
        sim.run(round(settle / dt))
        start = sim.com()
        sim.run(round(measured / dt))
        distances.append(float(np.linalg.norm((sim.com() - start)[:2])) / physics.scene.voxel_size)
    return {"size_m": size, "distances": distances,
            "unperturbed": simulate(robot, physics=physics).distance}


def startup(rounds: int = 5) -> dict:
    """Median CPU s of fresh processes: ``mjregen walk`` of the tripod with no simulated
    time (imports, command line, plugin, compile, JSON), and importing numpy and mujoco."""
    tripod = ROOT / "assets" / "robots" / "paper" / "tripod.npy"
    commands = {
        "walk": [sys.executable, "-m", "mjregen", "walk", str(tripod), "--json", "--settle", "0",
                 "--duration", "0"],
        "imports": [sys.executable, "-c", "import numpy, mujoco"],  # as the command does
        "python": [sys.executable, "-c", "pass"],
    }
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["MUJOCO_GL"] = "disable"  # what mjregen walk sets for itself
    env["OPENBLAS_NUM_THREADS"] = "1"  # and this
    out = {}
    for name, command in commands.items():
        samples = []
        for _ in range(rounds):
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            subprocess.run(command, check=True, stdout=subprocess.DEVNULL, env=env)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            samples.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
        out[name] = statistics.median(samples)
    return out


RECORDS = {  # records of paper-size runs: (conditions at the paper's scale, how they ran)
    ROOT / "records" / "results": (("3d_ff", "3d_lstm"), "2 worker processes per run"),
    ROOT / "records" / "paper": (("3d_ff", "3d_lstm", "2d_ff", "2d_lstm"),
                                 "one run per core (serial), two at once"),
}
RUN_SETTINGS = {  # runs that ran otherwise than their records folder's others
    "paper/3d_ff/seed_4": "2 worker processes, alone on the machine",
    "paper/qd/ga/seed_2": "2 worker processes, alone on the machine",
}


def _metrics(folder: Path) -> list[dict]:
    """The rows of a run folder's metrics.csv (strings, by column)."""
    with open(folder / "metrics.csv", newline="") as handle:
        return list(csv.DictReader(handle))


def recorded_evolutions(root: Path, conditions: tuple[str, ...] = ("3d_ff", "3d_lstm"),
                        how: str = "") -> list[dict]:
    """Per paper-size evolution of `conditions` kept in `root` (<condition>/seed_<n>):
    generations done of its planned ones, wall hours (the generations' own, summed),
    evaluations per second, the wall hours of all its planned generations at that rate, and
    at its median generation's wall time (s; robust to pauses of the machine)."""
    runs = []
    for condition, infos in list_runs(root).items():
        if condition not in conditions:
            continue
        for info in infos:
            rows = _metrics(info.path)
            simulated = sum(int(row["distinct"]) for row in rows)
            median_s = statistics.median(float(row["wall_time"]) for row in rows)
            population = info.config["ga"]["population"]
            last = info.best_files(info.generations_done - 1)[1]
            key = f"{root.name}/{condition}/seed_{info.seed}"
            runs.append({
                "run": f"{condition} seed {info.seed}", "records": root.name,
                "how": RUN_SETTINGS.get(key, how),
                "population": population,
                "generations": info.generations_done, "planned": info.generations_planned,
                "complete": info.complete, "wall_h": info.elapsed / 3600,
                "evaluations_per_s": population * info.generations_done / info.elapsed,
                "simulated_per_s": simulated / info.elapsed,
                "planned_h": info.elapsed * info.generations_planned / info.generations_done
                / 3600,
                "median_generation_s": median_s,
                "median_h": median_s * info.generations_planned / 3600,
                "last_best_voxels": (int(np.count_nonzero(np.load(last)))
                                     if last.is_file() else None),
            })
    return runs


def all_recorded_evolutions() -> list[dict]:
    """`recorded_evolutions` of every records folder in `RECORDS`."""
    return [run for root, (conditions, how) in RECORDS.items()
            for run in recorded_evolutions(root, conditions, how)]


def recorded_bullets(recorded: list[dict]) -> list[str]:
    """The Result bullets on the finished paper-size runs, per records folder and dimension."""
    lines = []
    for records, how in dict.fromkeys((r["records"], r["how"]) for r in recorded):
        for dim in ("3d", "2d"):
            done = [r for r in recorded if r["complete"] and (r["records"], r["how"]) ==
                    (records, how) and r["run"].startswith(dim)]
            if done:
                wall = _span([r["wall_h"] for r in done])
                median = _span([r["median_h"] for r in done])
                lines.append(
                    f"- The finished paper-size {dim.upper()} evolutions of `records/{records}/` "
                    f"({len(done)}; population {done[0]['population']} × {done[0]['planned']} "
                    f"generations, {how}): **{wall} h** of wall time"
                    + (f" each; at each run's median generation {median} h" if len(done) > 1
                       else f"; at its median generation {median} h") + " (table below).")
    two_cores = two_core_runs()
    if two_cores:
        lines.append("- Paper-size 3D runs on 2 cores with nothing beside them (whole, or "
                     "projected from their first generations measured): "
                     + ", ".join(f"**{r['projected_h']:.2f} h** (`{r['reference']}`, "
                                 f"{_measured_part(r)}, {_workers(r['command'])})"
                                 for r in two_cores)
                     + " (section \"The same evolution again, and on 2 cores\").")
    return lines


def _measured_part(run: dict) -> str:
    """"measured whole" or "N generations measured" of a `two_core_runs` entry."""
    if run["generations_done"] == run["planned"]:
        return "measured whole"
    return f"{run['generations_done']} generations measured"


def _span(values: list[float]) -> str:
    """'low–high' of `values` (2 decimals), or the one value."""
    low, high = f"{min(values):.2f}", f"{max(values):.2f}"
    return low if low == high else f"{low}–{high}"


REPEATED = ROOT / "records" / "paper" / "qd" / "ga"  # the QD comparison's GA: 3d_ff seeds again
ORIGINALS = ROOT / "records" / "paper" / "3d_ff"
TWO_CORES = Path(__file__).with_name("paper_run_2_cores.json")  # a paper run's start on 2 cores
SAME_COLUMNS = ("best", "mean", "std")  # equal in every generation: the same evolution


def _same_evolution(rows: list[dict], reference: list[dict]) -> bool:
    """Whether `rows` (generations of a run) equal the first generations of `reference` in
    best, mean and std fitness, to the digits metrics.csv keeps."""
    return len(rows) <= len(reference) and all(
        row[k] == ref[k] for row, ref in zip(rows, reference) for k in SAME_COLUMNS)


def _hours(rows: list[dict]) -> float:
    return sum(float(row["wall_time"]) for row in rows) / 3600


def repeated_runs() -> list[dict]:
    """Each 3d_ff run of records/paper that the QD comparison's GA ran again: its
    generations in both, wall hours of those generations in each, and whether they are the
    same evolution."""
    out = []
    for rerun in sorted(REPEATED.glob("seed_*")):
        original = ORIGINALS / rerun.name
        if not ((rerun / "metrics.csv").is_file() and (original / "metrics.csv").is_file()):
            continue
        again, first = _metrics(rerun), _metrics(original)
        n = min(len(again), len(first))
        out.append({"run": f"3d_ff {rerun.name.replace('_', ' ')}", "generations": n,
                    "original_h": _hours(first[:n]), "again_h": _hours(again[:n]),
                    "how": RUN_SETTINGS.get("/".join(rerun.parts[-4:]),
                                            "one run per core, beside another"),
                    "same": _same_evolution(again[:n], first)})
    return out


def two_core_runs(path: Path | None = None) -> list[dict]:
    """The measured starts of paper runs on 2 cores (`path`, default TWO_CORES: a list of
    measurements), each projected to all its generations by its reference run's share of
    time in those generations ([] without the file).

    Raises:
      ValueError: a measurement's generations are not its reference run's evolution.
    """
    path = TWO_CORES if path is None else path
    if not path.is_file():
        return []
    out = []
    for measured in json.loads(path.read_text()):
        reference = _metrics(ROOT / measured["reference"])
        rows = measured["generations"]
        if not _same_evolution(rows, reference):
            raise ValueError(f"{path}: {measured['what']}: its generations are not those of "
                             f"{measured['reference']}")
        share = _hours(reference[: len(rows)]) / _hours(reference)
        wall = _hours(rows) * 3600
        out.append({**measured, "generations_done": len(rows), "planned": len(reference),
                    "wall_s": wall, "share": share, "projected_h": wall / share / 3600})
    return out


def _workers(command: str) -> str:
    """"2 threads" or "2 processes": the workers of a measured run's command line (the
    evolve command's --backend default and the QD comparison's backend: processes)."""
    words = command.split()
    count = words[words.index("--workers") + 1] if "--workers" in words else "?"
    kind = words[words.index("--backend") + 1] if "--backend" in words else "process"
    return f"{count} {'threads' if kind == 'thread' else 'processes'}"


def repeated_section() -> list[str]:
    """The section on records' runs evolved again: their wall times, and runs' starts on 2
    cores with nothing beside them."""
    repeated, two_cores = repeated_runs(), two_core_runs()
    if not repeated and not two_cores:
        return []
    lines = ["## The same evolution again, and on 2 cores", "",
             "A run's recorded wall time depends on what else the machine did meanwhile. The "
             "GA runs of the quality-diversity comparison evolve 3d_ff seeds 0-2 of "
             "`records/paper/` again, days later with the code of their day (the first runs: "
             "one run per core, beside another); where their best, mean and std fitness equal "
             "the first run's in every generation, the two are the same evolution and only the "
             "time differs (what slowed the first run, other work beside it, the machine's "
             "speed that day or the code of its day, the table does not tell).", "",
             "| run | generations compared | same evolution | first run (h) | again (h) "
             "| how it ran again | first / again |",
             "|---|---|---|---|---|---|---|"]
    lines += [f"| {r['run']} | {r['generations']} | {'yes' if r['same'] else 'no'} | "
              f"{r['original_h']:.2f} | {r['again_h']:.2f} | {r['how']} | "
              f"{r['original_h'] / r['again_h']:.2f} |" for r in repeated]
    if two_cores:
        lines += ["", "On 2 cores, nothing else running on the machine (each measurement's "
                  "command, under `/usr/bin/time -v`, is in "
                  "`benchmarks/paper_run_2_cores.json`): each measurement is the same "
                  "evolution as its reference run in every generation measured, and a part of a "
                  "run is projected to all of the run's generations by the reference's share of "
                  "time in those generations. CPU: the whole process's and its worker "
                  "processes' (start-up, and a generation stopped part way, included).", "",
                  "| measured | workers | date, commit | reference (its share of time in those "
                  "generations) | generations' wall time (s) | process CPU / wall (s) | all "
                  "generations on 2 cores (h) |",
                  "|---|---|---|---|---|---|---|"]
        lines += [f"| {r['what']} | {_workers(r['command'])} | {r['date']}, {r['commit']} | "
                  f"`{r['reference']}` ({r['share']:.1%}) | {r['wall_s']:.0f} | "
                  f"{r['process_cpu_s']:.0f} / {r['process_wall_s']:.0f} | "
                  f"**{r['projected_h']:.2f}** |" for r in two_cores]
    return lines


def recorded_section(recorded: list[dict]) -> list[str]:
    """The section on the paper-size evolutions kept in records/."""
    lines = [
        "## The evolutions at the paper's scale",
        "",
        "The paper-size runs kept in `records/` (`metrics.csv`: each generation's wall time, "
        "summed), on the 2-core machine of their day: those of `records/results/` on 2 "
        "worker processes each, some beside other work (test suites, benchmarks, another "
        "run), so the fastest is the nearest to the machine's own rate; those of "
        "`records/paper/` one run per core (`--backend serial`), two runs at once, so two "
        "cores finish two runs in the time of one (a run's hours on 2 cores are half its "
        "own), some paused or resumed across sessions (the median generation's time is "
        "robust to both), except where the table says otherwise. Evaluations count the "
        "population; the GA's cache simulates each distinct genome once. A step costs in "
        "proportion to the voxels, so a run whose robots stay small is cheaper: the last "
        "column counts the voxels of its last generation's best robot.",
        "",
        "| run | records | how it ran | generations | wall h | evaluations / s | robots "
        "simulated / s | all generations at that rate (h) | median s per generation | all "
        "generations at the median (h) | last best robot's voxels |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    lines += [f"| {r['run']} | {r['records']} | {r['how']} | "
              f"{r['generations']} of {r['planned']} | "
              f"{r['wall_h']:.2f} | {r['evaluations_per_s']:.2f} | {r['simulated_per_s']:.2f} | "
              f"{r['planned_h']:.2f} | {r['median_generation_s']:.1f} | {r['median_h']:.2f} | "
              f"{'' if r['last_best_voxels'] is None else r['last_best_voxels']} |"
              for r in recorded]
    return lines


def _machine() -> str:
    model = next((line.split(":", 1)[1].strip() for line in cpu_features().splitlines()
                  if line.startswith("model name")), platform.processor() or platform.machine())
    return (f"{model}, {os.cpu_count()} cores, Python {platform.python_version()}, MuJoCo "
            f"{mujoco.__version__}, {datetime.date.today().isoformat()}")


def _ratio_range(report: dict, names: list[str]) -> str:
    ratios = [report[n]["default"]["ratio_to_voxelyze"] for n in names
              if n in report and report[n]["default"].get("ratio_to_voxelyze") is not None]
    return f"{min(ratios):.2f}–{max(ratios):.2f}" if ratios else "not measured"


def _vector_unit() -> str:
    """The widest x86 vector instructions this CPU has, as `-march=native` uses them."""
    flags = set(cpu_features().split())
    return "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else "the CPU's vectors"


def _total_ratio(report: dict, names: list[str]) -> float:
    """mjregen's CPU time over the engine's, summed over the robots `names`."""
    return (sum(report[n]["default"]["cpu_s"] for n in names)
            / sum(report[n]["voxelyze_cpu_s"] for n in names))


def implicit_damping_paragraph(steps: dict, safety: float) -> list[str]:
    """Lines of the doc on taking the dampers implicitly, from `step_analysis`'s rows (none
    when no robot has a bond network)."""
    analysed = {name: row for name, row in steps.items() if "zeta" in row}
    if not analysed:
        return []
    costs = [row["damping_cost"] for row in analysed.values()]
    costliest = max(analysed, key=lambda name: analysed[name]["damping_cost"])
    row = analysed[costliest]
    longest = row["damping_cost"] / safety
    return [
        "",
        "Taking the dampers implicitly would lift the damped limit towards the undamped one "
        f"(the table's {min(costs):.1f}–{max(costs):.1f} ×), but they couple every voxel to "
        "its neighbours (C = βK over the bond network), so the step would solve "
        "(M + hC) v' = M v + h f each time. Taking only each dof's own damping implicitly "
        "(its neighbours' at the last step) needs no solve, but is the same as adding h C_ii "
        "to the dof's mass: the h C_ii / m column (median over the voxels' sliding dofs, at "
        "mjregen's step) says by how much, relatively, and that extra mass would slow the "
        "slow modes, the gait, as much as the fast ones. The full solve by conjugate "
        "gradients costs one bond-damping pass (most of a step's work) per iteration, and "
        "(M + hC) has condition number up to 1 + hμ: on the "
        f"{DOC_ROBOTS.get(costliest, costliest)}, {1.0 + row['damping_step']:.1f} at mjregen's "
        f"step and {1.0 + row['damping_step'] * longest:.1f} at the undamped limit, so tens "
        "of iterations to the motion's accuracy, for a step at most "
        f"{longest:.1f} × longer. Neither pays.",
    ]


def rotational_inertia_paragraph(steps: dict) -> list[str]:
    """Lines of the doc on the voxels' rotational inertia as a lever, from `step_analysis`'s
    rows (none when no robot has a bond network)."""
    gains = {name: row["rotations_held"] for name, row in steps.items() if "zeta" in row}
    if not gains:
        return []
    most = max(gains, key=gains.get)
    return [
        "",
        "A larger rotational inertia of the voxels (a lever common in explicit voxel and "
        "particle codes) cannot lengthen the step much: at its extreme, the rotations held "
        "still, the damped limit grows by only "
        f"{100 * (min(gains.values()) - 1):.1f}–{100 * (max(gains.values()) - 1):.1f} % "
        f"(the table's last column; most on the {DOC_ROBOTS.get(most, most)}). The fastest "
        "modes slide the voxels against each other (axial and transverse bond modes), so "
        "their rate is set by the voxels' mass, which is the physics.",
    ]


def explicit_schemes_paragraph(steps: dict, safety: float,
                               hertz: float | None = None) -> list[str]:
    """Lines of the doc on other explicit schemes (`explicit_schemes.comparison` on each
    robot's λ, μ; the slow mode at the muscles' frequency), none when no robot has a bond
    network."""
    schemes = _sibling("explicit_schemes")
    hertz = Physics().scene.frequency if hertz is None else hertz
    rows = {name: schemes.comparison(row["stiffness_rate"], row["damping_rate"], safety,
                                     2.0 * math.pi * hertz)
            for name, row in steps.items() if "zeta" in row}
    if not rows:
        return []

    def spread(scheme: str, key: str, per_evaluation: bool = False) -> str:
        low, high = (f"{v:.2f}" for v in extremes(scheme, key, per_evaluation))
        return low if low == high else f"{low}–{high}"

    def extremes(scheme: str, key: str, per_evaluation: bool = False) -> tuple[float, float]:
        values = [r[key] / (r["evaluations"] if per_evaluation else 1)
                  for robot in rows.values() for r in robot if r["scheme"] == scheme]
        return min(values), max(values)

    euler = spread("semi-implicit Euler", "damping_kept")
    best = [max(r["step_keeping"] / r["evaluations"] for r in robot
                if r["scheme"] != "semi-implicit Euler") for robot in rows.values()]
    cheapest = (min(best), max(best))
    return [
        "",
        "Another explicit scheme does lengthen the limit, but only by taking the damping "
        "away from the slow modes, the gait's (`benchmarks/explicit_schemes.py`: each "
        "robot's network as modes up to √λ damped in proportion to their stiffness, c = "
        f"μ ω²/λ, the slow mode at the muscles' {hertz:g} Hz). Semi-implicit Euler, the "
        "engine's scheme and the plugin's, damps every mode at its own rate (a step "
        f"multiplies its energy by 1 − hc): at {safety:g} of its limit it keeps {euler} of "
        "the slow mode's damping ratio. The explicit Runge–Kutta schemes with the longest "
        "real stability interval per force evaluation, the damped Chebyshev (RKC) ones "
        "(one stage is forward Euler), reach limits "
        f"{spread('RKC 1', 'limit')} (1 stage), {spread('RKC 2', 'limit')} (2 stages) and "
        f"{spread('RKC 3', 'limit')} (3 stages) times semi-implicit Euler's, but at "
        f"{safety:g} of those limits they keep only {spread('RKC 1', 'damping_kept')}, "
        f"{spread('RKC 2', 'damping_kept')} and {spread('RKC 3', 'damping_kept')} of the "
        "slow mode's damping: their error grows with h ω²/c, which damping in proportion "
        "to stiffness makes one share for all modes. Keeping 97 % of it needs steps of "
        f"{spread('RKC 1', 'step_keeping')}, {spread('RKC 2', 'step_keeping')} and "
        f"{spread('RKC 3', 'step_keeping')} of today's, "
        f"{spread('RKC 2', 'step_keeping', True)} and {spread('RKC 3', 'step_keeping', True)} "
        f"per force evaluation for 2 and 3 stages: {1 / cheapest[1]:.0f}–{1 / cheapest[0]:.0f} "
        "times today's cost at best.",
    ]


def _sibling(name: str):
    """The module `name`.py beside this script."""
    spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name(f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def performance_doc(report: dict, extra: dict, evolution: dict | None,
                    recorded: list[dict], sections: list[str] = ()) -> str:
    """docs/performance.md from one run of this script (`recorded`: `recorded_evolutions`)."""
    lines = _head_and_result(report, extra, evolution, recorded)
    lines += _per_robot_section(report, extra["steps"])
    lines += _before_section()
    lines += _where_the_time_goes(report, extra)
    lines += _real_evolution_section(evolution)
    if recorded:
        lines += ["", *recorded_section(recorded), "", *repeated_section()]
    return "\n".join([*lines, *sections]) + "\n"


def _head_and_result(report: dict, extra: dict, evolution: dict | None,
                     recorded: list[dict]) -> list[str]:
    """The title, how the report was made, the machine and the Result bullets."""
    start = extra["startup"]
    paper = [n for n in report if n.startswith("paper_")]
    randoms = [n for n in report if n.startswith("random_")
               and report[n]["voxelyze_cpu_s"] is not None]
    others = [n for n in report if not n.startswith(("paper_", "random_")) and report[n]["voxels"]
              and report[n]["voxelyze_cpu_s"] is not None]
    lines = [
        "# Performance: CPU time per evaluation, side by side with the paper's engine",
        "",
        "Generated by `python benchmarks/speed.py --voxelyze DIR --rounds "
        f"{extra['rounds']} --models {' '.join(extra['models'])} --doc docs/performance.md "
        "--evolution evolution.json --throughput throughput.json --starts starts.json "
        "--backends backends.json --gpu gpu.json --settle-rest settle_grid.json "
        "settle_sheet.json` (each JSON written by `--json` of: `python benchmarks/evolution.py "
        "short-run`, `evolution.py compare --before DIR`, `evolution.py starts`, "
        "`evolution.py backends`, `batched_bonds.py`, `settle_rest.py` and "
        "`settle_rest.py --body sheet`). "
        "`DIR` holds the paper's engine, Voxelyze as evosoro builds it, compiled with -O3, "
        "and its `vxa.py`, which runs it on any grid with the paper's settings. Each round "
        "runs the engine on the robot and then one `simulate` call (compile included, in a "
        "warm process); the rounds interleave, the table gives medians of CPU seconds of one "
        "evaluation (0.05 s settle + 0.5 s walk in 3D). CPU time, because the machine is "
        "shared: compare the ratios, which both sides of one run share; seconds from another "
        "day or machine do not compare.",
        "",
        f"Machine: {_machine()}. The plugin library is built with `{' '.join(FLAGS[:2])}` "
        "and strict IEEE arithmetic (no fused multiply-add, no reassociation).",
        "",
        "## Result",
        "",
        f"- The paper's robots: **{_ratio_range(report, paper)}** of the engine's CPU time "
        f"per evaluation; robots without hard voxels: **{_ratio_range(report, others)}**"
        + (f"; a random initial 3D population ({len(randoms)} robots): "
           f"**{_ratio_range(report, randoms)}**, {_total_ratio(report, randoms):.2f} of the "
           "engine's CPU time over all of them." if randoms else "."),
        f"- `mjregen walk ROBOT --json` as a fresh process, with nothing simulated: "
        f"{start['walk']:.2f} CPU s, of which Python with numpy (one BLAS thread, as the "
        f"command sets it) and mujoco imported costs {start['imports']:.2f} s "
        f"({start['python']:.2f} s for Python alone).",
    ]
    if evolution is not None:
        lines.append(
            f"- A real 3D evolution (the paper's GA, population {evolution['ga']['population']}, "
            f"{len(evolution['generation_wall_s'])} generations, 2 worker processes): "
            f"{evolution['evaluations_per_s']:.2f} evaluations per second; the paper's 300 "
            f"generations at its mean time per generation: "
            f"**{evolution['projected_paper_run_h']:.1f} h** (an upper bound: the first "
            "generations grow the largest robots; whole runs below).")
    lines += recorded_bullets(recorded)
    return lines


def _per_robot_section(report: dict, steps: dict) -> list[str]:
    """The table of CPU time per robot beside the engine's, and the tendon bonds' cost."""
    lines = [
        "",
        "## Per robot",
        "",
        "| robot | N | engine CPU s | mjregen CPU s | ratio | steps engine / mjregen | "
        "µs per voxel-step engine / mjregen |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, row in report.items():
        ours, engine = row["default"], row["voxelyze_cpu_s"]
        count = steps.get(name, {}).get("engine_steps")
        per_step = "" if engine is None or count is None else \
            f"{1e6 * engine / (count * row['voxels']):.3f} / {ours['us_per_voxel_step']:.3f}"
        engine_cpu = "" if engine is None else f"{engine:.3f}"
        ratio = "" if engine is None else f"{ours['cpu_s'] / engine:.2f}"
        engine_count = "" if count is None else f"{count:,}"
        lines.append(f"| {DOC_ROBOTS.get(name, name)} | {row['voxels']} | {engine_cpu} | "
                     f"{ours['cpu_s']:.3f} | {ratio} | {engine_count} / {ours['steps']:,} | "
                     f"{per_step} |")
    tendons = {n: row["tendon-bonds"]["cpu_s"] / row["default"]["cpu_s"]
               for n, row in report.items() if "tendon-bonds" in row}
    lines += [
        "",
        "The engine's steps follow its rule (0.9 / (2π √(k/m)), k = E·L of the stiffest "
        "material present); it reports no count. mjregen's µs per voxel-step include compile.",
    ]
    if tendons:
        lines += [
            "",
            "`--bonds tendons` (8 spring tendons per bond, the same linear mechanics) costs "
            + ", ".join(f"{DOC_ROBOTS.get(n, n)} {r:.1f}×" for n, r in tendons.items())
            + " the CPU time of the default beam bonds.",
        ]
    return lines


def _before_section() -> list[str]:
    """The table measured before the plugin's optimisation (`speed_before.json`)."""
    before = json.loads((Path(__file__).with_name("speed_before.json")).read_text())
    lines = [
        "",
        "## Before",
        "",
        f"{before['source'][0].upper() + before['source'][1:]}.",
        "",
        "| robot | N | engine CPU s | mjregen CPU s | ratio | mjregen steps |",
        "|---|---|---|---|---|---|",
    ]
    for name, row in before["robots"].items():
        count = "" if row["steps"] is None else f"{row['steps']:,}"
        lines.append(f"| {DOC_ROBOTS.get(name, name)} | {row['voxels']} | "
                     f"{row['voxelyze_cpu_s']:.3f} | {row['cpu_s']:.3f} | "
                     f"{row['cpu_s'] / row['voxelyze_cpu_s']:.2f} | {count} |")
    return lines


def _where_the_time_goes(report: dict, extra: dict) -> list[str]:
    """Why the numbers are the scalar code's, the chaos that makes that matter, and the step."""
    steps = extra["steps"]
    paper = [n for n in report if n.startswith("paper_")]
    chaos_run = extra["chaos"]
    spread = chaos_run["distances"]
    lines = [
        "",
        "## Where the time goes, and what keeps the results",
        "",
        "- **The same numbers, faster.** The plugin's per-voxel data are rows (a structure of "
        "arrays); the beam bonds' arithmetic, the voxels' frames, drag and the native "
        f"stepper's integration are loops the compiler vectorises ({_vector_unit()} on this "
        "machine); the "
        "bonds read their voxels by gather and add their forces back in bond order. Every "
        "operation is the one the scalar code did, in the same order, so the motion is the "
        "scalar code's to the last bit (the paper robots' distances: "
        + ", ".join(f"{DOC_ROBOTS[n]} {report[n]['default']['distance']:.4f}" for n in paper)
        + ").",
        f"- **Why the same bits matter.** Moving every voxel of the tripod by "
        f"{chaos_run['size_m']:g} m at random before the settle changes its 0.5 s distance from "
        f"{chaos_run['unperturbed']:.4f} to {min(spread):.4f}–{max(spread):.4f} voxel lengths "
        f"({len(spread)} runs). " + (
            "Its walk is chaotic at the rounding level, so any change of arithmetic (single "
            "precision, fused multiply-add, a reordered sum, another step) moves its distance "
            "by this much." if max(spread) - min(spread) > 1e-3 * abs(chaos_run["unperturbed"])
            else "At this size the walk does not part, but larger differences grow "
            "(docs/accuracy.md: how much of a fitness is physics), so a change of arithmetic "
            "(single precision, fused multiply-add, a reordered sum) is a change of results."),
        "- **The step.** Each robot's step is 0.75 of Euler's stability limit of its own bond "
        f"network, with the paper engine's damping (ζ = {Physics().scene.bond_damping_ratio:g} "
        "on a bond's force rows, half of it on its moments): a mode's damping grows with its "
        "frequency, the fastest mode is overdamped (ζ below), and its damping, not its "
        "stiffness, sets the limit. The engine steps 0.9 / (2π √(k/m)) of its stiffest "
        "material whatever the network. Its dampers take the rates of the last step, "
        "(x_n − x_(n−1)) / h, which in its semi-implicit Euler step are the velocities "
        "v_n that mjregen's dampers take: the same linear dynamics, so the same limit.",
        "",
        "| robot | fastest mode ζ | undamped / damped limit | steps engine / mjregen | "
        "engine's step / the damped limit | h C_ii / m | limit, rotations held / limit |",
        "|---|---|---|---|---|---|---|",
    ]
    safety = Physics().scene.timestep_safety
    lines += _step_rows(steps, safety)
    lines += [
        "",
        "On dense blocks (the networks' stiffest topology, which the engine's rule is made "
        "for) the engine steps at the damped limit itself: its 0.9 of the material's period "
        "is the edge of stability, where mjregen keeps a margin (its step is "
        f"{safety:g} of the limit; the largest stable fraction is about 1.1 on most robots, "
        "docs/accuracy.md). On sparse robots such as the paper's its rule is conservative and "
        "mjregen's network rule takes longer steps. Robots without hard voxels are dense "
        "blocks of one soft material, where the engine's step is the limit's and mjregen's "
        f"{safety:g} of it: that margin, not the cost of a step, is the ratio's remainder. A "
        "longer step at the same accuracy needs another integrator for the overdamped modes "
        "(their damping sets the limit); the paragraphs below measure the candidates.",
    ]
    return [*lines, *rotational_inertia_paragraph(steps),
            *implicit_damping_paragraph(steps, safety), *explicit_schemes_paragraph(steps, safety)]


def _step_rows(steps: dict, safety: float) -> list[str]:
    """The step table's row of each robot with a step analysis (`step_analysis`)."""
    rows = []
    for name, row in steps.items():
        if "zeta" not in row:
            continue
        engine = "" if row["engine_steps"] is None else f"{row['engine_steps']:,}"
        edge = ("" if row["engine_steps"] is None else
                f"{safety * row['steps'] / row['engine_steps']:.2f}")
        rows.append(f"| {DOC_ROBOTS.get(name, name)} | {row['zeta']:.2f} | "
                    f"{row['damping_cost']:.2f} | {engine} / {row['steps']:,} | {edge} | "
                    f"{row['own_damping_step']:.2f} | {row['rotations_held']:.3f} |")
    return rows


def _real_evolution_section(evolution: dict | None) -> list[str]:
    """The section on a real short evolution (`evolution.py short-run`), if measured."""
    lines: list[str] = []
    if evolution is not None:
        lines += [
            "",
            "## A real evolution",
            "",
            f"`benchmarks/evolution.py short-run`: seed {evolution['seed']}, population "
            f"{evolution['ga']['population']}, {evolution['workers']} worker processes. Wall "
            "seconds per generation: "
            + ", ".join(f"{w:.1f}" for w in evolution["generation_wall_s"])
            + " (robots simulated: " + ", ".join(map(str, evolution["distinct_per_generation"]))
            + " of 100; the GA's cache skips repeated genomes). Best fitness per generation: "
            + ", ".join(f"{b:.2f}" for b in evolution["best"]) + ".",
        ]
        sizes = evolution.get("mean_voxels_per_generation")
        if sizes:
            lines[-1] += " Mean voxels per robot: " + ", ".join(f"{v:.0f}" for v in sizes) + "."
            wall = evolution["generation_wall_s"]
            if len(sizes) > 1 and sizes[0] > max(sizes[1:]) and wall[0] == max(wall):
                lines[-1] += (
                    " The first generation's random NCAs grow the largest robots (the paper's "
                    "initial genes fill much of the grid) and a step costs in proportion to "
                    "the voxels, so that generation is the slowest however few robots it "
                    "simulates; selection, with the voxel cost in the fitness, shrinks them.")
    return lines


def _doc_sections(args: argparse.Namespace) -> list[str]:
    """The sections of docs/performance.md read from the other benchmarks' JSON files."""
    sections = []
    if args.throughput:
        sections += _sibling("evolution").throughput_section(
            json.loads(args.throughput.read_text()),
            json.loads(args.starts.read_text()) if args.starts else None)
    if args.backends:
        sections += _sibling("evolution").backends_section(
            json.loads(args.backends.read_text()))
    if args.phases:
        sections += _sibling("generation_phases").markdown_section(
            json.loads(args.phases.read_text()))
    if args.gpu:
        sections += _sibling("batched_bonds").markdown_section(
            json.loads(args.gpu.read_text()))
    if args.settle_rest:
        sections += _sibling("settle_rest").markdown_section(
            [json.loads(path.read_text()) for path in args.settle_rest])
    return sections


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--voxelyze", type=Path, help="folder of the paper engine's vxa.py")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--models", nargs="+", default=["default", "mj-step"], choices=MODELS)
    parser.add_argument("--robots", nargs="+", help="subset of robot names")
    parser.add_argument("--json", type=Path, help="write the report here")
    parser.add_argument("--doc", type=Path, help="write the full report (docs/performance.md)")
    parser.add_argument("--evolution", type=Path,
                        help="JSON of benchmarks/evolution.py short-run, for --doc")
    parser.add_argument("--throughput", type=Path,
                        help="JSON of benchmarks/evolution.py compare, for --doc")
    parser.add_argument("--starts", type=Path,
                        help="JSON of benchmarks/evolution.py starts, for --doc (with "
                             "--throughput)")
    parser.add_argument("--backends", type=Path,
                        help="JSON of benchmarks/evolution.py backends, for --doc")
    parser.add_argument("--phases", type=Path,
                        help="JSON of benchmarks/generation_phases.py, for --doc")
    parser.add_argument("--gpu", type=Path, help="JSON of benchmarks/batched_bonds.py, for --doc")
    parser.add_argument("--settle-rest", type=Path, nargs="+",
                        help="JSONs of benchmarks/settle_rest.py (one per --body), for --doc")
    parser.add_argument("--records", action="store_true",
                        help="print only the Result bullets and the section on the paper-size "
                             "runs kept in records/ (nothing is measured)")
    args = parser.parse_args()
    if args.records:
        recorded = all_recorded_evolutions()
        print("\n".join([*recorded_bullets(recorded), "", *recorded_section(recorded), "",
                         *repeated_section()]))
        return
    table = robots()
    names = args.robots or (list(DOC_ROBOTS) if args.doc else
                            ["paper_tripod", "paper_biped", "paper_multiped", "block_7x7x7_soft"])
    unknown = sorted(set(names) - set(table))
    if unknown:
        parser.error(f"unknown robots {unknown}; choose from {sorted(table)}")
    engine = PaperEngine(args.voxelyze).run if args.voxelyze else None
    report = summary(measure(names, args.models, args.rounds, engine), table)
    print(markdown(report, args.models))
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))
    if args.doc:
        evolution = json.loads(args.evolution.read_text()) if args.evolution else None
        extra = {"startup": startup(), "steps": step_analysis({n: table[n] for n in names}),
                 "chaos": chaos(table["paper_tripod"]), "rounds": args.rounds,
                 "models": args.models,
                 "engine": args.voxelyze is not None}
        sections = _doc_sections(args)
        args.doc.write_text(performance_doc(report, extra, evolution, all_recorded_evolutions(),
                                            sections))
        print(f"wrote {args.doc}")


if __name__ == "__main__":
    main()
