"""Picking three good and diverse walkers for the regrowth experiment."""

from pathlib import Path

import numpy as np

from mjregen.experiments import walkers as wk
from mjregen.grid import Robot


def candidate(distance: float, body: np.ndarray, generation: int) -> wk.Candidate:
    robot = Robot.from_body(body.astype(np.int8))
    return wk.Candidate(Path("run"), "3d_ff", 0, generation, distance - 0.0583 * robot.n_voxels,
                        distance, robot, wk.morphology(robot))


def test_picks_the_farthest_then_diverse_walkers_never_a_robot_that_stands_still():
    """A soft 15-voxel slab that barely moves is the most different morphology here, but it
    is no walker: only robots covering a quarter of the best distance are candidates."""
    walkers = [candidate(20.0, np.full((5, 5, 5), 3), 0),
               candidate(18.0, np.full((5, 5, 4), 4), 1),
               candidate(12.0, np.full((3, 3, 2), 3), 2),
               candidate(9.0, np.full((6, 2, 2), 4), 3)]
    still = candidate(0.01, np.ones((5, 3, 1)), 4)
    picked = wk.pick_walkers([*walkers, still])
    assert picked[0].distance == 20.0 and len(picked) == 3
    assert still not in picked
    assert all(p.distance >= wk.MIN_WALK * 20.0 for p in picked)
    assert wk.pick_walkers([still]) == [still]  # alone, the farthest is itself
