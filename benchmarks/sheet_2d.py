"""The paper's 2D robots are sheets: mjregen's sheet beside the paper's engine, and its cost.

    python benchmarks/sheet_2d.py --voxelyze DIR [--robots 40] [--seed 0] [NAME=PATTERN.npy ...]
        [--json out.json]

The paper's code writes a grown 2D pattern into Voxelyze as one layer of voxels lying on the
floor (Z_Voxels 1) and walks it for 1.0 s of settle and 0.25 s measured. Each robot here
(the non-empty patterns of ``--robots`` initial genomes of each 2D network, seed ``--seed``,
and the patterns given) is walked three ways: as that sheet in mjregen (the default physics
for the 2D times, start 0: `mjregen.tasks.bodies.body_physics`), as the same sheet in the
paper's engine (DIR: its folder with ``vxa.py``), and as a robot in the x-z plane (mjregen's
"grid" body of a 2D pattern, which the engine cannot run). Prints the distances and the CPU
seconds of each walk, and a summary: the engine's distance over mjregen's for the robots
that move (> 0.01 voxel lengths in either), and the CPU seconds per evaluation of each body.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from settle_rest import initial_patterns  # the sibling benchmark, beside this script

from mjregen.grid import Robot, lay_flat
from mjregen.physics import Physics
from mjregen.physics.simulation import simulate
from mjregen.tasks.bodies import body_physics
from mjregen.validation.engine import PAPER_DT_FRACTION, PaperEngine

MOVES = 0.01  # voxel lengths: a robot that moves less in both is left out of the ratios


def walk_three_ways(name: str, pattern: np.ndarray, engine: PaperEngine) -> dict:
    """Distances (voxel lengths) and CPU s of `pattern` as a sheet in mjregen and in the
    engine, and as a robot in the x-z plane."""
    sheet = Robot(lay_flat(pattern))
    physics = body_physics(Physics(), "sheet")
    start = time.process_time()
    mjregen = simulate(sheet, physics=physics)
    mjregen_cpu = time.process_time() - start
    start = time.process_time()
    plane = simulate(Robot(pattern))
    plane_cpu = time.process_time() - start
    times = physics.scene.timing(3)
    answer = engine.run_window(sheet.grid, dt_fraction=PAPER_DT_FRACTION, stop=sum(times),
                               measure_from=times[0])
    return {"name": name, "voxels": sheet.n_voxels, "sheet": mjregen.distance,
            "sheet_stable": mjregen.stable, "sheet_cpu_s": mjregen_cpu,
            "engine": answer["distance"], "engine_cpu_s": answer["cpu_s"],
            "plane": plane.distance, "plane_cpu_s": plane_cpu}


def summary(rows: list[dict]) -> str:
    moving = [r for r in rows if max(r["sheet"], r["engine"]) > MOVES]
    ratios = np.array([r["engine"] / r["sheet"] for r in moving if r["sheet"] > MOVES])

    def within(low: float, high: float) -> int:
        return int(np.sum((ratios >= low) & (ratios <= high)))

    cpu = {k: float(np.median([r[f"{k}_cpu_s"] for r in rows]))
           for k in ("sheet", "engine", "plane")}
    lines = [f"- {len(rows)} robots, {len(moving)} move more than {MOVES} voxel lengths "
             f"(in mjregen's sheet or the engine's); unstable in mjregen: "
             f"{sum(not r['sheet_stable'] for r in rows)}."]
    if len(ratios):
        lines.append(
            f"- engine / mjregen sheet distance over the {len(ratios)} that move in mjregen: "
            f"median {np.median(ratios):.3f}, quartiles {np.quantile(ratios, 0.25):.3f}-"
            f"{np.quantile(ratios, 0.75):.3f}, range {ratios.min():.3f}-{ratios.max():.3f}; "
            f"within 0.8-1.25: {within(0.8, 1.25)}, within 0.5-2: {within(0.5, 2.0)}.")
    lines.append(f"- CPU s per evaluation, medians: mjregen sheet {cpu['sheet']:.3f}, the "
                 f"optimised engine {cpu['engine']:.3f} (mjregen / engine "
                 f"{cpu['sheet'] / cpu['engine']:.2f}), mjregen x-z plane robot "
                 f"{cpu['plane']:.3f}.")
    return "\n".join(lines)


def markdown(rows: list[dict]) -> str:
    head = ["| robot | voxels | sheet in mjregen | sheet in the engine | engine / mjregen | "
            "x-z plane robot in mjregen | CPU s: mjregen, engine |",
            "|---|---|---|---|---|---|---|"]
    body = [f"| {r['name']} | {r['voxels']} | {r['sheet']:.4f} | {r['engine']:.4f} | "
            + (f"{r['engine'] / r['sheet']:.3f}" if r["sheet"] > MOVES else "–")
            + f" | {r['plane']:.4f} | {r['sheet_cpu_s']:.3f}, {r['engine_cpu_s']:.3f} |"
            for r in rows]
    return "\n".join(head + body)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--voxelyze", type=Path, required=True,
                        help="folder of the paper's engine and its vxa.py")
    parser.add_argument("patterns", nargs="*", help="2D patterns (.npy) or NAME=PATH")
    parser.add_argument("--robots", type=int, default=40,
                        help="initial genomes per network (default 40)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    engine = PaperEngine(args.voxelyze)
    todo = [(name or Path(path).stem, np.load(path))
            for name, _, path in (item.rpartition("=") for item in args.patterns)]
    bad = [name for name, pattern in todo if pattern.ndim != 2]
    if bad:
        parser.error(f"not 2D patterns: {', '.join(bad)}")
    todo += initial_patterns(args.robots, args.seed)
    rows = []
    for name, pattern in todo:
        rows.append(walk_three_ways(name, pattern, engine))
        print(markdown(rows[-1:]).splitlines()[-1], flush=True)
    print(markdown(rows))
    print(summary(rows))
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
