"""Speed report (#8): CPU and wall time per locomotion evaluation, per model and robot.

For each robot of a fixed set (2D 5×5, 3D 112-voxel slab with and without hard voxels, the
7×7×7 block, the paper's biped/tripod/multiped, the shipped evolved 3D walkers) and each
model (`MODELS`: the default, where beam bonds, floor, self-collision and drag are one C loop,
the native stepper integrates and the time step is the robot's own network's; the same with
the stiffest-bond time-step rule; that stepped by ``mj_step`` (the default before session
4); 8 tendons per bond, with either stepper (with ``mj_step``: the default before #8);
MuJoCo doing floor contacts,
self-collision and drag; everything in MuJoCo, i.e. the exported MJCF with its tendons):
median over `--repeats` full `simulate` calls (compile included) of CPU and wall seconds, µs
per step, steps, and the ratio to the paper engine's optimised cost (0.0125·N CPU-s per
0.55 s evaluation of N voxels, measured on this machine; <1 = faster). Our overhead: the
same model and state advanced by one bare C call (the native stepper's, else
``mj_step(model, data, nstep=steps)``; no Python per step, no compile, no checks) vs
`simulate`'s total CPU time. And a population's throughput (evaluations/s) with 1 and 2
worker processes (`ProcessBackend`).

    /work/venv/bin/python benchmarks/speed.py [--repeats 3] [--models default stiffest-bond mj-step]
        [--robots slab_112 ...] [--json docs/performance.json] [--md docs/performance_results.md]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from pathlib import Path

import mujoco
import numpy as np

from mjregen.compile import compile_robot
from mjregen.grid import Robot
from mjregen.parallel import ProcessBackend, SerialBackend
from mjregen.physics import Physics
from mjregen.simulate import simulate, simulation_of

ROOT = Path(__file__).resolve().parents[1]
VOXELYZE_CPU_S_PER_VOXEL = 0.0125  # optimised paper engine, per 0.55 s evaluation
VOXELYZE_UNOPTIMISED = 0.087  # the paper's own binary
MUJOCO_CONTACTS = {"contact_shape": "point"}  # MuJoCo point floor, collision spheres, viscosity
TENDON_BONDS = {"bond_element": "tendons"}  # 8 tendons per bond (the default before #8)
STIFFEST_BOND = {"timestep_rule": "stiffest_bond"}  # the time-step rule before the network's
MJ_STEP = {"stepper": "mujoco", **STIFFEST_BOND}  # the default at the start of session 4
MODELS = {
    "default": {},
    "stiffest-bond": STIFFEST_BOND,
    "mj-step": MJ_STEP,
    "tendon-bonds": TENDON_BONDS,
    "tendon-bonds-mj-step": {**TENDON_BONDS, **MJ_STEP},  # the default before #8
    "mujoco-contacts": MUJOCO_CONTACTS,
    "tendon": {**MUJOCO_CONTACTS, **TENDON_BONDS, "bond_backend": "tendon"},
}


def robots() -> dict[str, Robot]:
    rng = np.random.default_rng(0)
    sheet = rng.choice([1, 2, 3, 4], size=(5, 5)).astype(np.int8)
    slab = np.ones((7, 4, 4), dtype=np.int8)
    slab[:, :, 0] = np.where(np.arange(7)[:, None] % 2 == 0, 3, 4)  # legs layer: red/green
    slab[:, :, 3] = 4
    slab_hard = slab.copy()
    slab_hard[:, :, 2] = 2  # a hard layer
    block = rng.choice([1, 3, 4], size=(7, 7, 7)).astype(np.int8)
    out = {"sheet_2d_5x5": Robot.from_body(sheet), "slab_3d_112": Robot.from_body(slab),
           "slab_3d_112_hard": Robot.from_body(slab_hard),
           "block_3d_7x7x7": Robot.from_body(block)}
    for name in ("tripod", "biped", "multiped"):
        out[f"paper_{name}"] = Robot(np.load(ROOT / "assets" / "robots" / "paper" / f"{name}.npy"))
    for path in sorted((ROOT / "assets" / "nca").glob("walker_3d_*.npy")):  # evolved walkers
        out[f"evolved_{path.stem}"] = Robot.load(path)
    return out


def _evaluate(item: tuple[Robot, Physics]) -> float:
    robot, physics = item
    return simulate(robot, physics=physics).cpu_time


def bare_cpu(robot: Robot, physics: Physics, steps: int) -> float:
    """CPU s of one bare C call that makes all `steps` (the native stepper's, else
    ``mj_step(nstep=steps)``) on the simulated model and state (no compile, no checks)."""
    sim = simulation_of(compile_robot(robot, physics=physics))
    start = time.process_time()
    if sim.stepper is not None:
        sim.stepper.step(steps)
    else:
        mujoco.mj_step(sim.model, sim.data, nstep=steps)
    return time.process_time() - start


def mujoco_only_us_per_step(robot: Robot, physics: Physics, steps: int = 2000) -> float:
    """µs per step of MuJoCo's own work on the simulated model: an MjData without native
    bonds registered (the callback returns at once). The robot then falls apart, but with
    no contacts MuJoCo's cost does not depend on the state."""
    compiled = compile_robot(robot, physics=physics)
    model = compiled.simulation_model
    data = mujoco.MjData(model)
    start = time.process_time()
    mujoco.mj_step(model, data, nstep=steps)
    return (time.process_time() - start) / steps * 1e6


def measure(name: str, robot: Robot, physics: Physics, repeats: int) -> dict:
    runs = [simulate(robot, physics=physics) for _ in range(repeats)]
    steps = runs[0].steps
    cpu = statistics.median(r.cpu_time for r in runs)
    wall = statistics.median(r.wall_time for r in runs)
    compile_cpu = []
    for _ in range(repeats):
        start = time.process_time()
        compile_robot(robot, physics=physics)
        compile_cpu.append(time.process_time() - start)
    bare = statistics.median(bare_cpu(robot, physics, steps) for _ in range(repeats))
    budget = VOXELYZE_CPU_S_PER_VOXEL * robot.n_voxels
    return {
        "voxels": robot.n_voxels, "dim": robot.dim, "steps": steps,
        "timestep_s": runs[0].timestep, "cpu_s": cpu, "wall_s": wall,
        "us_per_step": cpu / steps * 1e6,
        "mujoco_only_us_per_step": statistics.median(
            mujoco_only_us_per_step(robot, physics) for _ in range(repeats)),
        "us_per_voxel_step": cpu / steps / robot.n_voxels * 1e6,
        "compile_cpu_s": statistics.median(compile_cpu),
        "bare_c_loop_cpu_s": bare, "overhead_vs_bare": cpu / bare - 1.0,
        "voxelyze_cpu_s": budget, "ratio_to_voxelyze": cpu / budget,
        "distance": runs[0].distance, "stable": runs[0].stable,
        "identical_repeats": len({r.distance for r in runs}) == 1,
    }


def population(robot: Robot, physics: Physics, size: int, workers: int) -> dict:
    items = [(robot, physics)] * size
    backend = SerialBackend() if workers == 1 else ProcessBackend(workers)
    with backend:
        backend.map(_evaluate, items[:workers])  # warm up: worker start, native build
        start = time.perf_counter()
        outcomes = backend.map(_evaluate, items)
        wall = time.perf_counter() - start
    assert all(o.ok for o in outcomes)
    return {"workers": workers, "evaluations": size, "wall_s": wall,
            "evaluations_per_s": size / wall}


def markdown(report: dict) -> str:
    lines = [f"Machine: {report['machine']}; MuJoCo {report['mujoco']}; median of "
             f"{report['repeats']} runs; CPU s per evaluation (compile + 0.05 s settle + 0.5 s "
             "walk in 3D; 1 s + 0.25 s in 2D). Voxelyze = 0.0125·N CPU-s (optimised paper "
             "engine on this machine); ratio < 1 is faster.", "",
             "µs/step mj_step alone: the same model stepped by mj_step without our forces "
             "(MuJoCo's own kinematics, dynamics, integration: what the native stepper "
             "replaces; meaningful for models without MuJoCo contacts). Bare C loop: all steps "
             "in one call (native stepper, else mj_step(nstep)); overhead = our CPU s (compile, "
             "checks, Python) over it.",
             "",
             "| robot | N | model | steps | µs/step | µs/step mj_step alone | µs/voxel/step | "
             "CPU s | wall s | compile s | bare C loop s | overhead | ratio to Voxelyze |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, rows in report["robots"].items():
        for model, r in rows.items():
            lines.append(
                f"| {name} | {r['voxels']} | {model} | {r['steps']} | {r['us_per_step']:.1f} "
                f"| {r['mujoco_only_us_per_step']:.1f} | {r['us_per_voxel_step']:.2f} | {r['cpu_s']:.2f} | {r['wall_s']:.2f} | "
                f"{r['compile_cpu_s']:.3f} | {r['bare_c_loop_cpu_s']:.2f} | "
                f"{100 * r['overhead_vs_bare']:+.1f} % | {r['ratio_to_voxelyze']:.2f} |")
    if report.get("population"):
        lines += ["", "Population throughput (" + report["population_robot"] + ", default):", "",
                  "| workers | evaluations | wall s | evaluations/s |", "|---|---|---|---|"]
        for p in report["population"]:
            lines.append(f"| {p['workers']} | {p['evaluations']} | {p['wall_s']:.1f} | "
                         f"{p['evaluations_per_s']:.3f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--models", nargs="+", default=["default", "stiffest-bond", "mj-step"],
                        choices=sorted(MODELS))
    parser.add_argument("--robots", nargs="+", help="subset of robot names")
    parser.add_argument("--population", type=int, default=8,
                        help="population size for the 1- vs 2-worker throughput (0: skip)")
    parser.add_argument("--json", default=str(ROOT / "docs" / "performance.json"))
    parser.add_argument("--md", default=str(ROOT / "docs" / "performance_results.md"))
    args = parser.parse_args()
    selected = {k: v for k, v in robots().items() if not args.robots or k in args.robots}
    report = {"mujoco": mujoco.__version__, "repeats": args.repeats,
              "machine": f"{platform.processor() or platform.machine()}, "
                         f"{os.cpu_count()} cores", "robots": {}}
    for name, robot in selected.items():
        report["robots"][name] = {}
        for model in args.models:
            physics = Physics().replace_scene(**MODELS[model])
            row = measure(name, robot, physics, args.repeats)
            report["robots"][name][model] = row
            print(name, model, json.dumps(row), flush=True)
    if args.population:
        robot_name = "paper_tripod"
        physics = Physics()
        report["population_robot"] = robot_name
        report["population"] = [population(robots()[robot_name], physics, args.population, w)
                                for w in (1, 2)]
        print(json.dumps(report["population"]), flush=True)
    Path(args.json).write_text(json.dumps(report, indent=2) + "\n")
    Path(args.md).write_text(markdown(report))


if __name__ == "__main__":
    main()
