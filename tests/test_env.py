"""The dm_env environment: dm_env's own conformance suite, exact agreement with `simulate`,
random rollouts, determinism, bad actions."""

import math

import dm_env
import numpy as np
import pytest
from absl.testing import absltest
from dm_env import test_utils

from mjregen.env import RobotEnv
from mjregen.grid import Material, Robot
from mjregen.physics import Physics
from mjregen.physics.simulation import Simulation, simulate

P, M, S = Material.MUSCLE_PLUS, Material.MUSCLE_MINUS, Material.SOFT


def tiny_walker() -> Robot:
    """Four voxels: two legs of soft, a body of muscle + and muscle −."""
    body = np.zeros((2, 1, 2), dtype=np.int8)
    body[:, 0, 1] = [P, M]
    body[:, 0, 0] = [S, S]
    return Robot.from_body(body)


class ConformanceTest(test_utils.EnvironmentTestMixin, absltest.TestCase):
    """dm_env's test helpers: specs, FIRST/MID/LAST sequence, reset after LAST."""

    def make_object_under_test(self):
        return RobotEnv(tiny_walker(), duration=0.01, control_timestep=0.0025)

    def make_action_sequence(self):  # long enough for two episodes (4 steps each)
        rng = np.random.default_rng(0)
        for _ in range(10):
            yield rng.uniform(-1.0, 0.0, size=2)


def test_specs_describe_the_robot():
    robot = tiny_walker()
    env = RobotEnv(robot, duration=0.01)
    observation = env.reset().observation
    assert env.action_spec().shape == (2,)
    assert env.action_spec().maximum == 0.0  # the paper's contract-only muscles
    for name, spec in env.observation_spec().items():
        spec.validate(observation[name])
    assert observation["voxel_positions"].shape == (robot.n_voxels, 3)
    symmetric = RobotEnv(robot, physics=Physics().replace(waveform="symmetric"))
    assert symmetric.action_spec().maximum == 1.0


def test_episode_with_the_paper_waveform_reproduces_simulate():
    """One physics step per control step and the paper's waveform as the action: the
    return is exactly the distance `simulate` measures."""
    robot, duration = tiny_walker(), 0.02
    env = RobotEnv(robot, duration=duration, control_timestep=1e-9)
    assert env.n_substeps == 1
    settle, _ = env.compiled.physics.scene.timing(3)
    clock = Simulation(env.compiled.model, physics=env.compiled.physics,
                       muscles=None, actuation_start=settle)
    step = env.reset()
    start_steps = round(settle / env.compiled.timestep)
    total, k = 0.0, 0
    while not step.last():
        step = env.step(np.array(clock.strains((start_steps + k) * env.compiled.timestep)))
        total += step.reward
        k += 1
    expected = simulate(robot, duration=duration)
    assert k == round(duration / env.compiled.timestep)
    assert expected.distance > 0.01  # the robot moves, so the check means something
    assert math.isclose(total, expected.distance, rel_tol=1e-9, abs_tol=1e-12)
    assert step.step_type == dm_env.StepType.LAST and step.discount == 1.0


def test_random_rollout_is_finite_and_deterministic():
    def rollout(seed: int) -> tuple[np.ndarray, float]:
        env = RobotEnv(tiny_walker(), duration=0.02)
        rng = np.random.default_rng(seed)
        step, total, n = env.reset(), 0.0, 0
        while not step.last():
            step = env.step(rng.uniform(-1.0, 0.0, size=2))
            total += step.reward
            n += 1
            assert all(np.all(np.isfinite(v)) for v in step.observation.values())
        assert n == env.n_control_steps == 8
        return step.observation["voxel_positions"], total

    first, again, other = rollout(1), rollout(1), rollout(2)
    np.testing.assert_array_equal(first[0], again[0])
    assert first[1] == again[1]
    assert not np.array_equal(first[0], other[0])  # the actions matter


def test_muscles_move_the_voxels_and_no_action_does_not():
    env = RobotEnv(tiny_walker(), duration=0.01)
    rest = env.reset().observation["voxel_positions"]
    for _ in range(4):
        idle = env.step(np.zeros(2))
    env.reset()
    for _ in range(4):
        squeezed = env.step(np.array([-1.0, 0.0]))
    still = np.abs(idle.observation["voxel_positions"] - rest).max()
    moved = np.abs(squeezed.observation["voxel_positions"] - rest).max()
    assert moved > 20 * max(still, 1e-9)
    assert moved > 1e-5  # m: a 14 % contraction of a 1 mm voxel shows


def test_step_after_last_resets():
    env = RobotEnv(tiny_walker(), duration=0.005, control_timestep=0.0025)
    env.reset()
    assert env.step(np.zeros(2)).mid()
    assert env.step(np.zeros(2)).last()
    assert env.step(np.zeros(2)).first()


@pytest.mark.parametrize("action, problem", [
    (np.zeros(3), "shape"), (np.array([0.5, 0.0]), "outside"),
    (np.array([np.nan, 0.0]), "finite"), (np.array([-1.5, 0.0]), "outside")])
def test_bad_actions_are_rejected(action, problem):
    env = RobotEnv(tiny_walker(), duration=0.01)
    env.reset()
    with pytest.raises(ValueError, match=problem):
        env.step(action)


@pytest.mark.parametrize("kwargs", [{"duration": 0.0}, {"control_timestep": -1.0},
                                    {"duration": float("nan")}])
def test_bad_settings_are_rejected(kwargs):
    with pytest.raises(ValueError, match="positive number of seconds"):
        RobotEnv(tiny_walker(), **kwargs)


def test_2d_robot():
    grid = np.zeros((5, 4), dtype=np.int8)
    grid[1:4, 1] = [S, S, S]
    grid[1:4, 2] = [P, S, M]
    env = RobotEnv(Robot(grid), duration=0.01)
    observation = env.reset().observation
    assert observation["voxel_positions"].shape == (6, 3)
    np.testing.assert_allclose(observation["voxel_positions"][:, 1], 0.0, atol=1e-12)
    step = env.step(np.array([-1.0, -0.5]))
    assert np.all(np.isfinite(step.observation["voxel_velocities"]))
