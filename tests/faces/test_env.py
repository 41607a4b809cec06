"""The robot as a dm_control task (`mjregen.env.load`)."""

import math
import subprocess
import sys

import dm_env
import numpy as np
import pytest
from absl.testing import absltest
from dm_control.rl import control
from dm_env import test_utils

from mjregen.env import VoxelPhysics, load
from mjregen.grid import Material, Robot
from mjregen.physics import Physics, sphere_physics
from mjregen.physics.simulation import simulate

P, M, S = Material.MUSCLE_PLUS, Material.MUSCLE_MINUS, Material.SOFT


def tiny_walker() -> Robot:
    """Four voxels: two legs of soft, a body of muscle + and muscle −."""
    body = np.zeros((2, 1, 2), dtype=np.int8)
    body[:, 0, 1] = [P, M]
    body[:, 0, 0] = [S, S]
    return Robot.from_body(body)


def tiny_walker_2d() -> Robot:
    grid = np.zeros((5, 4), dtype=np.int8)
    grid[1:4, 1] = [S, S, S]
    grid[1:4, 2] = [P, S, M]
    return Robot(grid)


def actions(seed: int = 0):
    rng = np.random.default_rng(seed)
    for _ in range(10):
        yield rng.uniform(-1.0, 0.0, size=2)


class ConformanceTest3D(test_utils.EnvironmentTestMixin, absltest.TestCase):
    """dm_env's test helpers: specs, FIRST/MID/LAST sequence, reset after LAST."""

    def make_object_under_test(self):
        return load(tiny_walker(), duration=0.01, control_timestep=0.0025)

    def make_action_sequence(self):  # long enough for two episodes (4 steps each)
        return actions()


class ConformanceTest2D(ConformanceTest3D):
    def make_object_under_test(self):
        return load(tiny_walker_2d(), duration=0.01, control_timestep=0.0025)


def test_import_and_type():
    done = subprocess.run([sys.executable, "-c", "import dm_control, mjregen.env"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    env = load(Robot.load("assets/robots/paper/tripod.npy"), duration=0.005)
    assert isinstance(env, control.Environment) and isinstance(env.physics, VoxelPhysics)


def test_specs_and_named_access():
    env = load(tiny_walker(), duration=0.01)
    assert env.action_spec().shape == (2,) and env.action_spec().maximum == 0.0
    assert env.observation_spec()["voxel_positions"].shape == (4, 3)
    symmetric = load(tiny_walker(), physics=Physics().replace(waveform="symmetric"))
    assert symmetric.action_spec().maximum == 1.0
    env.reset()
    physics = env.physics
    np.testing.assert_array_equal(physics.named.data.xpos["voxel_1_1_1"],
                                  physics.data.xpos[physics.model.ptr.body("voxel_1_1_1").id])
    assert physics.floor_contacts() == 2  # the two legs stand on the floor
    env.step(np.array([-1.0, 0.0]))
    np.testing.assert_array_equal(physics.muscle_strains(), [-1.0, 0.0])


def test_open_loop_episode_reproduces_simulate():
    """The model's own waveform drives the muscles: the return is `simulate`'s distance."""
    robot, duration = tiny_walker(), 0.02
    env = load(robot, duration=duration, control_timestep=1e-9, open_loop=True)
    assert env.action_spec().shape == (0,)
    step, total, k = env.reset(), 0.0, 0
    while not step.last():
        step = env.step(np.zeros(0))
        total += step.reward
        k += 1
    expected = simulate(robot, duration=duration)
    assert k == expected.steps - round(0.05 / expected.timestep)
    assert expected.distance > 0.01  # the robot moves, so the check means something
    assert math.isclose(total, expected.distance, rel_tol=0.0, abs_tol=1e-9)
    assert step.step_type == dm_env.StepType.LAST and step.discount == 1.0


def test_episodes_draw_their_starts_reproducibly():
    """With starts=K each reset draws one of K starts (seeded by start_seed): the episodes'
    first states repeat for the same seed, differ between episodes, and are keyframes of
    starts 0 .. K-1; starts=1 starts every episode from start 0."""
    def first_states(seed: int, starts: int) -> list[np.ndarray]:
        env = load(tiny_walker(), duration=0.005, open_loop=True, start_seed=seed,
                   starts=starts)
        return [env.reset().observation["voxel_positions"] for _ in range(6)]

    a, b = first_states(3, 4), first_states(3, 4)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert len({x.tobytes() for x in a}) > 1  # several of the 4 starts were drawn
    single = first_states(3, 1)
    assert len({x.tobytes() for x in single}) == 1
    with pytest.raises(ValueError, match="starts"):
        load(tiny_walker(), starts=0)


def test_reset_is_deterministic_and_actions_matter():
    def rollout(seed: int) -> tuple[np.ndarray, float]:
        env = load(tiny_walker(), duration=0.02)
        step, total = env.reset(), 0.0
        first = step.observation["voxel_positions"]
        for action in actions(seed):
            step = env.step(action)
            total += step.reward
            assert all(np.all(np.isfinite(v)) for v in step.observation.values())
            if step.last():
                break
        return first, step.observation["voxel_positions"], total

    a, b, c = rollout(1), rollout(1), rollout(2)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    assert a[2] == b[2] and not np.array_equal(a[1], c[1])


def test_muscles_move_the_voxels_and_no_action_does_not():
    """From the exact start: one voxel deep, the walker would topple from a shifted one."""
    env = load(tiny_walker(), duration=0.01, physics=Physics().replace(start_shift=0.0))
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


@pytest.mark.parametrize("action, problem", [
    (np.zeros(3), "shape"), (np.array([0.5, 0.0]), "outside"),
    (np.array([np.nan, 0.0]), "finite")])
def test_bad_actions_are_rejected(action, problem):
    env = load(tiny_walker(), duration=0.01)
    env.reset()
    with pytest.raises(ValueError, match=problem):
        env.step(action)


@pytest.mark.parametrize("kwargs", [{"duration": 0.0}, {"control_timestep": -1.0},
                                    {"duration": float("nan")}])
def test_bad_settings_are_rejected(kwargs):
    with pytest.raises(ValueError, match="positive number of seconds"):
        load(tiny_walker(), **kwargs)


def test_a_control_step_longer_than_the_episode_is_refused():
    with pytest.raises(ValueError, match="exceeds the episode's duration"):
        load(tiny_walker(), duration=0.01, control_timestep=0.02)


def test_pure_mujoco_pipeline_is_refused():
    from mjregen.errors import MjregenError

    with pytest.raises(MjregenError, match="voxel pipeline"):
        load(tiny_walker(), physics=sphere_physics())


def test_2d_robot():
    env = load(tiny_walker_2d(), duration=0.01)
    observation = env.reset().observation
    assert observation["voxel_positions"].shape == (6, 3)
    np.testing.assert_allclose(observation["voxel_positions"][:, 1], 0.0, atol=1e-12)
    step = env.step(np.array([-1.0, -0.5]))
    assert np.all(np.isfinite(step.observation["voxel_velocities"]))
