"""The paper engine's reference cases, re-run in mjregen.

The reference trajectories (recorded from the paper's Voxelyze build) cover small
mechanical cases and the paper's three robots. This module sets up each
case in mjregen with a given `Physics`, runs it and returns the same measures the
reference's `summary.json` holds, plus traces for plots. The reference numbers that the
cases are judged by are copied here (`REFERENCE`), and the engine's centre-of-mass path of
each paper robot ships with the package (`ENGINE_PATHS`), so tests need no other data.

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
# the engine's COM path of each paper robot, every 1 ms (benchmarks/fidelity.py --write-paths)
ENGINE_PATHS = "engine_robot_paths.npz"

# From the reference's summary.json (paper engine, its default settings).
REFERENCE = {
    "drop_voxel": {"rest_z": 0.4986266e-3, "rebound": 4.611e-5, "min_zbot": -5.825e-5},
    "drop_block": {"rest_z": 1.4913018e-3, "first_apex_z": 1.72913e-3, "zmin": 1.375927e-3},
    "slide_bar_v0.2": {"slide": 1.36786e-3, "stop_after": 13.9e-3},
    "slide_bar_v0.1": {"slide": 0.35094e-3, "stop_after": 7.1e-3},
    "bar_red_green": {"len_min": 0.92949e-3, "len_max": 1.0e-3},
    "cantilever": {"sag_end": 0.2844656e-3, "sag_max": 0.5185711e-3, "sag_max_t": 8.913e-3},
    "biped": {"distance": 40.4904, "heading": -111.30, "airborne": 0.4461},
    "tripod": {"distance": 43.5776, "heading": -35.44, "airborne": 0.3543},
    "multiped": {"distance": 42.8010, "heading": 10.00, "airborne": 0.0682},
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


def drop_voxel(physics: Physics) -> CaseResult:
    """One soft voxel, bottom face at 5 mm, 0.1 s: rest height, rebound, penetration."""
    compiled = compile_robot(Robot.box((1, 1, 1)), physics=physics, elevation=5e-3)
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
    compiled = compile_robot(Robot.box((3, 3, 3)), physics=physics, elevation=2e-3)
    sim = simulation_of(compiled)
    t, x, reason = _run_recording(sim, compiled.body_ids, 0.2, every=1)
    z = x[:, :, 2].mean(axis=1)
    low, apex = _first_bounce(z)
    return CaseResult("drop_block", {
        "rest_z": z[-1], "first_apex_z": apex, "zmin": z[low]},
        {"z": (t, z)}, stable=not reason)


def slide_bar(physics: Physics, speed: float) -> CaseResult:
    """3×1×1 soft bar resting; every voxel gets +x `speed` (m/s) at 10 ms: slide, stop."""
    compiled = compile_robot(Robot.box((3, 1, 1)), physics=physics)
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
    compiled = compile_robot(Robot.box((5, 1, 1), Material.HARD),
                             physics=physics.replace(floor=False), clamped=[(1, 1, 1)])
    sim = simulation_of(compiled)
    t, x, reason = _run_recording(sim, compiled.body_ids, 0.3, every=1)
    sag = x[0, -1, 2] - x[:, -1, 2]
    k = int(np.argmax(sag))
    return CaseResult("cantilever", {"sag_end": sag[-1], "sag_max": sag[k],
                                     "sag_max_t": t[k]}, {"sag": (t, sag)},
                      stable=not reason)


def engine_path(name: str) -> tuple[np.ndarray, np.ndarray]:
    """The paper engine's COM path of paper robot `name`: t ``(n,)`` s every 1 ms from 0,
    COM ``(n, 3)`` m in its lattice frame (voxel (i, j, k) starts at ((i, j, k) + ½)·L)."""
    with np.load(asset("reference", ENGINE_PATHS)) as data:
        return data[f"{name}_t"], data[f"{name}_com"]


def heading_of(start: np.ndarray, end: np.ndarray) -> float:
    """Degrees counter-clockwise from +x of the planar move from `start` to `end`."""
    move = np.asarray(end)[:2] - np.asarray(start)[:2]
    return math.degrees(math.atan2(move[1], move[0]))


def path_difference(t: np.ndarray, com: np.ndarray, name: str, settle: float) -> float:
    """m: RMS distance between a planar COM path (t ``(n,)`` s, com ``(n, 3)`` m) and the
    engine's for robot `name`, both from their COM at the end of the settle, every 1 ms
    of the walk."""
    t_ref, com_ref = engine_path(name)
    grid = t_ref[t_ref >= settle - 1e-9]
    grid = grid[grid <= t[-1] + 1e-9]
    ours = np.stack([np.interp(grid, t, com[:, k]) for k in range(2)], axis=1)
    theirs = np.stack([np.interp(grid, t_ref, com_ref[:, k]) for k in range(2)], axis=1)
    gap = (ours - ours[0]) - (theirs - theirs[0])
    return float(np.sqrt(np.mean(np.sum(gap**2, axis=1))))


def airborne_fraction(sim: Simulation, t: np.ndarray, x: np.ndarray, settle: float,
                      physics: Physics, materials: list[int]) -> float:
    """Fraction of the samples after `settle` (t ``(n,)`` s, voxel centres x ``(n, v, 3)``
    m) in which no voxel touches the floor: every centre above its current half size
    (L/2, scaled by its muscle strain), the engine's contact test."""
    L = physics.scene.voxel_size
    plus = np.array([physics.materials[m].strain_amplitude
                     if physics.materials[m].is_muscle and physics.materials[m].phase_sign > 0
                     else 0.0 for m in materials])
    minus = np.array([physics.materials[m].strain_amplitude
                      if physics.materials[m].is_muscle and physics.materials[m].phase_sign < 0
                      else 0.0 for m in materials])
    walking = np.flatnonzero(t >= settle - 1e-12)
    flying = 0
    for k in walking:
        e_plus, e_minus = sim.strains(float(t[k]))
        half = 0.5 * L * (1.0 + plus * e_plus + minus * e_minus)
        flying += bool(np.all(x[k, :, 2] > half))
    return flying / len(walking)


def paper_robot(physics: Physics, name: str) -> CaseResult:
    """A paper robot, 0.05 s settle + 0.5 s walk: distance (vox), heading (deg), the planar
    COM path's RMS difference from the engine's (m), the fraction of the walk airborne, COM
    heights (m)."""
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
    if reason:
        return CaseResult(name, {"distance": math.nan, "heading": math.nan,
                                 "com_rms": math.nan, "airborne": math.nan,
                                 "z_settled": math.nan, "z_mean": math.nan},
                          {"com": (t, com)}, stable=False)
    materials = [m for _, m in robot.voxels()]
    return CaseResult(name, {
        "distance": distance, "heading": heading_of(com[k0], com[-1]),
        "com_rms": path_difference(t, com, name, settle),
        "airborne": airborne_fraction(sim, t, x, settle, physics, materials),
        "z_settled": com[k0, 2], "z_mean": com[walking, 2].mean()},
        {"com": (t, com)})


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
