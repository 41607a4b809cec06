"""Settle, actuate, measure: one locomotion evaluation of a robot, with a stability guard.

`simulate(robot)` compiles the robot (`mjregen.physics.compile`), starts it from one of its
starts (every voxel moved by a seeded offset: `mjregen.physics.start_state`; a keyframe of the
model), lets it settle without actuation for the scene's settle time, then drives the muscles
for the measured time and returns a `Result`. `Simulation.run` advances ``CHECK_EVERY`` steps
between stability checks. In the voxel pipeline (the default) every force and the muscles
are the voxel plugin's, inside MuJoCo's step, so no Python runs per step; the steps are the
native stepper's (`mjregen.physics.stepper`: ``mj_step``'s Euler step for independent voxel
bodies, to rounding, at half the cost) or ``mj_step``'s (the pipeline's ``stepper``; the
pipeline's builder chooses, `mjregen.physics.builders`). In the pure-MuJoCo pipeline the only
per-step Python work is writing the driven tendons' rest lengths.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Sequence

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from mjregen.errors import PhysicsParameterError
from mjregen.grid import Robot
from mjregen.physics.builders import builder_for
from mjregen.physics.compile import CompiledRobot, compile_robot
from mjregen.physics.params import Physics
from mjregen.physics.tendons import MuscleTendons
from mjregen.physics.timestep import rotational_dofs

RUNAWAY_SPEED = 5000.0  # voxel lengths per second (5 m/s at 1 mm; walkers reach ~0.3 m/s)
CHECK_EVERY = 200  # steps between checks for NaN and runaway speed
MAX_RECORD_BYTES = 2**30  # a recorded centre-of-mass trajectory (8 bytes x 3 a step)
WARNINGS = [(name, int(value)) for name, value in mujoco.mjtWarning.__members__.items()
            if name != "mjNWARNING"]


@dataclass(frozen=True)
class Result:
    """Outcome of one evaluation.

    Attributes:
      distance: planar (x, y) displacement of the centre of mass, in voxel lengths, from the
        end of the settle to the end of the run (NaN when unstable; 0 for an empty robot).
      dim: 2 or 3.
      displacement: (dx, dy) of that displacement in voxel lengths (2D: dy = 0; NaN when
        unstable); `heading` is its direction.
      n_voxels: number of voxels.
      stable: False when the state became NaN, MuJoCo warned, or a voxel ran away.
      reason: why the run is unstable ("" when stable).
      steps: number of steps made.
      sim_time: simulated seconds.
      timestep: s.
      wall_time, cpu_time: seconds spent compiling and simulating (wall clock, and CPU of
        the thread that ran them, so that simulations on parallel threads are not counted
        twice).
      times: ``(steps + 1,)`` s, when `record`; else None.
      com: ``(steps + 1, 3)`` m, centre of mass at `times`, when `record`; else None.
    """

    distance: float
    dim: int
    n_voxels: int
    stable: bool
    reason: str
    steps: int
    sim_time: float
    timestep: float
    wall_time: float
    cpu_time: float
    times: np.ndarray | None = None
    com: np.ndarray | None = None
    displacement: tuple[float, float] = (0.0, 0.0)

    @property
    def heading(self) -> float:
        """Direction of `displacement` in degrees, counter-clockwise from the x axis, in
        (-180, 180]; NaN when the robot did not move or the run is unstable."""
        dx, dy = self.displacement
        if not (math.isfinite(dx) and math.isfinite(dy)) or (dx == 0.0 and dy == 0.0):
            return math.nan
        return math.degrees(math.atan2(dy, dx))


class Simulation:
    """Steps a MuJoCo model of a robot with its stability guard (and, in the pure-MuJoCo
    pipeline, its muscle drive).

    With `plugin_instance` (the voxel pipeline) the voxel plugin computes every force and
    drives the muscles; `stepper` is the `mjregen.physics.stepper.NativeStepper` that
    advances `data` when the pipeline's ``stepper`` allows, else None (``mj_step``). `run`
    then updates the positional and velocity quantities (``xpos``, ``subtree_com``,
    ``cvel``) once at its end, for the final state (``mj_step`` leaves those of the state
    before its last step).
    Without it (the pure-MuJoCo pipeline) `run` rewrites ``model.tendon_lengthspring`` of
    the driven tendons before every step, so give each `Simulation` its own model.

    Args:
      model: the MuJoCo model (also one loaded from the exported XML).
      physics: the robot's physics (voxel size, actuation, the pipeline's stepper).
      muscles: the pure-MuJoCo pipeline's driven tendons (None: passive robot, or the voxel
        plugin drives them).
      actuation_start: s, time at which the muscle waveform starts (phase 0), for `muscles`.
      plugin_instance: the voxel plugin's instance id in `model`, or None.
      start_key: the keyframe the state starts from (`CompiledRobot.start_key`), or None
        (``qpos0``).
    """

    def __init__(self, model: mujoco.MjModel, *, physics: Physics,
                 muscles: MuscleTendons | None = None, actuation_start: float = 0.0,
                 plugin_instance: int | None = None, start_key: int | None = None) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        if start_key is not None:
            mujoco.mj_resetDataKeyframe(model, self.data, start_key)
        self.steps = 0
        scene = physics.scene
        self._scene = scene
        self._start = actuation_start
        self._muscles = muscles
        if muscles is not None:
            if plugin_instance is not None:
                raise ValueError("the voxel plugin drives its own muscles: pass muscles=None")
            length = muscles.voxel_size
            self._base = np.full(muscles.count, length)
            self._plus = length * muscles.weights[:, 0]
            self._minus = length * muscles.weights[:, 1]
            self._lateral2 = muscles.lateral ** 2
            self._rest = self.model.tendon_lengthspring[: muscles.count]
        self.stepper = builder_for(physics.pipeline).stepper(model, self.data, physics,
                                                             plugin_instance)
        self._inv_limit = inverse_speed_limits(model, scene.voxel_size)

    def strains(self, t: float) -> tuple[float, float]:
        """Signed strains (e₊, e₋) of the two muscle phases at time `t` (s)."""
        if t < self._start:
            return 0.0, 0.0
        wave = math.sin(2.0 * math.pi * self._scene.frequency * (t - self._start))
        if self._scene.waveform == "contract":
            return min(0.0, wave), min(0.0, -wave)
        return wave, -wave

    def run(self, n_steps: int, *, com: np.ndarray | None = None) -> str:
        """Advance `n_steps` steps; return "" or the reason the state became unstable.

        Args:
          n_steps: number of steps.
          com: optional ``(n_steps, 3)`` array, filled with the centre of mass (m) at the
            start of each step.
        """
        done = 0
        while done < n_steps:
            part = None if com is None else com[done: done + CHECK_EVERY]
            done += self._advance(self.steps + done, min(CHECK_EVERY, n_steps - done), part)
            reason = self.check()
            if reason:
                self.steps += done
                return reason
        self.steps += n_steps
        if self.stepper is not None:
            self._kinematics()
        return ""

    def _advance(self, first: int, n_steps: int, com: np.ndarray | None) -> int:
        """Advance up to `n_steps` steps from step `first` (counted from the start of the
        simulation; fewer after a bad value in the native stepper) and return how many: in C
        where nothing is left to do in Python between steps (the native stepper, or
        ``mj_step`` without muscles to drive or a path to record), else one ``mj_step`` at a
        time; `com` as in `run`."""
        model, data = self.model, self.data
        if self.stepper is not None:
            part = None if com is None else np.empty((n_steps, 3))
            n_steps = self.stepper.step(n_steps, part)
            if com is not None:
                com[:n_steps] = part[:n_steps]
            return n_steps
        if com is None and self._muscles is None:
            mujoco.mj_step(model, data, nstep=n_steps)
            return n_steps
        dt = model.opt.timestep
        for k in range(n_steps):
            if self._muscles is not None:
                self._drive_muscles((first + k) * dt)
            mujoco.mj_step(model, data)
            if com is not None:
                com[k] = data.subtree_com[0]
        return n_steps

    def _drive_muscles(self, t: float) -> None:
        """Set the muscle tendons' rest lengths for time `t` (s): the pure-MuJoCo
        pipeline's muscle drive."""
        plus, minus = self.strains(t)
        axial = self._base + self._plus * plus + self._minus * minus
        rest = np.sqrt(axial * axial + self._lateral2)
        self._rest[:] = rest[:, None]

    def _kinematics(self) -> None:
        """Positions, frames, centres of mass and their velocities (``xpos``, ``subtree_com``,
        ``cvel``, ...) of the current state, which the native stepper does not compute; no
        forces."""
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)
        mujoco.mj_comVel(self.model, self.data)

    def check(self) -> str:
        """"" if the state is finite, warning-free and slower than RUNAWAY_SPEED."""
        return instability(self.data, self._inv_limit)

    def com(self) -> np.ndarray:
        """Centre of mass ``(3,)`` in m of the current state."""
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)
        return self.data.subtree_com[0].copy()


def inverse_speed_limits(model: mujoco.MjModel, voxel_size: float) -> np.ndarray:
    """``(nv,)`` s/m (s/rad on rotations): 1 / RUNAWAY_SPEED of each dof (a rotation's
    limit is RUNAWAY_SPEED voxel lengths per voxel length)."""
    return np.where(rotational_dofs(model), voxel_size, 1.0) / (RUNAWAY_SPEED * voxel_size)


def instability(data: mujoco.MjData, inverse_limits: np.ndarray) -> str:
    """Why `data`'s state is unstable ("" if it is finite, warning-free and every dof slower
    than its limit, `inverse_speed_limits`)."""
    if np.any(data.warning.number):
        for name, warning in WARNINGS:
            if data.warning[warning].number > 0:
                return f"MuJoCo warning {name}"
    if not (np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))):
        return "NaN or infinite state"
    if data.qvel.size and np.max(np.abs(data.qvel) * inverse_limits) > 1.0:
        return f"runaway speed (above {RUNAWAY_SPEED:g} voxel lengths per second)"
    return ""


def simulation_of(compiled: CompiledRobot, start: int = 0) -> Simulation:
    """A `Simulation` of a compiled robot from its start `start` (muscles from the end of the
    scene's settle)."""
    settle, _ = compiled.physics.scene.timing(compiled.robot.dim)
    return Simulation(compiled.model, physics=compiled.physics, muscles=compiled.muscles,
                      actuation_start=settle, plugin_instance=compiled.plugin_instance,
                      start_key=compiled.start_key(start))


def simulate(
    robot: Robot | ArrayLike,
    *,
    physics: Physics | None = None,
    duration: float | None = None,
    record: bool = False,
    start_seed: int = 0,
    start: int = 0,
) -> Result:
    """Evaluate a robot's locomotion: settle, actuate, measure.

    Args:
      robot: a `Robot` or a grid that validates as one (2D or 3D); an empty one gives
        distance 0 without simulating.
      physics: materials, scene and pipeline; None = the paper's.
      duration: s of actuation that the distance counts; None = the scene's measured time.
      record: also return the centre-of-mass trajectory (every step).
      start_seed: the evaluation's seed of the start (an evolution's: its run's seed; >= 0).
      start: which start of the robot (>= 0): every voxel moved by a random offset of the
        scene's ``start_shift`` drawn from `start_seed`, `start` and the grid
        (`mjregen.physics.start_state`); with start shift 0 both are ignored and every
        voxel starts exactly at its grid position.
    Returns:
      A `Result`; an unstable run is marked ``stable=False`` (distance NaN) and never
      raises. The locomotion task's fitness: `mjregen.tasks.fitness.locomotion_fitness`.
    Raises:
      InvalidGridError: `robot` is not a valid grid.
      PhysicsParameterError: `duration` negative or not finite, or a `record`ed trajectory
        larger than MAX_RECORD_BYTES.
      CompileError: `start_seed` or `start` not a whole number >= 0.
    """
    return simulate_starts(robot, physics=physics, duration=duration, record=record,
                           start_seed=start_seed, starts=(start,))[0]


def simulate_starts(
    robot: Robot | ArrayLike,
    *,
    physics: Physics | None = None,
    duration: float | None = None,
    record: bool = False,
    start_seed: int = 0,
    starts: Sequence[int] = (0,),
) -> list[Result]:
    """`simulate` the robot from each of `starts` (indices of its starts), compiling it once:
    element ``i`` equals ``simulate(robot, ..., start=starts[i])`` exactly. Each `Result`'s
    wall and CPU time include an equal share of the compile. Arguments and errors as for
    `simulate`."""
    wall0, cpu0 = time.perf_counter(), time.thread_time()
    robot = robot if isinstance(robot, Robot) else Robot(robot)
    physics = Physics() if physics is None else physics
    if duration is not None and not (math.isfinite(duration) and duration >= 0):
        raise PhysicsParameterError(f"duration must be a finite time >= 0 s, got {duration!r}")
    if robot.is_empty:
        empty = Result(distance=0.0, dim=robot.dim, n_voxels=0, stable=True, reason="",
                       steps=0, sim_time=0.0, timestep=0.0,
                       wall_time=time.perf_counter() - wall0, cpu_time=time.thread_time() - cpu0)
        return [empty for _ in starts]
    compiled = compile_robot(robot, physics=physics, starts=starts, start_seed=start_seed)
    share = ((time.perf_counter() - wall0) / len(starts),
             (time.thread_time() - cpu0) / len(starts))
    return [walk(compiled, start, duration=duration, record=record, compile_time=share)
            for start in starts]


def walk(compiled: CompiledRobot, start: int = 0, *, duration: float | None = None,
         record: bool = False, sim: Simulation | None = None,
         compile_time: tuple[float, float] = (0.0, 0.0)) -> Result:
    """Settle and walk `compiled` from its start `start`, or from the state of `sim` (a
    `simulation_of(compiled)` whose state the caller changed, e.g. perturbed finer than a
    keyframe holds); `compile_time`: (wall, CPU) s to add to the result's. As `simulate`."""
    wall0, cpu0 = time.perf_counter(), time.thread_time()
    robot, physics = compiled.robot, compiled.physics
    dim = robot.dim
    settle, measured = physics.scene.timing(dim)
    measured = measured if duration is None else duration
    dt = compiled.timestep
    n_settle, n_measure = round(settle / dt), round(measured / dt)
    sim = simulation_of(compiled, start) if sim is None else sim
    size = (n_settle + n_measure + 1) * 3 * 8
    if record and size > MAX_RECORD_BYTES:
        raise PhysicsParameterError(
            f"recording the centre of mass at each of {n_settle + n_measure:,} steps would take "
            f"{size / 2**30:.1f} GiB (at most {MAX_RECORD_BYTES / 2**30:g}); walk a shorter "
            "duration, or without the trajectory")
    com = np.empty((n_settle + n_measure + 1, 3)) if record else None
    reason = sim.run(n_settle, com=None if com is None else com[:n_settle])
    begin = sim.com()
    if not reason:
        reason = sim.run(n_measure, com=None if com is None else com[n_settle:-1])
    end = sim.com()
    if com is not None:
        com[sim.steps] = end
        com = com[: sim.steps + 1]
    planar = [0, 1] if dim == 3 else [0]
    length = physics.scene.voxel_size
    distance = float(np.linalg.norm(end[planar] - begin[planar])) / length
    dx, dy = (end[0] - begin[0]) / length, (end[1] - begin[1]) / length if dim == 3 else 0.0
    stable = not reason
    return Result(
        distance=distance if stable else math.nan, dim=dim, n_voxels=robot.n_voxels,
        displacement=(float(dx), float(dy)) if stable else (math.nan, math.nan),
        stable=stable, reason=reason, steps=sim.steps, sim_time=sim.steps * dt, timestep=dt,
        wall_time=time.perf_counter() - wall0 + compile_time[0],
        cpu_time=time.thread_time() - cpu0 + compile_time[1],
        times=None if com is None else np.arange(sim.steps + 1) * dt, com=com)
