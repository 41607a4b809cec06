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
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import statistics
import time
from pathlib import Path

import numpy as np

from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.physics.simulation import simulate

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
    out["block_7x7x7_soft"] = Robot.from_body(np.ones((7, 7, 7), dtype=np.int8))
    out["block_7x7x7_muscle"] = Robot.from_body(
        rng.choice([1, 3, 4], size=(7, 7, 7)).astype(np.int8))
    slab = np.ones((7, 4, 4), dtype=np.int8)
    slab[:, :, 0] = np.where(np.arange(7)[:, None] % 2 == 0, 3, 4)  # legs: red/green
    slab[:, :, 3] = 4
    out["slab_3d_112"] = Robot.from_body(slab)
    out["sheet_2d_5x5"] = Robot.from_body(rng.choice([1, 2, 3, 4], size=(5, 5)).astype(np.int8))
    for path in sorted((ROOT / "assets" / "nca").glob("walker_3d_*.npy")):
        out[f"evolved_{path.stem}"] = Robot.load(path)
    return out


def load_engine(folder: Path):
    """The ``run(grid) -> {"distance", "cpu_s"}`` of the paper engine's ``vxa.py``."""
    spec = importlib.util.spec_from_file_location("vxa", folder / "vxa.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.run


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--voxelyze", type=Path, help="folder of the paper engine's vxa.py")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--models", nargs="+", default=["default", "mj-step"], choices=MODELS)
    parser.add_argument("--robots", nargs="+", help="subset of robot names")
    parser.add_argument("--json", type=Path, help="write the report here")
    args = parser.parse_args()
    table = robots()
    names = args.robots or ["paper_tripod", "paper_biped", "paper_multiped", "block_7x7x7_soft"]
    unknown = sorted(set(names) - set(table))
    if unknown:
        parser.error(f"unknown robots {unknown}; choose from {sorted(table)}")
    engine = load_engine(args.voxelyze) if args.voxelyze else None
    report = summary(measure(names, args.models, args.rounds, engine), table)
    print(markdown(report, args.models))
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
