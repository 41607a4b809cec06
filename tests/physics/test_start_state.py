"""The start of a walk: seeded offsets of every voxel, held in the model as keyframes."""

import math

import mujoco
import numpy as np
import pytest

from mjregen.errors import CompileError
from mjregen.grid import Robot
from mjregen.physics import Physics, PhysicsParameterError, migrate_physics
from mjregen.physics.compile import compile_robot
from mjregen.physics.model import robot_layout
from mjregen.physics.migrate import PHYSICS_FORMAT
from mjregen.physics.params import DEFAULT_START_SHIFT
from mjregen.physics.simulation import simulate, simulate_starts
from mjregen.physics.start_state import MAX_STARTS, key_name, rest_qpos, start_generator

EXACT = Physics().replace(start_shift=0.0)


def soft_plate() -> Robot:
    """A one-voxel-thick soft plate, 5 wide and 7 tall, standing on its 5-voxel edge: an
    equilibrium that only an exact mirror symmetry (across y) keeps."""
    grid = np.zeros((9, 9, 9), dtype=np.int8)
    grid[2:7, 4, 1:8] = 1
    return Robot(grid)


@pytest.mark.parametrize("dim, clamped", [(3, ()), (3, ((1, 1, 1),)), (2, ()), (2, ((1, 1),))])
def test_rest_coordinates_are_the_models_qpos0(dim, clamped):
    robot = Robot.box((3, 2, 2) if dim == 3 else (3, 2))
    layout = robot_layout(robot, EXACT, set(clamped), 0.0)
    qpos, translational = rest_qpos(layout)
    model = compile_robot(robot, physics=EXACT, clamped=clamped).model
    assert np.array_equal(qpos, model.qpos0)
    assert translational.sum() == dim * (robot.n_voxels - len(clamped))


def test_each_start_moves_the_positions_by_the_shift_and_leaves_rotations():
    shift = 1e-3
    compiled = compile_robot(Robot.box((4, 4, 4)), physics=Physics().replace(start_shift=shift),
                             starts=(0, 1))
    model = compiled.model
    assert compiled.starts == (0, 1) and model.nkey == 2
    offsets = [(model.key_qpos[compiled.start_key(k)] - model.qpos0).reshape(-1, 7)
               for k in (0, 1)]
    for offset in offsets:
        assert np.all(offset[:, 3:] == 0.0)  # orientations exact
        assert np.std(offset[:, :3]) / 1e-3 == pytest.approx(shift, rel=0.2)  # voxel lengths
        assert abs(np.mean(offset[:, :3])) < 4 * shift * 1e-3 / np.sqrt(offsets[0][:, :3].size)
    assert not np.allclose(offsets[0], offsets[1])


def test_a_start_is_named_by_its_seed_its_index_and_the_robot():
    grid = np.asarray(Robot.box((3, 3, 3)).grid)
    other = grid.copy()
    other[1, 1, 1] = 3

    def draw(g, seed, index):
        return start_generator(g, seed, index).normal(size=4)

    assert np.array_equal(draw(grid, 5, 2), draw(grid.copy(), 5, 2))
    draws = [draw(grid, 5, 2), draw(grid, 6, 2), draw(grid, 5, 3), draw(other, 5, 2)]
    assert len({d.tobytes() for d in draws}) == 4


def test_simulate_walks_from_a_start_that_the_start_list_repeats_to_the_bit():
    robot = Robot.load("assets/robots/bimorph_walker_3d.npy")
    many = simulate_starts(robot, duration=0.05, starts=(0, 1, 2), start_seed=3)
    for index, result in enumerate(many):
        alone = simulate(robot, duration=0.05, start_seed=3, start=index)
        assert alone.distance == result.distance and alone.steps == result.steps
    assert len({r.distance for r in many}) == 3
    exact = simulate(robot, physics=EXACT, duration=0.05)
    assert exact.distance not in {r.distance for r in many}
    assert many[0].distance == pytest.approx(exact.distance, rel=0.05)


def test_without_a_start_shift_seed_and_index_change_nothing():
    robot = Robot.load("assets/robots/bimorph_walker_3d.npy")
    compiled = compile_robot(robot, physics=EXACT, starts=(4,), start_seed=9)
    assert compiled.model.nkey == 0 and compiled.starts == () and compiled.start_key(4) is None
    walks = {simulate(robot, physics=EXACT, duration=0.05, start_seed=s, start=k).distance
             for s, k in ((0, 0), (9, 4))}
    assert len(walks) == 1


def test_a_plate_on_its_edge_stands_from_the_exact_start_and_falls_from_a_shifted_one():
    """An unstable equilibrium: the exact start keeps the mirror symmetry to rounding, so the
    plate stands (its centre of mass stays 3.5 voxels up); any shift topples it, and it ends
    lying on its face (centre of mass half a voxel up)."""
    plate = soft_plate()
    assert plate.mirror_axes() == ("x", "y")
    standing = simulate(plate, physics=EXACT, record=True)
    fallen = simulate(plate, record=True)
    assert standing.com[-1, 2] / 1e-3 == pytest.approx(3.5, abs=0.1)
    assert fallen.com[0, 2] / 1e-3 == pytest.approx(3.5, abs=0.01)
    assert fallen.com[-1, 2] / 1e-3 < 0.75


def test_the_exported_model_holds_the_starts():
    compiled = compile_robot(Robot.load("assets/robots/paper/tripod.npy"), starts=(0, 2),
                             start_seed=1)
    plain = mujoco.MjModel.from_xml_string(compiled.to_xml())  # the plugin is loaded
    assert plain.nkey == 2 and plain.key(key_name(2)).id == compiled.start_key(2)
    assert np.array_equal(plain.key_qpos, compiled.model.key_qpos)
    with pytest.raises(CompileError, match="start 1 was not compiled"):
        compiled.start_key(1)


def test_the_default_start_shift_and_older_descriptions():
    assert Physics().scene.start_shift == DEFAULT_START_SHIFT == 1e-4
    older = {**Physics().to_dict(), "format": 4}
    older["scene"] = {k: v for k, v in older["scene"].items() if k != "start_shift"}
    assert Physics.from_dict(older).scene.start_shift == 0.0
    assert migrate_physics(older)["format"] == PHYSICS_FORMAT


@pytest.mark.parametrize("shift", [-1e-9, math.nan, math.inf, 0.5, "1e-4", True, 1e-6])
def test_a_bad_start_shift_is_refused(shift):
    with pytest.raises(PhysicsParameterError, match="start_shift"):
        Physics().replace(start_shift=shift)


@pytest.mark.parametrize("kwargs, message", [
    ({"start_seed": -1}, "start_seed"), ({"start_seed": 1.5}, "start_seed"),
    ({"starts": (-1,)}, "start index"), ({"starts": ()}, "at least one"),
    ({"starts": (1, 1)}, "distinct")])
def test_bad_starts_are_refused(kwargs, message):
    with pytest.raises(CompileError, match=message):
        compile_robot(Robot.box((2, 2, 2)), **kwargs)


@pytest.mark.parametrize("shift, share", [(1e-5, 0.6), (1e-4, 0.9)])
def test_the_start_shift_survives_the_keyframes_digits(shift, share):
    """MJCF keeps 6 significant digits of a position (steps of 1e-5 voxel lengths 1 to 10
    voxel lengths from the origin): the smallest shift allowed still moves most coordinates,
    the default nearly all, by about the shift asked (a 1e-9 one would have moved none)."""
    compiled = compile_robot(Robot.load("assets/robots/paper/tripod.npy"),
                             physics=Physics().replace(start_shift=shift))
    offsets = (compiled.model.key_qpos[0] - compiled.model.qpos0).reshape(-1, 7)[:, :3] / 1e-3
    assert np.mean(offsets != 0.0) > share
    assert np.std(offsets) == pytest.approx(shift, rel=0.2)


def test_more_than_one_exact_start_is_refused():
    """With start shift 0 every start is the exact start: K of them would be one walk K
    times (K times its cost), so compile, walk and the task refuse more than one."""
    exact = Physics().replace(start_shift=0.0)
    with pytest.raises(CompileError, match="every start is the exact start"):
        compile_robot(Robot.box((2, 2, 2)), physics=exact, starts=(0, 1))
    assert compile_robot(Robot.box((2, 2, 2)), physics=exact).starts == ()


def test_more_starts_than_a_model_holds_are_refused():
    with pytest.raises(CompileError, match="more than one model holds"):
        compile_robot(Robot.box((2, 2, 2)), starts=range(MAX_STARTS + 1))
