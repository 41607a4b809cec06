"""Do small changes of the physics tell the walks that transfer from those that do not?

    python benchmarks/perturbed_physics.py TRANSFER_JSON [--root ROOT] [--only 3d_]
        [--change 0.03] [--radius 0.02] [--own-starts] [--json out.json]

TRANSFER_JSON is a `benchmarks/transfer.py --json` file (e.g. records/paper/transfer.json):
its robots measured in the paper's engine, each with its verdict ("transfers"), of which
those whose name starts with ``--only`` (default ``3d_``: the 3D runs' robots, which walk for
the 3D times) are taken; their files are ROOT/<name> (ROOT: the JSON's folder unless
given). Each robot walks in mjregen
from start 0 (seed 0) with today's default physics and with six changes of it, one at a
time: every material's Young's modulus times 1 ± ``--change``, every material's static and
kinetic friction times 1 ± ``--change``, and the self-collision radius ± ``--radius`` voxel
lengths (with ``--own-starts`` the k-th of the seven walks from start k instead, as a
fitness that gives each start its own change of the physics would). Printed per robot: the seven distances (voxel lengths over the paper's 0.5 s), their
spread (standard deviation / mean) and lowest / default; then the spreads of the robots that
transfer against those that do not (`mjregen.search.compare`: exact Mann-Whitney and
permutation tests), and the rank correlation with the engine's walks of the default
distance, of the mean and of the lowest of the seven.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.physics.simulation import simulate_starts
from mjregen.search.compare import compare_groups


def variants(change: float, radius: float) -> dict[str, Physics]:
    """The default physics and its six one-at-a-time changes, by name."""
    base = Physics()

    def materials(stiffness: float = 1.0, friction: float = 1.0) -> Physics:
        return dataclasses.replace(base, materials={
            m: dataclasses.replace(p, youngs_modulus=p.youngs_modulus * stiffness,
                                   friction=p.friction * friction,
                                   kinetic_friction=p.kinetic_friction * friction)
            for m, p in base.materials.items()})

    r = base.pipeline.collision_radius
    return {"default": base,
            f"E x{1 - change:g}": materials(stiffness=1 - change),
            f"E x{1 + change:g}": materials(stiffness=1 + change),
            f"mu x{1 - change:g}": materials(friction=1 - change),
            f"mu x{1 + change:g}": materials(friction=1 + change),
            f"collision r {r - radius:g}": base.replace(collision_radius=r - radius),
            f"collision r {r + radius:g}": base.replace(collision_radius=r + radius)}


def spearman(x: np.ndarray, y: np.ndarray) -> float:
    """Rank correlation of two samples without ties."""
    rx, ry = np.argsort(np.argsort(x)), np.argsort(np.argsort(y))
    return float(np.corrcoef(rx, ry)[0, 1])


def measure(entries: list[dict], root: Path, physics: dict[str, Physics], only: str,
            own_starts: bool = False) -> list[dict]:
    """One row per robot of `entries` named ``only...`` and measured in the engine: its walks
    under `physics`, from start 0, or the k-th from start k (`own_starts`)."""
    rows = []
    for entry in entries:
        if not entry["name"].startswith(only) or entry.get("engine") is None:
            continue
        robot = Robot.load(root / entry["name"])
        walks = {name: simulate_starts(robot, physics=p, starts=[k if own_starts else 0])[0]
                 .distance for k, (name, p) in enumerate(physics.items())}
        values = np.array(list(walks.values()))
        rows.append({"name": entry["name"], "voxels": robot.n_voxels,
                     "transfers": bool(entry["transfers"]), "engine": entry["engine"],
                     "walks": walks, "spread": float(values.std() / abs(values.mean())),
                     "lowest_share": float(values.min() / values[0])})
        print(rows[-1], flush=True)
    return rows


def summary(rows: list[dict]) -> list[str]:
    """The table and the tests, as Markdown lines."""
    names = list(rows[0]["walks"])
    lines = [f"| robot | voxels | transfers | engine | {' | '.join(names)} | spread | lowest / "
             "default |", "|---|---|---|---|" + "---|" * (len(names) + 2)]
    for r in rows:
        lines.append(f"| {r['name'].split('/best')[0]} | {r['voxels']} | "
                     f"{'yes' if r['transfers'] else 'no'} | {r['engine']:.2f} | "
                     + " | ".join(f"{v:.2f}" for v in r["walks"].values())
                     + f" | {r['spread']:.2f} | {r['lowest_share']:.2f} |")
    spread = {flag: [r["spread"] for r in rows if r["transfers"] == flag] for flag in (True, False)}
    lines += ["", "Spread, " + compare_groups(spread[True], spread[False]).sentence(
        ("robots that transfer", "robots that do not")) + "."]
    engine = np.array([r["engine"] for r in rows])
    walks = np.array([list(r["walks"].values()) for r in rows])
    lines.append("Rank correlation with the engine's walks (Spearman, n = "
                 f"{len(rows)}): the default distance {spearman(walks[:, 0], engine):.2f}, "
                 f"the mean of the seven {spearman(walks.mean(axis=1), engine):.2f}, the "
                 f"lowest {spearman(walks.min(axis=1), engine):.2f}.")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("transfer_json", type=Path, help="a benchmarks/transfer.py --json file")
    parser.add_argument("--root", type=Path, help="the robots' folder (default: the JSON's)")
    parser.add_argument("--only", default="3d_",
                        help="the robots whose name starts so (default 3d_: the 3D runs')")
    parser.add_argument("--change", type=float, default=0.03,
                        help="relative change of stiffness and friction (default 0.03)")
    parser.add_argument("--radius", type=float, default=0.02,
                        help="change of the self-collision radius, voxel lengths (default 0.02)")
    parser.add_argument("--own-starts", action="store_true",
                        help="the k-th walk from start k (default: every walk from start 0)")
    parser.add_argument("--json", type=Path, help="write the rows here")
    args = parser.parse_args(argv)
    if not (0.0 < args.change < 1.0 and 0.0 < args.radius < 0.5):
        parser.error("--change must be in (0, 1) and --radius in (0, 0.5)")
    try:
        entries = json.loads(args.transfer_json.read_text())
        rows = measure(entries, args.root or args.transfer_json.parent,
                       variants(args.change, args.radius), args.only, args.own_starts)
    except (OSError, ValueError, KeyError) as error:
        parser.error(f"{args.transfer_json}: {error}")
    if len({r["transfers"] for r in rows}) < 2:
        parser.error("the JSON needs 3D robots that transfer and robots that do not")
    print("\n".join(summary(rows)))
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
