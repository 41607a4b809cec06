"""The beam bonds of many robots as one batched computation (torch), against the voxel plugin.

    python benchmarks/batched_bonds.py [--robots 20] [--rounds 5] [--device cpu]
        [--json out.json]

A prototype of the ground for GPUs (docs/gpu.md): the plugin's beam bond law
(`mjregen/physics/plugin/forces.c`, `beam_bond`), written as tensor operations over every
bond of a batch of robots at once (the robots' voxels concatenated, each bond naming its two
voxels by index; a GPU library that needs equal sizes per world pads instead), in float64,
each operation in the plugin's order. It reports:

- agreement: the generalized bond forces of each robot (the shipped walkers, the paper's
  robots and random initial 3D robots, each in a deformed, moving state taken from its walk
  with muscles active) against the plugin's (`mj_forward` on the same robot with only its
  bonds: floor, drag and self-collision off), as the largest difference relative to the
  largest force;
- throughput: CPU (or `--device`) seconds per voxel of one force evaluation of the whole
  batch, median of `--rounds`, beside the plugin's whole native step per voxel (bonds,
  floor, collision, drag and the integration: more work than the batch does).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import torch

from mjregen.grid import Robot
from mjregen.growth.nca import NCAConfig, grow
from mjregen.growth.networks import random_genomes
from mjregen.physics import Physics, VoxelPipeline
from mjregen.physics.compile import CompiledRobot, compile_robot
from mjregen.physics.simulation import simulation_of

ASSETS = Path(__file__).resolve().parent.parent / "assets"
SERIES_LIMIT = 0.09  # s² at and above which the rotation gain takes asin (as the plugin)


@dataclass
class BondBatch:
    """The beam bonds of a batch of 3D robots, voxels concatenated in robot order.

    Attributes:
      i, j: ``(B,)`` long, each bond's voxels (batch indices).
      axis: ``(B,)`` long, the bond's rest axis.
      constants: ``(13, B)`` float64: k_axial, k_shear, k_bend, k_twist, beta, beta_bend,
        beta_twist, k0, kd, lateral², muscle_plus·L, muscle_minus·L, driven (1/0).
      first_voxel: ``(R + 1,)`` the batch index of each robot's first voxel, and the total.
      voxel_size: m.
    """

    i: torch.Tensor
    j: torch.Tensor
    axis: torch.Tensor
    constants: torch.Tensor
    first_voxel: list[int]
    voxel_size: float


def bond_batch(robots: list[CompiledRobot], device: str) -> BondBatch:
    """The batch of `robots` (compiled with beam bonds)."""
    ends, axes, rows, first = [], [], [], [0]
    for compiled in robots:
        beams = compiled.bonds.beams
        ends.append(beams.ends + first[-1])
        axes.append(beams.axis)
        muscle = np.zeros((beams.count, 2))
        muscle[: len(beams.muscle_weights)] = beams.muscle_weights
        driven = np.zeros(beams.count)
        driven[: len(beams.muscle_weights)] = 1.0
        L = compiled.physics.scene.voxel_size
        rows.append(np.column_stack([beams.stiffness, beams.beta, beams.axial_law,
                                     muscle * L, driven]))
        first.append(first[-1] + len(compiled.voxel_index))
    ends, table = np.concatenate(ends), np.concatenate(rows).T
    as_long = {"dtype": torch.long, "device": device}
    return BondBatch(i=torch.tensor(ends[:, 0], **as_long), j=torch.tensor(ends[:, 1], **as_long),
                     axis=torch.tensor(np.concatenate(axes), **as_long),
                     constants=torch.tensor(table, dtype=torch.float64, device=device),
                     first_voxel=first, voxel_size=robots[0].physics.scene.voxel_size)


def voxel_frames(qpos: torch.Tensor, qvel: torch.Tensor) -> dict[str, torch.Tensor]:
    """Each voxel's position, unit quaternion, rotation matrix (rows of 9), velocity and
    world angular velocity from its free joint's ``(V, 7)`` qpos and ``(V, 6)`` qvel, as the
    plugin's `voxel_states`."""
    qw, qx, qy, qz = qpos[:, 3], qpos[:, 4], qpos[:, 5], qpos[:, 6]
    norm = torch.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    qw, qx, qy, qz = qw / norm, qx / norm, qy / norm, qz / norm
    q00, q01, q02, q03 = qw * qw, qw * qx, qw * qy, qw * qz
    q11, q12, q13 = qx * qx, qx * qy, qx * qz
    q22, q23, q33 = qy * qy, qy * qz, qz * qz
    R = torch.stack([q00 + q11 - q22 - q33, 2 * (q12 - q03), 2 * (q13 + q02),
                     2 * (q12 + q03), q00 - q11 + q22 - q33, 2 * (q23 - q01),
                     2 * (q13 - q02), 2 * (q23 + q01), q00 - q11 - q22 + q33])
    o0, o1, o2 = qvel[:, 3], qvel[:, 4], qvel[:, 5]
    w = torch.stack([R[0] * o0 + R[1] * o1 + R[2] * o2, R[3] * o0 + R[4] * o1 + R[5] * o2,
                     R[6] * o0 + R[7] * o1 + R[8] * o2])
    return {"p": qpos[:, :3].T, "q": torch.stack([qw, qx, qy, qz]), "R": R,
            "v": qvel[:, :3].T, "w": w}


def _rotation_gain(s2: torch.Tensor) -> torch.Tensor:
    """2 asin(s) / s with s² = `s2`: the plugin's series below SERIES_LIMIT, asin above."""
    series = 2.0 + s2 * (1.0 / 3.0 + s2 * (0.15 + s2 * (5.0 / 56.0 + s2 * 35.0 / 576.0)))
    sn = torch.sqrt(s2)
    exact = 2.0 * torch.asin(torch.clamp(sn, max=1.0)) / sn
    return torch.where(s2 < SERIES_LIMIT, series, exact)


def _mid_frame(qi: torch.Tensor, qj: torch.Tensor):
    """Each bond's rotation vector of q_i⁻¹ q_j (short way), its gain and the mid frame's
    rotation matrix (9 rows), as the plugin's `beam_bond`."""
    rw = qi[0] * qj[0] + qi[1] * qj[1] + qi[2] * qj[2] + qi[3] * qj[3]
    rv = [qi[0] * qj[1] - qj[0] * qi[1] - (qi[2] * qj[3] - qi[3] * qj[2]),
          qi[0] * qj[2] - qj[0] * qi[2] - (qi[3] * qj[1] - qi[1] * qj[3]),
          qi[0] * qj[3] - qj[0] * qi[3] - (qi[1] * qj[2] - qi[2] * qj[1])]
    flip = rw < 0.0
    rw = torch.where(flip, -rw, rw)
    rv = [torch.where(flip, -r, r) for r in rv]
    s2 = rv[0] * rv[0] + rv[1] * rv[1] + rv[2] * rv[2]
    hn = 1.0 / torch.sqrt((1.0 + rw) * (1.0 + rw) + s2)
    hw, hv0, hv1, hv2 = (1.0 + rw) * hn, rv[0] * hn, rv[1] * hn, rv[2] * hn
    mw = qi[0] * hw - qi[1] * hv0 - qi[2] * hv1 - qi[3] * hv2
    mx = qi[0] * hv0 + qi[1] * hw + qi[2] * hv2 - qi[3] * hv1
    my = qi[0] * hv1 + qi[2] * hw + qi[3] * hv0 - qi[1] * hv2
    mz = qi[0] * hv2 + qi[3] * hw + qi[1] * hv1 - qi[2] * hv0
    M = [mw * mw + mx * mx - my * my - mz * mz, 2 * (mx * my - mw * mz),
         2 * (mx * mz + mw * my), 2 * (mx * my + mw * mz), mw * mw - mx * mx + my * my - mz * mz,
         2 * (my * mz - mw * mx), 2 * (mx * mz - mw * my), 2 * (my * mz + mw * mx),
         mw * mw - mx * mx - my * my + mz * mz]
    return rv, _rotation_gain(s2), M


def _to_mid(M: list, x: list) -> list:
    """M^T x."""
    return [M[0] * x[0] + M[3] * x[1] + M[6] * x[2], M[1] * x[0] + M[4] * x[1] + M[7] * x[2],
            M[2] * x[0] + M[5] * x[1] + M[8] * x[2]]


def _to_world(M: list, x: list) -> list:
    """M x."""
    return [M[0] * x[0] + M[1] * x[1] + M[2] * x[2], M[3] * x[0] + M[4] * x[1] + M[5] * x[2],
            M[6] * x[0] + M[7] * x[1] + M[8] * x[2]]


def bond_forces(batch: BondBatch, frames: dict, ep: float, em: float):
    """Each bond's force on j and torques on i and j (world, ``(3, B)`` each) at muscle strains
    (`ep`, `em`), as the plugin's `beam_bond`."""
    i, j, c = batch.i, batch.j, batch.constants
    rv, gain, M = _mid_frame(frames["q"][:, i], frames["q"][:, j])
    p, v, w = frames["p"], frames["v"], frames["w"]
    dw = [p[a, j] - p[a, i] for a in range(3)]
    wm = [0.5 * (w[a, j] + w[a, i]) for a in range(3)]
    uw = [(v[0, j] - v[0, i]) - (wm[1] * dw[2] - wm[2] * dw[1]),
          (v[1, j] - v[1, i]) - (wm[2] * dw[0] - wm[0] * dw[2]),
          (v[2, j] - v[2, i]) - (wm[0] * dw[1] - wm[1] * dw[0])]
    d, dd, dD = _to_mid(M, dw), _to_mid(M, uw), _to_mid(M, [w[a, j] - w[a, i] for a in range(3)])
    k_axial, k_shear, k_bend, k_twist, beta, bend, twist, k0, kd, lat2, mp, mm, driven = c
    rest = torch.where(driven > 0.0, batch.voxel_size + (mp * ep + mm * em),
                       torch.full_like(mp, batch.voxel_size))
    along = [batch.axis == a for a in range(3)]
    B = [torch.where(along[a], k_twist * (gain * rv[a] + twist * dD[a]),
                     k_bend * (gain * rv[a] + bend * dD[a])) for a in range(3)]
    length = torch.where(along[0], d[0], torch.where(along[1], d[1], d[2]))
    rate = torch.where(along[0], dd[0], torch.where(along[1], dd[1], dd[2]))
    s_now, s_rest = torch.sqrt(length * length + lat2), torch.sqrt(rest * rest + lat2)
    axial = -k0 * (length - rest) - beta * k_axial * rate
    stiffening = kd * (s_now - s_rest) * length / s_now
    axial = torch.where(s_now > 0.0, axial - stiffening, axial)
    F = [torch.where(along[a], axial, -k_shear * (d[a] + beta * dd[a])) for a in range(3)]
    G = [torch.where(along[a], axial, -k_shear * (d[a] + bend * dd[a])) for a in range(3)]
    cross = [-0.5 * (d[1] * G[2] - d[2] * G[1]), -0.5 * (d[2] * G[0] - d[0] * G[2]),
             -0.5 * (d[0] * G[1] - d[1] * G[0])]
    Ti = [cross[a] + B[a] for a in range(3)]
    Tj = [cross[a] - B[a] for a in range(3)]
    return (torch.stack(_to_world(M, F)), torch.stack(_to_world(M, Ti)),
            torch.stack(_to_world(M, Tj)))


def generalized_forces(batch: BondBatch, qpos: torch.Tensor, qvel: torch.Tensor, ep: float,
                       em: float) -> torch.Tensor:
    """``(V, 6)`` generalized bond forces of every voxel of the batch (force, body-frame
    torque), summed in bond order as the plugin sums them."""
    frames = voxel_frames(qpos, qvel)
    F, Ti, Tj = bond_forces(batch, frames, ep, em)
    n_voxels = qpos.shape[0]
    ends = torch.stack([batch.j, batch.i], dim=1).reshape(-1)  # bond order: j then i
    force = torch.zeros((n_voxels, 3), dtype=torch.float64, device=qpos.device)
    torque = torch.zeros_like(force)
    force.index_add_(0, ends, torch.stack([F.T, -F.T], dim=1).reshape(-1, 3))
    torque.index_add_(0, ends, torch.stack([Tj.T, Ti.T], dim=1).reshape(-1, 3))
    R = frames["R"]
    body = torch.stack([R[a] * torque[:, 0] + R[3 + a] * torque[:, 1] + R[6 + a] * torque[:, 2]
                        for a in range(3)], dim=1)
    return torch.cat([force, body], dim=1)


def robots(count: int) -> dict[str, Robot]:
    """The shipped 3D walkers, the paper's robots and `count` random initial 3D robots."""
    chosen = {name: Robot.load(ASSETS / "robots" / "paper" / f"{name}.npy")
              for name in ("tripod", "biped", "multiped")}
    chosen.update({path.stem: Robot.load(path) for path in sorted(
        (ASSETS / "nca").glob("walker_3d_*.npy"))})
    config = NCAConfig(dim=3, kind="ff")
    grids = [g for g in grow(config, random_genomes(config, 3 * count, seed=0)).grids if g.any()]
    chosen.update({f"random_{k}": Robot(g) for k, g in enumerate(grids[:count])})
    return chosen


def moving_state(robot: Robot) -> tuple[np.ndarray, np.ndarray, float, float,
                                        tuple[float, float]]:
    """(qpos, qvel, time s, step s, muscle strains) of `robot` a quarter of a muscle cycle after the
    settle, walked with the default physics: bonds deformed and moving, muscles active."""
    sim = simulation_of(compile_robot(robot))
    steps = round((0.05 + 0.25 / 40.0) / sim.model.opt.timestep)
    sim.run(steps)
    dt = sim.model.opt.timestep
    return sim.data.qpos.copy(), sim.data.qvel.copy(), steps * dt, dt, sim.strains(steps * dt)


def plugin_bond_forces(compiled: CompiledRobot, qpos: np.ndarray, qvel: np.ndarray, t: float,
                       dt: float) -> np.ndarray:
    """``(V, 6)`` the plugin's generalized forces of `compiled` (bonds only) in that state at
    time `t` of a walk with steps `dt` (the plugin takes the muscles' phase at the nearest
    step; without its floor the robot's own step would differ)."""
    compiled.model.opt.timestep = dt
    data = mujoco.MjData(compiled.model)
    data.qpos[:], data.qvel[:], data.time = qpos, qvel, t
    mujoco.mj_forward(compiled.model, data)
    return data.qfrc_passive.reshape(-1, 6).copy()


def plugin_step_seconds(robot: Robot, steps: int = 2000) -> float:
    """CPU s of one native step of `robot` with the default physics (everything)."""
    sim = simulation_of(compile_robot(robot))
    cpu = time.process_time()
    sim.run(steps)
    return (time.process_time() - cpu) / steps


def markdown_section(report: dict) -> list[str]:
    """docs/performance.md's section on the batched prototype (a `main` report)."""
    agreement = report["agreement"].values()
    worst = max(row["largest relative difference"] for row in agreement)
    identical = sum(row["bit-identical"] for row in agreement)
    batched = report["batched bond forces: CPU s per voxel"]
    plugin = report["plugin native step (everything): CPU s per voxel, median"]
    return [
        "", "## The bond forces of many robots as one computation (GPU prepared)", "",
        f"`python benchmarks/batched_bonds.py --robots {report['random robots']}` (design and "
        "blockers: docs/gpu.md): the plugin's beam bond law as batched tensor operations "
        f"(torch, float64, on {report['device']} with {report['torch_threads']} threads) over "
        f"{report['robots']} robots at once ({report['voxels']:,} voxels, {report['bonds']:,} "
        "bonds: the shipped 3D walkers, the paper's robots and random initial robots).", "",
        f"- Agreement with the plugin, each robot in a deformed, moving state of its walk: "
        f"largest difference {worst:.1e} of the largest force; bit-identical in {identical} of "
        f"{report['robots']} robots (the operations are the plugin's, in its order, but "
        "torch's vectorised kernels round some differently).",
        f"- Cost: {1e6 * batched:.2f} CPU µs per voxel for one evaluation of the bond forces "
        f"({1e6 * report['batched bond forces: wall s per voxel']:.2f} µs wall), against "
        f"{1e6 * plugin:.2f} CPU µs per voxel for the plugin's whole native step (bonds, "
        "floor, self-collision, drag, integration): on a CPU the batch is "
        f"{batched / plugin:.0f} times slower, so batching pays only on a GPU, where it has "
        "not yet been measured (no GPU was lent to this project's runs).",
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=20, help="random initial 3D robots")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    bonds_only = Physics().replace(floor=False, drag_ratio=0.0,
                                   pipeline=VoxelPipeline(collision_radius=0.0))
    chosen = robots(args.robots)
    compiled, states, agreement = [], [], {}
    for robot in chosen.values():
        compiled.append(compile_robot(robot, physics=bonds_only))
        states.append(moving_state(robot))
    batch = bond_batch(compiled, args.device)
    as_tensor = {"dtype": torch.float64, "device": args.device}
    for name, robot, (qpos, qvel, t, dt, (ep, em)) in zip(chosen, compiled, states):
        one = bond_batch([robot], args.device)
        ours = generalized_forces(one, torch.tensor(qpos.reshape(-1, 7), **as_tensor),
                                  torch.tensor(qvel.reshape(-1, 6), **as_tensor), ep, em)
        theirs = plugin_bond_forces(robot, qpos, qvel, t, dt)
        difference = np.abs(ours.cpu().numpy() - theirs).max() / np.abs(theirs).max()
        agreement[name] = {"voxels": len(robot.voxel_index), "bonds": robot.bonds.count,
                           "largest relative difference": float(difference),
                           "bit-identical": bool(difference == 0.0)}
    # the throughput of the whole batch at one strain (the muscles' value matters not here)
    qpos = torch.tensor(np.concatenate([s[0].reshape(-1, 7) for s in states]), **as_tensor)
    qvel = torch.tensor(np.concatenate([s[1].reshape(-1, 6) for s in states]), **as_tensor)
    seconds = []
    for _ in range(args.rounds):
        cpu, wall = time.process_time(), time.perf_counter()
        generalized_forces(batch, qpos, qvel, -0.05, 0.0)
        if args.device != "cpu":
            torch.cuda.synchronize()
        seconds.append((time.process_time() - cpu, time.perf_counter() - wall))
    n_voxels = batch.first_voxel[-1]
    batched_cpu = statistics.median(s[0] for s in seconds) / n_voxels
    batched_wall = statistics.median(s[1] for s in seconds) / n_voxels
    plugin = [plugin_step_seconds(robot) / robot.n_voxels for robot in chosen.values()]
    report = {"robots": len(chosen), "random robots": args.robots, "voxels": n_voxels, "bonds": int(batch.i.numel()),
              "device": args.device, "torch_threads": torch.get_num_threads(),
              "agreement": agreement,
              "batched bond forces: CPU s per voxel": batched_cpu,
              "batched bond forces: wall s per voxel": batched_wall,
              "plugin native step (everything): CPU s per voxel, median":
                  statistics.median(plugin)}
    text = json.dumps(report, indent=2)
    print(text)
    if args.json:
        args.json.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
