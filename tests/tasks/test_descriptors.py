"""Behaviour descriptors of robot grids, checked on robots whose answers are known by
construction."""

import numpy as np
import pytest

from mjregen.grid import Material, Robot
from mjregen.tasks.descriptors import (
    DESCRIPTORS,
    check_descriptors,
    default_cells,
    describe,
    descriptor_ranges,
)

NAMES = ("voxels", "muscle", "height", "footprint", "feet")


def tripod_like() -> np.ndarray:
    """Three 1x1 legs two cells high under a 3x3 soft slab, in a 9^3 grid; one leg is
    muscle."""
    grid = np.zeros((9, 9, 9), dtype=np.int8)
    grid[2:5, 2:5, 3] = Material.SOFT  # slab, 9 voxels, on z = 3
    for x, y in ((2, 2), (4, 2), (3, 4)):
        grid[x, y, 1:3] = Material.HARD
    grid[3, 4, 1:3] = Material.MUSCLE_PLUS
    return grid


def test_values_of_a_three_legged_robot():
    values = dict(zip(NAMES, describe(tripod_like()[None], NAMES)[0]))
    assert values["voxels"] == 9 + 6
    assert values["muscle"] == pytest.approx(2 / 15)
    assert values["height"] == 3  # z = 1, 2, 3
    assert values["footprint"] == pytest.approx(9 / 49)  # the slab's shadow
    assert values["feet"] == 3  # three separate legs touch the floor layer


def test_touching_feet_are_one_patch_and_diagonal_ones_two():
    grid = np.zeros((9, 9, 9), dtype=np.int8)
    grid[2:4, 2, 1] = Material.SOFT  # two face neighbours: one foot
    grid[5, 5, 1] = grid[6, 6, 1] = Material.SOFT  # corner contact only: two feet
    assert describe(grid[None], ["feet"])[0, 0] == 3


def test_an_empty_robot_and_a_full_block():
    empty = np.zeros((9, 9, 9), dtype=np.int8)
    full = Robot.box((7, 7, 7), Material.MUSCLE_MINUS).grid
    values = describe(np.stack([empty, full]), NAMES)
    assert values[0].tolist() == [0, 0, 0, 0, 0]
    assert values[1].tolist() == [343, 1, 7, 1, 1]
    ranges = descriptor_ranges(NAMES, (9, 9, 9))
    for (low, high), value in zip(ranges, values[1]):
        assert low <= value <= high  # the fullest robot is inside every range


def test_two_dimensional_robots():
    grid = np.zeros((7, 7), dtype=np.int8)
    grid[1, 1:3] = grid[3, 1:3] = grid[5, 1:3] = Material.SOFT  # three legs, x = 1, 3, 5
    grid[1:6, 3] = Material.MUSCLE_PLUS  # a 5-cell beam across them
    values = dict(zip(NAMES, describe(grid[None], NAMES)[0]))
    assert values == {"voxels": 11, "muscle": pytest.approx(5 / 11), "height": 3,
                      "footprint": 1.0, "feet": 3}
    assert descriptor_ranges(["voxels", "feet"], (7, 7)) == [(-0.5, 25.5), (-0.5, 3.5)]


def test_counts_get_a_cell_per_value_up_to_twenty():
    assert default_cells(["voxels", "muscle", "height", "feet"], (9, 9, 9)) == (20, 10, 8, 20)
    assert default_cells(["height"], (7, 7)) == (6,)


def test_unknown_or_repeated_names_are_refused():
    with pytest.raises(ValueError, match="unknown behaviour descriptor 'legs'"):
        check_descriptors(["voxels", "legs"])
    with pytest.raises(ValueError, match="repeat"):
        check_descriptors(["voxels", "voxels"])
    with pytest.raises(ValueError, match="at least one"):
        check_descriptors([])
    assert set(DESCRIPTORS) == set(NAMES)
