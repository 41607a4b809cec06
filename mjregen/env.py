"""The robot as a dm_control task: `load(robot)` -> `dm_control.rl.control.Environment`.

In the style of dm_control's suite (`swimmer.py`, `cheetah.py`): `VoxelPhysics` (a
`dm_control.mujoco.Physics` of the robot's exported model) answers named physical questions,
`Locomotion` (a `dm_control.suite.base.Task`) holds the episode's rules, and `load` builds the
environment. Names are the model's: bodies ``voxel_<x>_<y>_<z>`` (2D ``voxel_<x>_<z>``), so
``physics.named.data.xpos["voxel_1_1_1"]`` reads a voxel; the actuators ``muscle_plus`` and
``muscle_minus`` are the two muscle groups.

Episode: `reset` restores a start state (the model's keyframe ``start_<k>``: every voxel
moved by its seeded offset, as `simulate`'s start k; k drawn from ``starts`` of them, start 0
alone by default) and lets the robot settle without actuation for the scene's settle time (as `mjregen.physics.simulate` does); each step holds the action for
`control_timestep` seconds of physics; the episode ends after `duration` s of control
(truncation, discount 1) or when the stability guard of `simulate` trips (termination,
discount 0).

Action: ``(2,)`` float, the signed strains of the two muscle groups (muscle + and muscle −)
in units of their strain amplitude: a muscle voxel's linear scale is 1 + amplitude × action;
bounds [−1, 0] for the "contract" waveform (muscles only contract), [−1, 1] for
"symmetric". With ``open_loop=True`` the muscles follow the scene's waveform, as in
`simulate`, and the action is empty.

Observation (SI units, voxels in body order): voxel_positions ``(n, 3)`` m,
voxel_velocities ``(n, 3)`` m/s, com ``(3,)`` m, com_velocity ``(3,)`` m/s.
Reward: forward progress, the increase during the step of the planar (x, y; 2D: x) distance
of the centre of mass from where it was at the end of the settle, in voxel lengths; the
return of an open-loop episode is the distance `simulate` measures.
"""

from __future__ import annotations

import collections
import math
import os

from mjregen.gl import HEADLESS_BACKENDS, requested_backend

if not requested_backend() and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = HEADLESS_BACKENDS[0]  # headless: dm_control would try GLFW

import mujoco  # noqa: E402 - after the OpenGL backend is chosen
import numpy as np  # noqa: E402
from dm_control import mujoco as dm_mujoco  # noqa: E402
from dm_control.rl import control  # noqa: E402
from dm_control.suite import base  # noqa: E402
from dm_env import specs  # noqa: E402

from mjregen.errors import CompileError, MjregenError  # noqa: E402
from mjregen.grid import Robot  # noqa: E402
from mjregen.physics import voxel_plugin  # noqa: E402
from mjregen.physics.builders import builder_for  # noqa: E402
from mjregen.physics.compile import compile_robot  # noqa: E402
from mjregen.physics.params import Physics  # noqa: E402
from mjregen.physics.simulation import instability, inverse_speed_limits  # noqa: E402

MUSCLE_GROUPS = ("muscle_plus", "muscle_minus")


class VoxelPhysics(dm_mujoco.Physics):
    """A robot's model with named physical questions (voxel bodies named as in the model)."""

    def voxel_bodies(self) -> np.ndarray:
        """``(n,)`` body ids of the voxels (bodies named ``voxel_...``), in body order."""
        model = self.model.ptr
        if getattr(self, "_voxel_model", None) is not model:  # found once per model
            self._voxel_model = model
            self._voxel_ids = np.array([b for b in range(1, model.nbody)
                                        if model.body(b).name.startswith("voxel_")], dtype=int)
        return self._voxel_ids

    def center_of_mass(self) -> np.ndarray:
        """``(3,)`` m: the robot's centre of mass."""
        return self.data.subtree_com[0].copy()

    def center_of_mass_velocity(self) -> np.ndarray:
        """``(3,)`` m/s: the velocity of the centre of mass."""
        mujoco.mj_subtreeVel(self.model.ptr, self.data.ptr)
        return self.data.subtree_linvel[0].copy()

    def voxel_positions(self) -> np.ndarray:
        """``(n, 3)`` m: the voxels' centres."""
        return self.data.xipos[self.voxel_bodies()].copy()

    def voxel_velocities(self) -> np.ndarray:
        """``(n, 3)`` m/s: the voxels' centre velocities."""
        mujoco.mj_subtreeVel(self.model.ptr, self.data.ptr)
        return self.data.subtree_linvel[self.voxel_bodies()].copy()

    def muscle_strains(self) -> np.ndarray:
        """``(2,)``: the strains commanded to the muscle groups (their controls; zeros when
        the model's waveform drives them)."""
        if self.model.nu < 2:
            return np.zeros(2)
        return np.array([self.named.data.ctrl[name] for name in MUSCLE_GROUPS])

    def floor_contacts(self) -> int:
        """Voxels whose centre is lower than half a voxel above the floor (touching it)."""
        bodies = self.voxel_bodies()
        size = self.model.geom_size[self.model.body_geomadr[bodies], 0]
        return int(np.count_nonzero(self.data.xipos[bodies, 2] < size))

    def distance_from(self, start: np.ndarray, planar: list[int], voxel_size: float) -> float:
        """Planar distance (voxel lengths) of the centre of mass from `start` ``(3,)`` m."""
        return float(np.linalg.norm(self.center_of_mass()[planar] - start[planar])) / voxel_size


class Locomotion(base.Task):
    """Walk as far as possible: reward is forward progress (module docstring)."""

    def __init__(self, *, dim: int, voxel_size: float, settle_steps: int, open_loop: bool,
                 contract: bool, start_keys: tuple[int | None, ...] = (None,),
                 random: int | None = None) -> None:
        super().__init__(random=random)
        self._start_keys = start_keys
        self._planar = [0, 1] if dim == 3 else [0]
        self._voxel = voxel_size
        self._settle_steps = settle_steps
        self._open_loop = open_loop
        self._high = 0.0 if contract else 1.0
        self._start = np.zeros(3)
        self._distance = 0.0
        self._inverse_limits: np.ndarray | None = None

    def initialize_episode(self, physics: VoxelPhysics) -> None:
        """Start from one of the model's start keyframes (every voxel moved by its seeded
        offset, when the scene has a start shift), drawn with the task's random state, settle
        without actuation; the distance counts from here."""
        key = self._start_keys[self.random.randint(len(self._start_keys))]
        if key is not None:
            mujoco.mj_resetDataKeyframe(physics.model.ptr, physics.data.ptr, key)
        physics.data.ctrl[:] = 0.0
        mujoco.mj_step(physics.model.ptr, physics.data.ptr, nstep=self._settle_steps)
        mujoco.mj_kinematics(physics.model.ptr, physics.data.ptr)
        mujoco.mj_comPos(physics.model.ptr, physics.data.ptr)
        self._start = physics.center_of_mass()
        self._distance = 0.0

    def action_spec(self, physics: VoxelPhysics) -> specs.BoundedArray:
        if self._open_loop:
            return specs.BoundedArray((0,), np.float64, minimum=0.0, maximum=0.0, name="none")
        return specs.BoundedArray((2,), np.float64, minimum=-1.0, maximum=self._high,
                                  name="muscle_strain")

    def before_step(self, action: np.ndarray, physics: VoxelPhysics) -> None:
        if self._open_loop:
            return
        action = np.asarray(action, dtype=np.float64)
        if action.shape != (2,):
            raise ValueError(f"action must have shape (2,) (strains of {', '.join(MUSCLE_GROUPS)}),"
                             f" got {action.shape}")
        if not np.all(np.isfinite(action)):
            raise ValueError(f"action must be finite, got {action}")
        if np.any(action < -1.0) or np.any(action > self._high):
            raise ValueError(f"action {action} is outside [-1, {self._high:g}]")
        physics.data.ctrl[:2] = action

    def get_observation(self, physics: VoxelPhysics) -> collections.OrderedDict:
        return collections.OrderedDict(
            voxel_positions=physics.voxel_positions(),
            voxel_velocities=physics.voxel_velocities(),
            com=physics.center_of_mass(),
            com_velocity=physics.center_of_mass_velocity())

    def get_reward(self, physics: VoxelPhysics) -> float:
        distance = physics.distance_from(self._start, self._planar, self._voxel)
        reward, self._distance = distance - self._distance, distance
        return reward

    def get_termination(self, physics: VoxelPhysics) -> float | None:
        """0 (termination) when the state is unstable as `simulate` judges it (a voxel
        faster than RUNAWAY_SPEED voxel lengths per second, NaN), else None."""
        if self._inverse_limits is None:
            self._inverse_limits = inverse_speed_limits(physics.model.ptr, self._voxel)
        return 0.0 if instability(physics.data.ptr, self._inverse_limits) else None


def load(robot: Robot, *, physics: Physics | None = None, duration: float | None = None,
         control_timestep: float | None = None, open_loop: bool = False,
         start_seed: int = 0, starts: int = 1) -> control.Environment:
    """The robot's locomotion environment (module docstring).

    Args:
      robot: a non-empty `Robot` (2D or 3D).
      physics: materials, scene and pipeline (the voxel pipeline); None = the paper's.
      duration: s of control per episode; None = the scene's measured time.
      control_timestep: s of physics per step; None = a tenth of an actuation period
        (2.5 ms at 40 Hz); rounded to a whole number (>= 1) of physics steps.
      open_loop: the muscles follow the scene's waveform (no action), as in `simulate`.
      start_seed: the seed of the robot's starts (`simulate`'s: every voxel moved by the
        scene's ``start_shift``), and of the draw of each episode's start.
      starts: each episode starts from one of starts 0 .. `starts` - 1, drawn at random
        (seeded by `start_seed`: the same sequence of episodes each time); 1 = every episode
        from start 0, as `simulate` walks.
    Raises:
      ValueError: non-positive `duration` or `control_timestep`, or a control step longer
        than the episode.
      CompileError: empty robot, a `start_seed` that is not a whole number >= 0, `starts`
        not from 1 to MAX_STARTS, or more than one start with start shift 0.
      MjregenError: the pure-MuJoCo pipeline (its muscles need a Python driver).
    """
    physics = Physics() if physics is None else physics
    if builder_for(physics.pipeline).drives_muscle_tendons:
        raise MjregenError("the environment runs the voxel pipeline (the MuJoCo pipeline's "
                           "muscles are driven from Python, not by the model)")
    scene = physics.scene
    if isinstance(starts, bool) or not isinstance(starts, int) or starts < 1:
        raise CompileError(f"starts must be a whole number >= 1, got {starts!r}")
    compiled = compile_robot(robot, physics=physics, drive="waveform" if open_loop else "ctrl",
                             starts=range(starts), start_seed=start_seed)
    settle, measured = scene.timing(robot.dim)
    duration = measured if duration is None else duration
    control_timestep = (1.0 / (10.0 * scene.frequency) if control_timestep is None
                        else control_timestep)
    for name, value in (("duration", duration), ("control_timestep", control_timestep)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number of seconds, got {value!r}")
    if control_timestep > duration:
        raise ValueError(f"control_timestep {control_timestep:g} s exceeds the episode's "
                         f"duration {duration:g} s: an episode is at least one control step")
    dt = compiled.timestep
    n_sub_steps = max(1, round(control_timestep / dt))
    n_steps = max(1, round(duration / (n_sub_steps * dt)))
    voxel_plugin.library()  # the plugin, registered before dm_control compiles the XML
    world = VoxelPhysics.from_xml_string(compiled.to_xml())
    task = Locomotion(dim=robot.dim, voxel_size=scene.voxel_size,
                      settle_steps=round(settle / dt), open_loop=open_loop,
                      contract=scene.waveform == "contract",
                      start_keys=tuple(compiled.start_key(k) for k in range(starts)),
                      random=start_seed)
    step = n_sub_steps * dt
    return control.Environment(world, task, time_limit=(n_steps - 0.5) * step,
                               control_timestep=step)

