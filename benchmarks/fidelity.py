"""Fidelity: re-run the paper engine's reference cases in mjregen and compare.

Runs every case of `mjregen.reference` with the chosen physics, writes a table (measure,
reference, mjregen, ratio) and overlay plots (mjregen vs reference) to `docs/fidelity.md`
and `docs/fidelity_*.png`, and the numbers to a JSON file.

    /work/venv/bin/python benchmarks/fidelity.py [--preset default|paper|legacy]
        [--scene key=value ...] [--cases tripod,drop_voxel] [--reference DIR]
        [--doc docs/fidelity.md] [--json fidelity.json] [--no-plots]

`--scene` overrides fields of the scene or of the preset's pipeline (JSON values:
`--scene bond_damping_ratio=0.5`, `--scene floor_damping=0.6`; `--scene 'pipeline="mujoco"'`
first switches to the pure-MuJoCo pipeline with its defaults), and
`--friction 1.0` sets every material's friction: this is how the ablations in
docs/fidelity.md were measured. Without `--doc` nothing is written but the table.

`--spread 0.5,0.55,...` instead walks each paper robot once per time-step safety (slightly
different integrations of the same physics: the gaits are chaotic) and prints the
distances, their median and range, and the median's ratio to the engine's distance
(`--jobs 2` runs them on two processes).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import time
from pathlib import Path

import numpy as np

from mjregen.physics import Physics, legacy_physics, paper_physics, sphere_physics
from mjregen.reference import CASES, REFERENCE, ROBOT_FILES, CaseResult, load_csv

ROOT = Path(__file__).resolve().parent.parent
# the paper engine's recordings (not shipped: 7.5 MB); --reference or $MJREGEN_REFERENCE
DEFAULT_REFERENCE = Path(os.environ.get("MJREGEN_REFERENCE", "reference"))
PRESETS = {"default": Physics, "paper": paper_physics, "legacy": legacy_physics,
           "sphere": sphere_physics}
UNITS = {"distance": (1.0, "vox"), "sag_max_t": (1e3, "ms"), "stop_after": (1e3, "ms")}


def physics_from_args(args: argparse.Namespace) -> Physics:
    physics = PRESETS[args.preset]()
    if args.friction is not None:  # the static coefficient; kinetic capped at it
        physics = Physics(materials={
            m: dataclasses.replace(p, friction=args.friction, kinetic_friction=None
                                   if p.kinetic_friction is None
                                   else min(p.kinetic_friction, args.friction))
            for m, p in physics.materials.items()}, scene=physics.scene,
            pipeline=physics.pipeline)
    changes = {}
    for item in args.scene:
        key, _, value = item.partition("=")
        changes[key] = json.loads(value)
    return physics.replace(**changes) if changes else physics


def rows(result: CaseResult) -> list[tuple[str, str, float, float, str]]:
    """(case, measure, reference, mjregen, unit) in display units."""
    out = []
    for measure, reference in REFERENCE.get(result.name, {}).items():
        scale, unit = UNITS.get(measure, (1e3, "mm"))
        out.append((result.name, measure, reference * scale,
                    result.measures.get(measure, math.nan) * scale, unit))
    if "z_settled" in result.measures:
        for measure in ("z_settled", "z_mean"):
            out.append((result.name, measure, math.nan, result.measures[measure] * 1e3, "mm"))
    return out


def reference_robot(reference: Path, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(t, com (n, 3)) of a paper robot from the reference trajectories."""
    data = load_csv(reference / f"{ROBOT_FILES[name]}.csv.gz")
    return data["t"], np.stack([data["com_x"], data["com_y"], data["com_z"]], axis=1)


def plot(result: CaseResult, reference: Path, out: Path) -> Path | None:
    """Overlay of mjregen and reference for one case, as a small PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    name = result.name
    if name in ROBOT_FILES:
        t_ref, com_ref = reference_robot(reference, name)
        t, com = result.traces["com"]
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(8, 3.2))
        for label, tt, cc, style in (("paper engine", t_ref, com_ref, "k-"),
                                     ("mjregen", t, com, "r-")):
            k = int(np.argmin(np.abs(tt - 0.05)))
            ax1.plot((cc[:, 0] - cc[k, 0]) * 1e3, (cc[:, 1] - cc[k, 1]) * 1e3, style, lw=1,
                     label=label)
            ax1.plot(0, 0, "bo", ms=3)
            ax2.plot(tt, cc[:, 2] * 1e3, style, lw=0.6, label=label)
        ax1.set(xlabel="x (vox)", ylabel="y (vox)", title=f"{name}: COM path from 0.05 s")
        ax1.set_aspect("equal", adjustable="datalim")
        ax2.set(xlabel="t (s)", ylabel="COM z (mm)", title="COM height")
        ax1.legend(fontsize=7)
    else:
        label, (t, values) = next(iter(result.traces.items()))
        fig, ax = plt.subplots(figsize=(5, 3))
        ref_file = reference / f"{name}.csv.gz"
        voxels = reference / f"{name}_voxels.csv.gz"
        if name in ("drop_voxel", "drop_block") and ref_file.exists():
            data = load_csv(ref_file)
            ax.plot(data["t"], data["com_z"] * 1e3, "k-", lw=1, label="paper engine")
        elif name.startswith("slide_bar") and ref_file.exists():
            data = load_csv(ref_file)
            ax.plot(data["t"], (data["com_x"] - data["com_x"][0]) * 1e3, "k-", lw=1,
                    label="paper engine")
        elif name == "cantilever" and voxels.exists():
            data = load_csv(voxels)
            tip = data["ix"] == data["ix"].max()
            ax.plot(data["t"][tip], (data["z"][tip][0] - data["z"][tip]) * 1e3, "k-", lw=1,
                    label="paper engine")
        elif name == "bar_red_green" and voxels.exists():
            data = load_csv(voxels)
            a, b = data["ix"] == 0, data["ix"] == 1
            d = np.linalg.norm(np.stack([data[k][b] - data[k][a] for k in "xyz"], 1), axis=1)
            ax.plot(data["t"][a], d * 1e3, "k-", lw=1, label="paper engine")
        ax.plot(t, values * 1e3, "r-", lw=1, label="mjregen")
        ax.set(xlabel="t (s)", ylabel=f"{label} (mm)", title=name)
        ax.legend(fontsize=7)
    fig.tight_layout()
    path = out / f"fidelity_{name.replace('.', '_')}.png"
    fig.savefig(path, dpi=72)
    plt.close(fig)
    return path


def _walk(item: tuple[str, Physics, float]) -> tuple[str, float, float]:
    from mjregen.grid import Robot
    from mjregen.physics.simulation import simulate

    name, physics, safety = item
    robot = Robot(np.load(ROOT / "assets" / "robots" / "paper" / f"{name}.npy"))
    result = simulate(robot, physics=physics.replace(timestep_safety=safety))
    return name, safety, result.distance


def spread(physics: Physics, safeties: list[float], jobs: int) -> str:
    """Markdown table: each paper robot's distance at each safety, median, range, ratio."""
    import multiprocessing

    items = [(name, physics, s) for name in ROBOT_FILES for s in safeties]
    with multiprocessing.get_context("fork").Pool(jobs) as pool:
        walked = pool.map(_walk, items)
    lines = ["| robot | " + " | ".join(f"{s:g}" for s in safeties)
             + " | median | range | engine | median / engine |",
             "|---" * (len(safeties) + 6) + "|"]
    for name in ROBOT_FILES:
        distances = [d for n, _, d in walked if n == name]
        median = float(np.median(distances))
        engine = REFERENCE[name]["distance"]
        lines.append(f"| {name} | " + " | ".join(f"{d:.1f}" for d in distances)
                     + f" | {median:.1f} | {min(distances):.1f}–{max(distances):.1f} | "
                     f"{engine:.2f} | {median / engine:.2f} |")
    return "\n".join(lines)


def markdown_table(all_rows: list[tuple]) -> str:
    lines = ["| case | measure | paper engine | mjregen | ratio |", "|---|---|---|---|---|"]
    for case, measure, ref, ours, unit in all_rows:
        ratio = f"{ours / ref:.2f}" if ref and math.isfinite(ref) and ref != 0 else ""
        ref_text = f"{ref:.4g} {unit}" if math.isfinite(ref) else "—"
        lines.append(f"| {case} | {measure} | {ref_text} | {ours:.4g} {unit} | {ratio} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", choices=sorted(PRESETS), default="default")
    parser.add_argument("--scene", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--friction", type=float, default=None)
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--reference", type=Path, default=DEFAULT_REFERENCE,
                        help="folder of the paper engine's recordings (*.csv.gz), for the plots "
                             "(default $MJREGEN_REFERENCE, else ./reference)")
    parser.add_argument("--doc", type=Path, default=None, help="write the table + plots here")
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--no-plots", action="store_true")
    parser.add_argument("--spread", default="", help="comma-separated time-step safeties")
    parser.add_argument("--jobs", type=int, default=1, help="processes for --spread")
    args = parser.parse_args()
    physics = physics_from_args(args)
    if args.spread:
        print(spread(physics, [float(s) for s in args.spread.split(",")], args.jobs))
        return
    all_rows, results = [], {}
    for name in args.cases.split(","):
        cpu0 = time.process_time()
        result = CASES[name](physics)
        result.cpu_time = time.process_time() - cpu0
        results[name] = result
        for row in rows(result):
            all_rows.append(row)
            print(" | ".join(str(x) for x in row), flush=True)
        print(f"  {name}: {result.cpu_time:.1f} CPU-s, stable={result.stable}", flush=True)
    table = markdown_table(all_rows)
    print(table)
    if args.json:
        args.json.write_text(json.dumps({n: {"measures": r.measures, "cpu_time": r.cpu_time,
                                             "stable": r.stable}
                                         for n, r in results.items()}, indent=1))
    if args.doc:
        out = args.doc.parent
        out.mkdir(parents=True, exist_ok=True)
        if not args.no_plots and args.reference.exists():
            for result in results.values():
                plot(result, args.reference, out)
        (out / "fidelity_table.md").write_text(
            f"preset `{args.preset}`, scene overrides {args.scene}, friction "
            f"{args.friction}\n\n{table}\n")


if __name__ == "__main__":
    main()
