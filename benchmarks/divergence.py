"""Where mjregen and the paper's engine part: a paper robot voxel by voxel against the
engine's per-voxel recording (every 5 ms), from the start.

    python benchmarks/divergence.py multiped [--reference DIR] [--until 0.15]
        [--scene key=value ...] [--worst 12]

Both robots are compared in their own frame: each voxel's position relative to its
simulation's initial centre of mass (mjregen centres the robot at x = y = 0, the engine
starts on its lattice). Printed per sample: the RMS and largest voxel difference, the
centre of mass difference and each robot's yaw (the best 2D rotation of its centred voxel
cloud onto the initial one, degrees counter-clockwise); then, at the first samples where the
RMS exceeds 0.05 and 0.5 voxel lengths, the voxels that differ most. ``--scene`` overrides
fields of the scene or the pipeline (JSON values, as in benchmarks/fidelity.py).
"""

from __future__ import annotations

import argparse
import json
import math
import os
from pathlib import Path

import numpy as np

from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.physics.compile import compile_robot
from mjregen.validation.reference import ROBOT_FILES, load_csv
from mjregen.physics.simulation import simulation_of

ROOT = Path(__file__).resolve().parent.parent
THRESHOLDS = (0.05, 0.5)  # voxel lengths


def engine_voxels(reference: Path, name: str) -> dict[str, np.ndarray]:
    """The engine's recording: t (T,), grid index (n, 3), material (n,), positions (T, n, 3)."""
    data = load_csv(reference / f"{ROBOT_FILES[name]}_voxels.csv.gz")
    n = int(data["i"].max()) + 1
    t = data["t"].reshape(-1, n)[:, 0]
    keep = np.r_[True, np.diff(t) > 1e-9]  # a sample written twice
    positions = np.stack([data[k] for k in "xyz"], axis=1).reshape(-1, n, 3)[keep]
    index = np.stack([data[k] for k in ("ix", "iy", "iz")], axis=1)[:n].astype(int)
    return {"t": t[keep], "index": index, "material": data["mat"][:n].astype(int),
            "positions": positions}


def mjregen_voxels(name: str, times: np.ndarray, physics: Physics) -> dict[str, np.ndarray]:
    """mjregen's voxel centres (T, n, 3) at the step nearest each of `times` (s)."""
    robot = Robot.load(ROOT / "assets" / "robots" / "paper" / f"{name}.npy")
    compiled = compile_robot(robot, physics=physics)
    sim = simulation_of(compiled)
    dt, step = compiled.timestep, 0
    positions = np.empty((len(times), len(compiled.voxel_index), 3))
    for k, t in enumerate(times):
        target = int(round(t / dt))
        if target > step and sim.run(target - step):
            positions = positions[:k]
            break
        step = max(step, target)
        positions[k] = sim.data.qpos.reshape(-1, 7)[:, :3]
    return {"index": np.asarray(compiled.voxel_index), "positions": positions}


def matching_order(engine_index: np.ndarray, our_index: np.ndarray) -> np.ndarray:
    """(n,) the index in mjregen's voxels of each engine voxel: grid indices up to each
    side's own origin."""
    key = {tuple(i): k for k, i in enumerate(our_index - our_index.min(axis=0))}
    return np.array([key[tuple(i)] for i in engine_index - engine_index.min(axis=0)])


def yaw(cloud: np.ndarray) -> np.ndarray:
    """(T,) degrees: the rotation about z that best maps the centred x-y cloud at time 0
    onto the one at each time (2D Kabsch)."""
    start = cloud[0, :, :2] - cloud[0, :, :2].mean(axis=0)
    out = []
    for frame in cloud:
        now = frame[:, :2] - frame[:, :2].mean(axis=0)
        h = start.T @ now
        out.append(math.degrees(math.atan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])))
    return np.array(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("robot", choices=sorted(ROBOT_FILES))
    parser.add_argument("--reference", type=Path,
                        default=Path(os.environ.get("MJREGEN_REFERENCE", "reference")),
                        help="folder of the engine's recordings (default $MJREGEN_REFERENCE, "
                             "else ./reference)")
    parser.add_argument("--until", type=float, default=0.15, help="s of samples to print")
    parser.add_argument("--scene", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--worst", type=int, default=12, help="voxels listed per threshold")
    args = parser.parse_args()
    overrides = {k: json.loads(v) for k, v in (item.split("=", 1) for item in args.scene)}
    physics = Physics().replace(**overrides)
    engine = engine_voxels(args.reference, args.robot)
    ours = mjregen_voxels(args.robot, engine["t"], physics)
    order = matching_order(engine["index"], ours["index"])
    length = physics.scene.voxel_size
    count = len(ours["positions"])
    theirs, mine = engine["positions"][:count], ours["positions"][:, order]
    theirs = theirs - theirs[0].mean(axis=0)  # equal voxel masses: COM = mean centre
    mine = mine - mine[0].mean(axis=0)
    gap = np.linalg.norm(theirs - mine, axis=2) / length  # (T, n) voxel lengths
    rms = np.sqrt((gap ** 2).mean(axis=1))
    com = (mine.mean(axis=1) - theirs.mean(axis=1)) / length
    yaw_theirs, yaw_mine = yaw(theirs), yaw(mine)
    print(f"{args.robot}: {count} samples compared, overrides {overrides or 'none'}")
    print("  t ms | RMS L | max L | COM mjregen - engine (L) | yaw engine, mjregen (deg)")
    for k, t in enumerate(engine["t"][:count]):
        if t <= args.until + 1e-9 or k == count - 1:
            print(f"{t * 1e3:6.1f} | {rms[k]:.4f} | {gap[k].max():.4f} | {com[k, 0]:+.3f} "
                  f"{com[k, 1]:+.3f} {com[k, 2]:+.3f} | {yaw_theirs[k]:+.1f} {yaw_mine[k]:+.1f}")
    for threshold in THRESHOLDS:
        above = np.flatnonzero(rms > threshold)
        if not above.size:
            print(f"\nthe RMS never exceeds {threshold} L")
            continue
        k = above[0]
        print(f"\nfirst RMS > {threshold} L at {engine['t'][k] * 1e3:.1f} ms; the voxels that "
              "differ most: grid index, material, difference (L), height engine / mjregen (mm)")
        for j in np.argsort(-gap[k])[: args.worst]:
            print(f"  {tuple(int(i) for i in engine['index'][j])} {engine['material'][j]} "
                  f"{gap[k, j]:.3f}  {engine['positions'][k, j, 2] * 1e3:.3f} / "
                  f"{ours['positions'][k, order[j], 2] * 1e3:.3f}")


if __name__ == "__main__":
    main()
