"""How a grown grid becomes the robot: the grid itself, or the paper's 2D sheet."""

import numpy as np
import pytest

from mjregen.errors import InvalidGridError
from mjregen.grid import Material, Robot
from mjregen.physics import Physics
from mjregen.tasks.bodies import BODIES, SHEET_SETTLE_REST, as_robots, body_physics, body_robot

PATTERN = np.pad(np.full((3, 4), Material.MUSCLE_PLUS, np.int8), 1)


def test_a_grid_body_changes_nothing():
    grids = PATTERN[None]
    assert as_robots(grids, "grid") is grids
    assert body_robot(Robot(PATTERN), "grid") == Robot(PATTERN)
    assert body_physics(Physics(), "grid") == Physics()
    assert set(BODIES) == {"grid", "sheet"}


def test_a_sheet_is_the_pattern_flat_on_the_floor_walked_for_the_2d_times():
    sheets = as_robots(PATTERN[None], "sheet")
    assert sheets.shape == (1, *PATTERN.shape, 3) and np.array_equal(sheets[0, :, :, 1], PATTERN)
    robot = body_robot(Robot(PATTERN), "sheet")
    assert robot == Robot(sheets[0]) and body_robot(robot, "sheet") == robot  # a sheet stays
    assert body_physics(Physics(), "sheet").scene.timing(3) == (1.0, 0.25)
    assert body_physics(Physics().replace(settle_time=0.2), "sheet").scene.timing(3) == (0.2, 0.25)


def test_a_sheets_settle_ends_at_rest_unless_the_physics_says_otherwise():
    assert body_physics(Physics(), "sheet").scene.settle_rest == SHEET_SETTLE_REST == 1e-6
    assert body_physics(Physics(), "grid").scene.rest_threshold == 0.0
    for given in (0.0, 1e-4):
        physics = Physics().replace(settle_rest=given)
        assert body_physics(physics, "sheet").scene.settle_rest == given
    mujoco_pipeline = Physics().replace(pipeline="mujoco")
    assert body_physics(mujoco_pipeline, "sheet").scene.rest_threshold == 0.0  # plugin only


def test_a_thick_3d_grid_is_not_a_sheet():
    with pytest.raises(InvalidGridError, match="not a sheet: a 3D grid of 5 layers"):
        body_robot(Robot.box((2, 2, 3)), "sheet")
