"""A `dm_env.Environment` of one robot whose muscle groups an outside controller drives.

It implements the `dm_env.Environment` interface directly on the `mujoco` bindings (the
voxel plugin takes the two strains as the controls of its ``muscle_plus`` and
``muscle_minus`` actuators). Agents and tools written against `dm_env` (acme, dm_env's test
helpers, ...) work with it.

Episode: `reset` compiles nothing; it restores the initial state, lets the robot settle
without actuation for the scene's settle time (as `mjregen.physics.simulation.simulate` does) and
returns the FIRST time step (`UnstableSettleError` if the robot diverges while settling).
Each `step` holds the action for `control_timestep` seconds of physics. The episode ends
(truncation, discount 1) after `duration` seconds of control, or (termination, discount 0,
reward 0) when the stability guard of `mjregen.physics.simulation` trips; `last_failure` then says
why.

Action: ``(2,)`` float, the signed strains of the two muscle groups (muscle + and muscle −)
in units of their strain amplitude: a muscle voxel's linear scale is 1 + amplitude × action.
Bounds follow the scene's waveform: [−1, 0] for "contract" (muscles only contract, as in
the paper), [−1, 1] for "symmetric". A group the robot does not have has no effect.

Observation (dict, SI units, voxels in `voxel_index` order):
  voxel_positions ``(n, 3)`` m, voxel_velocities ``(n, 3)`` m/s (centres of the voxels),
  com ``(3,)`` m, com_velocity ``(3,)`` m/s.

Reward: forward progress, the increase during the step of the planar (x, y; 2D: x) distance
of the centre of mass from where it was at the end of the settle, in voxel lengths. The
return of an episode is the distance that `simulate` scores, for the actions taken.
"""

from __future__ import annotations

import math

import dm_env
import mujoco
import numpy as np
from dm_env import specs

from mjregen.errors import MjregenError
from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.physics.compile import CompiledRobot, compile_robot
from mjregen.physics.simulation import Simulation

MUSCLE_GROUPS = ("muscle_plus", "muscle_minus")


class UnstableSettleError(MjregenError, RuntimeError):
    """The robot's simulation became unstable before the episode started."""


class RobotEnv(dm_env.Environment):
    """Drive a robot's two muscle groups step by step (see the module docstring).

    Args:
      robot: a non-empty `Robot` (2D or 3D) or an already compiled robot.
      physics: materials and scene when `robot` is a `Robot`; None = the paper's.
      duration: s of control per episode; None = the scene's measured time.
      control_timestep: s of physics per `step`; None = a tenth of an actuation period
        (2.5 ms at 40 Hz). Rounded to a whole number (>= 1) of physics steps.
    Raises:
      ValueError: non-positive `duration` or `control_timestep`.
      CompileError: empty robot.
    """

    def __init__(self, robot: Robot | CompiledRobot, *, physics: Physics | None = None,
                 duration: float | None = None, control_timestep: float | None = None) -> None:
        if isinstance(robot, CompiledRobot):
            physics, robot = robot.physics, robot.robot
        physics = Physics() if physics is None else physics
        # the voxel plugin takes the strains from two control inputs
        drive = "ctrl" if physics.pipeline.name == "voxel" else "waveform"
        compiled = compile_robot(robot, physics=physics, drive=drive)
        self.compiled = compiled
        scene = compiled.physics.scene
        settle, measured = scene.timing(compiled.robot.dim)
        duration = measured if duration is None else duration
        control_timestep = (1.0 / (10.0 * scene.frequency) if control_timestep is None
                            else control_timestep)
        for name, value in (("duration", duration), ("control_timestep", control_timestep)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of seconds, got {value!r}")
        dt = compiled.timestep
        self.n_substeps = max(1, round(control_timestep / dt))
        self.control_timestep = self.n_substeps * dt
        self.n_control_steps = max(1, round(duration / self.control_timestep))
        self._n_settle = round(settle / dt)
        self._model = compiled.model  # pure MuJoCo: its muscle rest lengths are rewritten
        self._sim = Simulation(self._model, physics=physics,
                               plugin_instance=compiled.plugin_instance)
        self._planar = [0, 1] if compiled.robot.dim == 3 else [0]
        self._voxel = scene.voxel_size
        self._high = 0.0 if scene.waveform == "contract" else 1.0
        muscles = compiled.muscles
        weights = np.zeros((0, 2)) if muscles is None else muscles.weights
        self._plus, self._minus = self._voxel * weights[:, 0], self._voxel * weights[:, 1]
        self._lateral2 = np.zeros(0) if muscles is None else muscles.lateral ** 2
        self._n_obs = len(compiled.body_ids)
        self._start = np.zeros(3)
        self._distance = 0.0
        self._steps_taken = 0
        self._needs_reset = True
        self.last_failure = ""

    def action_spec(self) -> specs.BoundedArray:
        return specs.BoundedArray(shape=(2,), dtype=np.float64, minimum=-1.0,
                                  maximum=self._high, name="muscle_strain")

    def observation_spec(self) -> dict[str, specs.Array]:
        n = self._n_obs
        return {
            "voxel_positions": specs.Array((n, 3), np.float64, name="voxel_positions"),
            "voxel_velocities": specs.Array((n, 3), np.float64, name="voxel_velocities"),
            "com": specs.Array((3,), np.float64, name="com"),
            "com_velocity": specs.Array((3,), np.float64, name="com_velocity"),
        }

    def reward_spec(self) -> specs.Array:
        return specs.Array(shape=(), dtype=np.float64, name="forward_progress")

    def discount_spec(self) -> specs.BoundedArray:
        return specs.BoundedArray(shape=(), dtype=np.float64, minimum=0.0, maximum=1.0,
                                  name="discount")

    def reset(self) -> dm_env.TimeStep:
        """Initial state, settle without actuation, FIRST time step."""
        self._set_strains(np.zeros(2))  # as `Simulation.run` does while settling
        mujoco.mj_resetData(self._model, self._sim.data)
        self._sim.steps = 0
        self._steps_taken = 0
        self.last_failure = self._sim.run(self._n_settle)
        self._needs_reset = bool(self.last_failure)
        if self.last_failure:
            raise UnstableSettleError(
                f"the robot became unstable while settling: {self.last_failure}")
        observation = self._observation()
        self._start = observation["com"]
        self._distance = 0.0
        return dm_env.restart(observation)

    def step(self, action: np.ndarray) -> dm_env.TimeStep:
        """Hold `action` for `control_timestep` s; a step after the last one resets.

        Raises:
          ValueError: `action` does not have shape (2,), is not finite or is out of bounds.
        """
        if self._needs_reset:
            return self.reset()
        self._set_strains(self._check_action(action))
        self.last_failure = self._sim.run(self.n_substeps)
        self._steps_taken += 1
        observation = self._observation()
        if self.last_failure:
            self._needs_reset = True
            return dm_env.termination(0.0, observation)
        com = observation["com"]
        distance = float(np.linalg.norm(com[self._planar] - self._start[self._planar]))
        reward, self._distance = (distance - self._distance) / self._voxel, distance
        if self._steps_taken >= self.n_control_steps:
            self._needs_reset = True
            return dm_env.truncation(reward, observation)
        return dm_env.transition(reward, observation)

    def _set_strains(self, action: np.ndarray) -> None:
        """Write the driven tendons' rest lengths, with the operations of `Simulation.run`
        (voxel plugin: the two strain controls)."""
        if self.compiled.plugin_instance is not None:
            self._sim.data.ctrl[:] = action
        elif len(self._plus):
            axial = self._voxel + self._plus * action[0] + self._minus * action[1]
            rest = np.sqrt(axial * axial + self._lateral2)
            self._model.tendon_lengthspring[: len(rest)] = rest[:, None]

    def _check_action(self, action: np.ndarray) -> np.ndarray:
        action = np.asarray(action, dtype=np.float64)
        if action.shape != (2,):
            raise ValueError(f"action must have shape (2,) (strains of {', '.join(MUSCLE_GROUPS)}),"
                             f" got {action.shape}")
        if not np.all(np.isfinite(action)):
            raise ValueError(f"action must be finite, got {action}")
        if np.any(action < -1.0) or np.any(action > self._high):
            raise ValueError(f"action {action} is outside [-1, {self._high:g}] (the scene's "
                             f"waveform is {self.compiled.physics.scene.waveform!r})")
        return action

    def _observation(self) -> dict[str, np.ndarray]:
        model, data = self._model, self._sim.data
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_comVel(model, data)
        mujoco.mj_subtreeVel(model, data)
        bodies = self.compiled.body_ids
        return {
            "voxel_positions": data.xipos[bodies].copy(),
            "voxel_velocities": data.subtree_linvel[bodies].copy(),
            "com": data.subtree_com[0].copy(),
            "com_velocity": data.subtree_linvel[0].copy(),
        }
