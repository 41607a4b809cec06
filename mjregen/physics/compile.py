"""Robot grid + physics -> one MuJoCo model: what `simulate` runs and `to_xml` exports.

The data flows one way: parameters (`params`, `presets`) -> arrays (`model`: voxels, bonds,
no MuJoCo) -> `MjSpec` (`mjcf`: bodies and the voxel plugin, or MuJoCo's tendons and
contacts) -> time step (`timestep`, decided here once and stored in the model's
``opt.timestep`` only) -> `CompiledRobot`, which `mjregen.physics.simulation` steps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import mujoco
import numpy as np

from mjregen.errors import CompileError
from mjregen.grid import Robot
from mjregen.physics import mjcf, start_state, timestep
from mjregen.physics.builders import builder_for
from mjregen.physics.model import (
    RobotBonds,
    RobotLayout,
    engine_floor_constants,
    robot_bonds,
    robot_layout,
)
from mjregen.physics.params import Physics, Scene
from mjregen.physics.rounding import round_like_mjcf
from mjregen.physics.tendons import MuscleTendons

BLOCK_STEP_FLOOR = 0.5  # a network step below this × its stiffest bond block's is a failure
# voxels of the largest robot compiled: one MuJoCo body each, compile time grows with the
# square (3,375 voxels: 9 s; 8,000: MuJoCo cannot allocate the model); the paper's grids
# hold at most 343
MAX_VOXELS = 4096


@dataclass(frozen=True)
class CompiledRobot:
    """A robot compiled to MuJoCo.

    Attributes:
      robot, physics: what was compiled.
      spec: the `mujoco.MjSpec` the model was compiled from (`to_xml` writes it).
      model: the `mujoco.MjModel` that `simulate` runs.
      voxel_index: ``(n_voxels, dim)`` int grid indices, in body order.
      body_ids: ``(n_voxels,)`` int MuJoCo body ids of the voxels.
      masses: ``(n_voxels,)`` float, kg.
      muscles: the "mujoco" pipeline's driven tendons (`Simulation` rewrites their rest
        lengths), or None (no muscles, or the voxel plugin drives them).
      bonds: the face bonds as tendons and as beams (`RobotBonds`).
      network_rates: (λ s⁻², μ s⁻¹) behind the network rule's time step (the largest
        eigenvalues of M⁻¹K and M⁻¹C, muscle stiffening included: the step is
        `timestep_safety` × `timestep.stable_step(λ, μ)` before rounding), or None (the
        stiffest-bond rule, or no bonds).
      starts: the indices of the starts the model holds as keyframes ``start_<index>``
        (`mjregen.physics.start_state`); empty when the scene's start shift is 0 (every walk
        starts at ``qpos0``, every voxel exactly at its grid position).
      start_seed: the seed those starts were drawn with.
      plugin_instance: the voxel plugin's instance id in `model`, or None (the pure-MuJoCo
        pipeline).
    """

    robot: Robot
    physics: Physics
    spec: mujoco.MjSpec
    model: mujoco.MjModel
    voxel_index: np.ndarray
    body_ids: np.ndarray
    masses: np.ndarray
    muscles: MuscleTendons | None
    bonds: RobotBonds
    network_rates: tuple[float, float] | None = None
    starts: tuple[int, ...] = ()
    start_seed: int = 0
    plugin_instance: int | None = 0

    def start_key(self, index: int) -> int | None:
        """The keyframe id of start `index`, or None when walks start at ``qpos0`` (start
        shift 0).

        Raises:
          CompileError: the model holds starts, but not this one.
        """
        if not self.starts:
            return None
        if index not in self.starts:
            raise CompileError(f"start {index} was not compiled into this model (it holds "
                               f"starts {', '.join(map(str, self.starts))})")
        return self.model.key(start_state.key_name(index)).id

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    @property
    def pipeline(self) -> str:
        """The pipeline's name: "voxel" or "mujoco" (`Physics.pipeline`)."""
        return self.physics.pipeline.name

    def to_xml(self) -> str:
        """MJCF of exactly `model`. With the "voxel" pipeline, loading it needs the plugin
        library: ``mujoco.mj_loadPluginLibrary(str(mjregen.plugin_library()))``."""
        return self.spec.to_xml()


def compile_robot(
    robot: Robot,
    *,
    physics: Physics | None = None,
    clamped: Iterable[Sequence[int]] = (),
    elevation: float = 0.0,
    drive: str = "waveform",
    starts: Sequence[int] = (0,),
    start_seed: int = 0,
) -> CompiledRobot:
    """Build the MuJoCo model of `robot`.

    Args:
      robot: a non-empty `Robot` (2D or 3D).
      physics: materials, scene and pipeline; None = the paper's (`Physics()`).
      clamped: grid indices of voxels fixed to the world (no joint), e.g. a cantilever's root.
      elevation: m, height of the lowest voxel's bottom face above the floor (>= 0).
      drive: "waveform" (the muscles follow the scene's waveform from the end of the
        settle) or "ctrl" (voxel pipeline: the strains (e₊, e₋) of the two muscle phases
        are the controls of the actuators ``muscle_plus`` and ``muscle_minus``, which apply
        no force themselves).
      starts: the starts (indices >= 0) the model holds as keyframes when the scene's
        ``start_shift`` is > 0 (`mjregen.physics.start_state`).
      start_seed: the evaluation's seed of those starts (>= 0).
    Raises:
      CompileError: empty robot, more than MAX_VOXELS voxels, a clamped index that is not a
        voxel, negative elevation, a start index or seed that is not a whole number >= 0, no
        starts or more than one with start shift 0, drive "ctrl" without the voxel pipeline,
        or a failed time step estimate.
      PhysicsParameterError: the robot's materials have different Poisson ratios; the
        network time step without the plugin library.
      NativeBuildError: the voxel pipeline, and the plugin library cannot be built.
    """
    physics = Physics() if physics is None else physics
    _check_request(robot, elevation, drive)
    starts, start_seed = _checked_starts(starts, start_seed)
    builder = builder_for(physics.pipeline)
    layout = robot_layout(robot, physics, {tuple(int(i) for i in c) for c in clamped},
                          elevation)
    bonds = robot_bonds(layout, physics)
    spec, bodies = mjcf.voxel_bodies(layout, physics)
    builder.add_forces(spec, bodies, layout, physics, bonds, drive)
    starts = _add_starts(spec, layout, physics.scene, robot.grid, starts, start_seed)
    block_step = timestep.stiffest_bond_step(physics, bonds.stiffest_rate)
    spec.option.timestep = round_like_mjcf(block_step)
    model = spec.compile()
    rates = None
    if physics.pipeline.timestep_rule == "network" and layout.bonds:
        rates = network_rule_rates(model, layout, physics, bonds)
        spec.option.timestep = round_like_mjcf(_network_step(rates, physics, block_step))
        model.opt.timestep = spec.option.timestep
    body_ids = np.array([model.body(body.name).id for body in bodies])
    return CompiledRobot(
        robot=robot, physics=physics, spec=spec, model=model,
        voxel_index=layout.grid_index, body_ids=body_ids, masses=layout.masses,
        muscles=bonds.muscles if builder.drives_muscle_tendons else None, bonds=bonds,
        network_rates=rates, starts=starts, start_seed=start_seed,
        plugin_instance=builder.plugin_instance)


def _check_request(robot: Robot, elevation: float, drive: str) -> None:
    """CompileError unless `robot` is a non-empty `Robot` of at most MAX_VOXELS voxels,
    `elevation` a finite height >= 0 and `drive` one of `mjcf.DRIVES`."""
    if not isinstance(robot, Robot):
        raise CompileError(f"compile_robot needs a Robot, got {type(robot).__name__}")
    if robot.is_empty:
        raise CompileError("cannot compile an empty robot (it has no voxels)")
    if robot.n_voxels > MAX_VOXELS:
        raise CompileError(f"a robot of {robot.n_voxels:,} voxels is larger than mjregen "
                           f"compiles ({MAX_VOXELS:,}: one MuJoCo body per voxel, and compile "
                           "time grows with the square of their number)")
    if not (math.isfinite(elevation) and elevation >= 0.0):
        raise CompileError(f"elevation must be a finite height >= 0 m, got {elevation!r}")
    if drive not in mjcf.DRIVES:
        raise CompileError(f"drive must be one of {mjcf.DRIVES}, got {drive!r}")


def _network_step(rates: tuple[float, float], physics: Physics, block_step: float) -> float:
    """s: the network rule's step from the network's `rates` (λ s⁻², μ s⁻¹), before rounding;
    CompileError when it is not credible against `block_step` (s, a block of the robot's
    stiffest bond)."""
    step = physics.scene.timestep_safety * timestep.stable_step(*rates)
    # a network is never stiffer than a block of its stiffest bond (measured: its step
    # is 1.46-3.7 times the block's); far below that, the estimate itself failed
    if not (math.isfinite(step) and step >= BLOCK_STEP_FLOOR * block_step):
        raise CompileError(
            f"the time step estimate of this robot failed: its bond network gave {step:.3g} "
            f"s (rates {rates[0]:.3g} s^-2, {rates[1]:.3g} s^-1), a block of its stiffest "
            f"bond {block_step:.3g} s; simulate it with timestep_rule='stiffest_bond'")
    return step


def _add_starts(spec: mujoco.MjSpec, layout: RobotLayout, scene: Scene, grid: np.ndarray,
                starts: tuple[int, ...], seed: int) -> tuple[int, ...]:
    """Add each start as the keyframe ``start_<index>`` (`start_state`); returns the starts
    the model holds: none with start shift 0 (every walk starts at ``qpos0``)."""
    if scene.start_shift == 0.0:
        if len(starts) > 1:
            raise CompileError(f"with start_shift 0 every start is the exact start: compile one "
                               f"start, not {len(starts)}")
        return ()
    for index in starts:
        spec.add_key(name=start_state.key_name(index), qpos=start_state.start_qpos(
            layout, scene, grid, seed=seed, index=index).tolist())
    return starts


def _checked_starts(starts: Sequence[int], seed: int) -> tuple[tuple[int, ...], int]:
    """(`starts` as a tuple of distinct ints, `seed` as an int), or CompileError."""
    try:
        indices = tuple(start_state.check_start("a start index", k) for k in starts)
        seed = start_state.check_start("start_seed", seed)
    except (TypeError, ValueError) as error:
        raise CompileError(str(error)) from None
    if not indices or len(set(indices)) != len(indices):
        raise CompileError(f"starts must be distinct indices, at least one, got {starts!r}")
    if len(indices) > start_state.MAX_STARTS:
        raise CompileError(f"{len(indices):,} starts are more than one model holds "
                           f"({start_state.MAX_STARTS:,} keyframes)")
    return indices, seed


def network_rule_rates(model: mujoco.MjModel, layout: RobotLayout, physics: Physics,
                       bonds: RobotBonds, *,
                       held: np.ndarray | None = None) -> tuple[float, float]:
    """(λ s⁻², μ s⁻¹) of the network rule (`mjregen.physics.timestep`), muscle stiffening
    included; `held`: ``(nv,)`` bool, dofs held still (`timestep.network_rates`). The
    pure-MuJoCo pipeline's network is measured on the same robot's plugin model with its
    tendons, floor off (its contacts are not the engine floor)."""
    model, physics = builder_for(physics.pipeline).rates_model(model, layout, physics, bonds)
    scene = physics.scene
    floor_k = floor_c = None
    if scene.floor:
        voxel_bodies = np.array([model.body(name).id for name in layout.names])
        stiffness, damping = engine_floor_constants(layout, physics)
        floor_k, floor_c = timestep.engine_floor_rates(
            model, voxel_bodies, dim=layout.dim, stiffness=stiffness, damping=damping,
            masses=layout.masses)
    stiffness, damping = timestep.network_rates(model, voxel_size=scene.voxel_size,
                                                floor_stiffness=floor_k, floor_damping=floor_c,
                                                held=held)
    stiffening = timestep.strain_stiffening(bonds.beams, scene)
    return stiffening * stiffness, stiffening * damping
