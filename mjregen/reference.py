"""The paper engine's reference cases, re-run in mjregen.

The reference trajectories (recorded from the paper's Voxelyze build) cover small
mechanical cases and the paper's three robots. This module sets up each
case in mjregen with a given `Physics`, runs it and returns the same measures the
reference's `summary.json` holds, plus traces for plots. The reference numbers that the
cases are judged by are copied here (`REFERENCE`), so tests need no data files.

Units: SI (m, s) unless a name says otherwise ("vox" = voxel lengths).
"""

from __future__ import annotations

import gzip
import math
import os
from dataclasses import dataclass, field
from typing import Callable

import mujoco
import numpy as np

from mjregen.grid import Material, Robot
from mjregen.physics import Physics
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import Simulation, simulation_of
from mjregen.resources import asset

PAPER_ROBOTS = asset("robots", "paper")

# From the reference's summary.json (paper engine, its default settings).
REFERENCE = {
    "drop_voxel": {"rest_z": 0.4986266e-3, "rebound": 4.611e-5, "min_zbot": -5.825e-5},
    "drop_block": {"rest_z": 1.4913018e-3, "first_apex_z": 1.72913e-3, "zmin": 1.375927e-3},
    "slide_bar_v0.2": {"slide": 1.36786e-3, "stop_after": 13.9e-3},
    "slide_bar_v0.1": {"slide": 0.35094e-3, "stop_after": 7.1e-3},
    "bar_red_green": {"len_min": 0.92949e-3, "len_max": 1.0e-3},
    "cantilever": {"sag_end": 0.2844656e-3, "sag_max": 0.5185711e-3, "sag_max_t": 8.913e-3},
    "biped": {"distance": 40.4904},
    "tripod": {"distance": 43.5776},
    "multiped": {"distance": 42.8010},
}
# COM height after the 0.05 s settle and its mean while walking (from the trajectories).
ROBOT_FILES = {"biped": "biped_selfcol_on", "tripod": "tripod_selfcol_on",
               "multiped": "multiped_selfcol_on"}


@dataclass
class CaseResult:
    """Measures of one case and traces to plot.

    Attributes:
      name: case name.
      measures: {measure: value} in SI units (robots: distance in voxel lengths).
      traces: {label: (t, values)} for plots; robots: "com" with values ``(n, 3)``.
      cpu_time: CPU seconds spent.
      stable: False when the simulation diverged.
    """

    name: str
    measures: dict[str, float]
    traces: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    cpu_time: float = 0.0
    stable: bool = True


def load_csv(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """A reference ``.csv.gz`` as {column: values}."""
    with gzip.open(path, "rt") as f:
        header = f.readline().strip().split(",")
    values = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {name: values[:, i] for i, name in enumerate(header)}


def _run_recording(sim: Simulation, body_ids: np.ndarray, duration: float, *,
                   every: int = 1) -> tuple[np.ndarray, np.ndarray, str]:
    """(t, xpos ``(n, n_voxels, 3)``, reason) sampled every `every` steps."""
    dt = sim.model.opt.timestep
    n = int(round(duration / dt))
    mujoco.mj_kinematics(sim.model, sim.data)
    ts, xs = [sim.steps * dt], [sim.data.xpos[body_ids].copy()]
    reason = ""
    done = 0
    while done < n:
        k = min(every, n - done)
        reason = sim.run(k)
        done += k
        ts.append(sim.steps * dt)
        xs.append(sim.data.xpos[body_ids].copy())
        if reason:
            break
    return np.array(ts), np.array(xs), reason


def _first_bounce(z: np.ndarray) -> tuple[int, float]:
    """(index of the first minimum, height of the apex that follows) of a falling z(t)."""
    dz = np.diff(z)
    rising = np.nonzero(dz > 0)[0]
    if not len(rising):
        return len(z) - 1, float(z[-1])
    low = int(rising[0])
    falling = np.nonzero(dz[low:] < 0)[0]
    end = low + int(falling[0]) + 1 if len(falling) else len(z)
    return low, float(z[low:end].max())


def _block(shape: tuple[int, ...], material: Material = Material.SOFT) -> Robot:
    return Robot.from_body(np.full(shape, int(material), dtype=np.int8))


def drop_voxel(physics: Physics) -> CaseResult:
    """One soft voxel, bottom face at 5 mm, 0.1 s: rest height, rebound, penetration."""
    compiled = compile_robot(_block((1, 1, 1)), physics=physics, elevation=5e-3)
    sim = simulation_of(compiled)
    t, x, reason = _run_recording(sim, compiled.body_ids, 0.1, every=1)
    z = x[:, 0, 2]
    L = physics.scene.voxel_size
    low, apex = _first_bounce(z)
    rest = z[-1]
    return CaseResult("drop_voxel", {
        "rest_z": rest, "rebound": apex - rest, "min_zbot": z.min() - L / 2},
        {"z": (t, z)}, stable=not reason)


def drop_block(physics: Physics) -> CaseResult:
    """3×3×3 soft block, bottom at 2 mm, 0.2 s: rest COM height, first rebound apex."""
    compiled = compile_robot(_block((3, 3, 3)), physics=physics, elevation=2e-3)
    sim = simulation_of(compiled)
    t, x, reason = _run_recording(sim, compiled.body_ids, 0.2, every=1)
    z = x[:, :, 2].mean(axis=1)
    low, apex = _first_bounce(z)
    return CaseResult("drop_block", {
        "rest_z": z[-1], "first_apex_z": apex, "zmin": z[low]},
        {"z": (t, z)}, stable=not reason)


def slide_bar(physics: Physics, speed: float) -> CaseResult:
    """3×1×1 soft bar resting; every voxel gets +x `speed` (m/s) at 10 ms: slide, stop."""
    compiled = compile_robot(_block((3, 1, 1)), physics=physics)
    sim = simulation_of(compiled)
    dt = compiled.timestep
    t0, x0, r0 = _run_recording(sim, compiled.body_ids, 0.01, every=1)
    model = compiled.model
    for body in compiled.body_ids:
        sim.data.qvel[model.jnt_dofadr[model.body_jntadr[body]]] = speed
    t1, x1, r1 = _run_recording(sim, compiled.body_ids, 0.09, every=1)
    x = np.concatenate([x0, x1[1:]])[:, :, 0].mean(axis=1)
    t = np.concatenate([t0, t1[1:]])
    start = x[len(t0) - 1]
    v = np.gradient(x, t)
    after = t > t0[-1] + 2 * dt
    moving = np.nonzero(after & (np.abs(v) > 1e-4))[0]
    stop = t[moving[-1]] - t0[-1] if len(moving) else 0.0
    name = f"slide_bar_v{speed:g}"
    return CaseResult(name, {"slide": x[-1] - start, "stop_after": stop},
                      {"x": (t, x - x[0])}, stable=not (r0 or r1))


def bar_red_green(physics: Physics) -> CaseResult:
    """Red + green voxel on the floor, actuated from t = 0, 0.2 s: centre distance."""
    robot = Robot.from_body(np.array([3, 4], dtype=np.int8).reshape(2, 1, 1))
    compiled = compile_robot(robot, physics=physics.replace(settle_time=0.0))
    sim = simulation_of(compiled)
    t, x, reason = _run_recording(sim, compiled.body_ids, 0.2, every=1)
    length = np.linalg.norm(x[:, 1] - x[:, 0], axis=1)
    late = t > 0.025
    return CaseResult("bar_red_green", {"len_min": length[late].min(),
                                        "len_max": length[late].max()},
                      {"length": (t, length)}, stable=not reason)


def cantilever(physics: Physics) -> CaseResult:
    """5 hard voxels along x, the first clamped, floor off, 0.3 s: tip sag."""
    compiled = compile_robot(_block((5, 1, 1), Material.HARD),
                             physics=physics.replace(floor=False), clamped=[(1, 1, 1)])
    sim = simulation_of(compiled)
    t, x, reason = _run_recording(sim, compiled.body_ids, 0.3, every=1)
    sag = x[0, -1, 2] - x[:, -1, 2]
    k = int(np.argmax(sag))
    return CaseResult("cantilever", {"sag_end": sag[-1], "sag_max": sag[k],
                                     "sag_max_t": t[k]}, {"sag": (t, sag)},
                      stable=not reason)


def paper_robot(physics: Physics, name: str) -> CaseResult:
    """A paper robot, 0.05 s settle + 0.5 s walk: distance (vox) and COM heights (m)."""
    robot = Robot.load(PAPER_ROBOTS / f"{name}.npy")
    compiled = compile_robot(robot, physics=physics)
    sim = simulation_of(compiled)
    settle, measured = physics.scene.timing(3)
    dt = compiled.timestep
    every = max(1, int(round(1e-4 / dt)))
    t, x, reason = _run_recording(sim, compiled.body_ids, settle + measured, every=every)
    masses = compiled.masses
    com = np.einsum("tvk,v->tk", x, masses) / masses.sum()
    # the reference's frame: lattice positions, voxel (i, j, k) centred at (i - 1 + ½)·L
    L = physics.scene.voxel_size
    lattice = (compiled.voxel_index - 1 + 0.5) * L
    shift = masses @ lattice / masses.sum() - com[0]
    shift[2] = 0.0
    com = com + shift
    k0 = int(np.argmin(np.abs(t - settle)))
    distance = float(np.linalg.norm(com[-1, :2] - com[k0, :2]) / L)
    walking = t >= settle
    return CaseResult(name, {
        "distance": distance if not reason else math.nan,
        "z_settled": com[k0, 2], "z_mean": com[walking, 2].mean()},
        {"com": (t, com)}, stable=not reason)


CASES: dict[str, Callable[[Physics], CaseResult]] = {
    "drop_voxel": drop_voxel,
    "drop_block": drop_block,
    "slide_bar_v0.2": lambda p: slide_bar(p, 0.2),
    "slide_bar_v0.1": lambda p: slide_bar(p, 0.1),
    "bar_red_green": bar_red_green,
    "cantilever": cantilever,
    "tripod": lambda p: paper_robot(p, "tripod"),
    "biped": lambda p: paper_robot(p, "biped"),
    "multiped": lambda p: paper_robot(p, "multiped"),
}
