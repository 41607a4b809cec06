"""Shifted starts: how much of a walk belongs to the exact start."""

import math

import numpy as np
import pytest

from mjregen.errors import MjregenError
from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.physics.simulation import simulate
from mjregen.resources import asset
from mjregen.search.backends import ThreadBackend
from mjregen.tasks.starts import KEPT, STILL, shifted_starts

WALKERS = asset("robots", "walkers")
MIRROR_WALKER = asset("robots", "mirror_walker_3d.npy")
SHORT = Physics().replace(settle_time=0.01)
EXACT = Physics().replace(start_shift=0.0)


def test_a_mirror_symmetric_walker_loses_its_walk_from_shifted_starts():
    """The mirror walker is its own mirror image across y: from the exact start it keeps that
    symmetry and walks a way that any shift ends (here the default start's 1e-4 voxel
    lengths, and the smallest one, 1e-5)."""
    robot = Robot.load(MIRROR_WALKER)
    starts = shifted_starts(robot, starts=3)
    assert starts.mirror_axes == ("y",) and starts.shift == 1e-4
    assert starts.default.distance == simulate(robot, physics=EXACT).distance
    assert starts.distances[0] == simulate(robot).distance  # start 0 is the default walk
    assert np.all(starts.stable) and starts.indices == (0, 1, 2) and starts.seed == 0
    assert starts.high < KEPT * starts.default.distance
    assert starts.kept == pytest.approx(starts.mean / starts.default.distance)
    assert starts.depends_on_start
    tiny = shifted_starts(robot, starts=2, shift=1e-5)  # the smallest a start keeps
    assert tiny.shift == 1e-5 and tiny.high < KEPT * tiny.default.distance


def test_a_walker_without_a_mirror_plane_keeps_its_walk():
    robot = Robot.load(WALKERS / "walker_3.npy")
    starts = shifted_starts(robot, starts=2)
    assert starts.mirror_axes == ()
    assert starts.low <= starts.mean <= starts.high
    assert starts.kept == pytest.approx(1.0, abs=0.01) and not starts.depends_on_start


def test_threads_walk_the_same_starts_as_one_process():
    robot = Robot.load(MIRROR_WALKER)
    serial = shifted_starts(robot, physics=SHORT, duration=0.1, starts=3, shift=1e-5,
                            start_seed=5, record_default=True)
    with ThreadBackend(2) as backend:
        threaded = shifted_starts(robot, physics=SHORT, duration=0.1, starts=3, shift=1e-5,
                                  start_seed=5, backend=backend, record_default=True)
    assert serial.indices == threaded.indices == (0, 1, 2) and serial.seed == threaded.seed == 5
    assert np.array_equal(serial.distances, threaded.distances)
    assert serial.default.distance == threaded.default.distance
    assert np.array_equal(serial.default.com, threaded.default.com)
    assert len(set(serial.distances.tolist())) == 3  # three different starts


def test_an_unstable_shifted_walk_counts_as_depending_on_the_start():
    """A walk that diverges gives no distance (NaN), is left out of the statistics and
    makes the robot's walk depend on its start."""
    robot = Robot.load(MIRROR_WALKER)
    unstable = SHORT.replace(timestep_safety=20.0)
    starts = shifted_starts(robot, physics=unstable, duration=0.02, starts=2)
    assert not np.any(starts.stable) and all(starts.reasons)
    assert math.isnan(starts.mean) and math.isnan(starts.kept)
    assert starts.depends_on_start


def test_a_robot_that_does_not_walk_has_no_share_to_keep():
    """The in-phase robot, mirrored across x and y, stays where it is (its net displacement
    cancels): its shifted starts' distances are rounding, not a share of a walk."""
    starts = shifted_starts(Robot.load(asset("robots", "symmetric_inphase_3d.npy")), starts=2)
    assert starts.default.distance < STILL and starts.mirror_axes == ("x", "y")
    assert math.isnan(starts.kept) and not starts.depends_on_start


@pytest.mark.parametrize("kwargs, message", [
    ({"starts": 0}, "starts"), ({"starts": 2.0}, "starts"), ({"shift": 0.0}, "shift"),
    ({"shift": math.nan}, "shift"), ({"shift": -1e-9}, "shift"), ({"shift": 0.5}, "shift"),
    ({"shift": 1e-9}, "round such a shift away"),
])
def test_bad_shifted_starts_are_refused(kwargs, message):
    with pytest.raises(MjregenError, match=message):
        shifted_starts(Robot.load(MIRROR_WALKER), **kwargs)


def test_an_empty_robot_has_no_start():
    with pytest.raises(MjregenError, match="empty"):
        shifted_starts(Robot(np.zeros((9, 9, 9), dtype=np.int8)))
