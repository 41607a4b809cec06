"""Locomotion evaluation: walking, symmetry, determinism, fitness, stability guard."""

import math
from pathlib import Path

import numpy as np
import pytest

from mjregen.errors import InvalidGridError
from mjregen.grid import Robot
from mjregen.physics import Physics, PhysicsParameterError
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import simulate, simulation_of
from mjregen.tasks.fitness import (
    EMPTY_FITNESS,
    UNSTABLE_FITNESS,
    VOXEL_COST,
    locomotion_fitness,
)

ROBOTS = Path(__file__).resolve().parents[2] / "assets" / "robots"


@pytest.fixture(scope="module")
def walker_3d():
    return simulate(Robot.load(ROBOTS / "bimorph_walker_3d.npy"), record=True)


def test_two_phase_walker_moves(walker_3d):
    """The bimorph walker moves (0.17 voxel lengths in 20 cycles; the mirror-symmetric robot
    moves 1e-15) along its length."""
    result = walker_3d
    assert result.stable and result.reason == ""
    assert result.distance > 0.1
    start = np.searchsorted(result.times, 0.05)
    displacement = result.com[-1] - result.com[start]
    assert abs(displacement[0]) > 10 * abs(displacement[1])
    settled = result.com[np.searchsorted(result.times, 0.05 - result.timestep / 2)]
    moved = (result.com[-1] - settled)[:2] / 1e-3  # voxel lengths
    assert np.allclose(result.displacement, moved, rtol=1e-9, atol=1e-12)
    assert result.heading == pytest.approx(math.degrees(math.atan2(*moved[::-1])), abs=1e-6)
    assert min(abs(result.heading), 180.0 - abs(result.heading)) < 6.0  # along ±x
    assert result.dim == 3 and VOXEL_COST == 0.0583
    assert locomotion_fitness(result) == pytest.approx(result.distance - 0.0583 * 20, abs=1e-12)


def test_two_phase_walker_moves_in_2d():
    result = simulate(Robot.load(ROBOTS / "bimorph_walker_2d.npy"))
    assert result.stable and result.distance > 0.4  # 0.75 in the paper's 10 cycles
    assert result.dim == 2 and locomotion_fitness(result) == result.distance
    assert result.displacement[1] == 0.0 and abs(result.displacement[0]) == result.distance
    assert result.heading in (0.0, 180.0)


def test_mirror_symmetric_in_phase_robot_does_not_move():
    """By mirror symmetry (x and y) its net displacement is zero; allow 1e-3 voxel lengths."""
    result = simulate(Robot.load(ROBOTS / "symmetric_inphase_3d.npy"))
    assert result.stable and result.distance < 1e-3


def test_record_covers_settle_and_measurement(walker_3d):
    result = walker_3d
    assert result.times.shape == (result.steps + 1,) and result.com.shape == (result.steps + 1, 3)
    assert result.sim_time == pytest.approx(0.55, abs=result.timestep)
    assert result.times[-1] == pytest.approx(result.sim_time)
    assert np.allclose(result.com[0, :2], 0.0, atol=1e-7)  # centred, to the start shift
    start = np.searchsorted(result.times, 0.05 - result.timestep / 2)
    distance = np.linalg.norm(result.com[-1, :2] - result.com[start, :2]) / 1e-3
    assert distance == pytest.approx(result.distance, rel=1e-9)
    assert result.wall_time > 0 and result.cpu_time > 0


def test_same_robot_gives_bit_identical_results():
    robot = Robot.from_body(np.array([[3, 1], [4, 2], [3, 4]], dtype=np.int8))
    physics = Physics().replace(settle_time=0.02, measured_time=0.05)
    a = simulate(robot, physics=physics, record=True)
    b = simulate(robot, physics=physics, record=True)
    assert a.distance == b.distance and a.steps == b.steps
    assert np.array_equal(a.com, b.com)


def test_duration_sets_the_measured_time():
    robot = Robot.box((2, 1, 1))
    result = simulate(robot, duration=0.01)
    assert result.steps == round(0.05 / result.timestep) + round(0.01 / result.timestep)
    with pytest.raises(PhysicsParameterError, match="duration"):
        simulate(robot, duration=-1.0)
    with pytest.raises(PhysicsParameterError, match="duration"):
        simulate(robot, duration=math.nan)


@pytest.mark.parametrize("shape, fitness", [((5, 5, 5), -20.0), ((5, 5), 0.0)])
def test_empty_robot_scores_without_simulating(shape, fitness):
    result = simulate(Robot(np.zeros(shape, dtype=np.int8)))
    assert result.dim == len(shape) and EMPTY_FITNESS[result.dim] == fitness
    assert locomotion_fitness(result) == fitness and result.steps == 0 and result.n_voxels == 0
    assert result.displacement == (0.0, 0.0) and math.isnan(result.heading)  # no direction


def test_unstable_run_is_flagged_with_penalty_not_raised():
    """20× the stable time step makes explicit integration diverge: a defined result."""
    robot = Robot.box((2, 2, 2))
    physics = Physics().replace(timestep_safety=20.0)
    result = simulate(robot, physics=physics)
    assert not result.stable and result.reason
    assert locomotion_fitness(result) == UNSTABLE_FITNESS[3] == -21.0
    assert math.isnan(result.distance) and math.isnan(result.heading)
    assert all(math.isnan(d) for d in result.displacement)
    assert result.steps < round(0.55 / result.timestep)  # stopped early
    result_2d = simulate(Robot.box((2, 2)), physics=physics)
    assert not result_2d.stable and locomotion_fitness(result_2d) == UNSTABLE_FITNESS[2] == -1.0


def test_invalid_grid_is_rejected_before_simulation():
    with pytest.raises(InvalidGridError, match="border"):
        simulate(np.ones((3, 3, 3), dtype=np.int8))
    with pytest.raises(InvalidGridError, match="unknown material"):
        simulate(np.full((3, 3), 7))
    grid = np.zeros((3, 3, 3), dtype=np.int8)
    grid[1, 1, 1] = 1
    assert simulate(grid, duration=0.001).stable  # plain arrays are validated and accepted


@pytest.mark.parametrize("element", ["beam", "tendons"])
def test_default_timestep_is_stable_for_a_block_with_interior_voxels(element):
    """The stability study behind the default safety factor 0.75, in small.

    A hard 4×4×4 block has 8 interior voxels with 6 bonds each, the stiffest connectivity
    a robot can have. Kicked with random velocities (every mode excited; a symmetric drop
    would leave the fastest, antisymmetric modes at rest), free of floor and gravity: at
    the default it runs; at 1.25 × the stability limit of the time-step rule it diverges,
    and the guard catches it. Beams and tendons have the same linear stiffness and damping,
    so the same limit (both run at 1.05 and diverge at 1.1).
    """
    robot = Robot.box((4, 4, 4), 2)
    outcomes = []
    for safety in (0.75, 1.25):
        physics = Physics().replace(timestep_safety=safety, bond_element=element,
                                          floor=False, gravity=0.0)
        sim = simulation_of(compile_robot(robot, physics=physics))
        sim.data.qvel[:] = np.random.default_rng(1).normal(size=sim.model.nv) * 1e-3
        outcomes.append(sim.run(3000))
    assert outcomes[0] == "" and outcomes[1] != ""


def test_a_trajectory_too_large_to_record_is_refused_before_it_is_taken(monkeypatch):
    from mjregen.physics import simulation

    monkeypatch.setattr(simulation, "MAX_RECORD_BYTES", 1000)
    robot = Robot.load(ROBOTS / "bimorph_walker_3d.npy")
    with pytest.raises(PhysicsParameterError, match="would take .* GiB .* shorter duration"):
        simulate(robot, duration=0.01, record=True)
    assert simulate(robot, duration=0.01).stable  # without the trajectory it walks
