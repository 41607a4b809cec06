"""How a grown grid becomes the robot that walks (torch-free: the `walk` command uses it).

A 3D NCA's grid is its robot. A 2D NCA's pattern is either a robot in the x-z plane ("grid")
or, as in the paper's code, which writes the grown pattern into Voxelyze as one layer
(``Z_Voxels`` 1), a sheet lying flat on the floor and walking in 3D ("sheet"), for the 2D
times (settle 1.0 s, 0.25 s measured) and scored by the 2D rule (the distance).
"""

from __future__ import annotations

import numpy as np

from mjregen.errors import InvalidGridError
from mjregen.grid import Robot, lay_flat
from mjregen.physics.params import Physics

# 1/s: a sheet's settle ends once every voxel is slower than 1e-6 voxel lengths/s and 1e-6
# rad/s (for 5 ms): a flat sheet comes to rest within about 1 % of the paper's 1 s settle,
# and its walk then moves by at most about 1e-11 voxel lengths (docs/performance.md)
SHEET_SETTLE_REST = 1e-6

BODIES = {
    "grid": "the grown grid is the robot (a 2D one moves in the x-z plane)",
    "sheet": "a 2D pattern lies flat on the floor as one layer of voxels and walks in 3D "
             "(the paper's 2D robots), for the 2D times, scored by the 2D rule; its settle "
             "ends once it is at rest",
}


def as_robots(grids: np.ndarray, body: str) -> np.ndarray:
    """The robots of grown grids int8 ``(P, *grid)``: the grids themselves, or (sheet) the
    patterns laid flat, int8 ``(P, X, Y, 3)``."""
    return lay_flat(grids) if body == "sheet" else grids


def body_robot(robot: Robot, body: str) -> Robot:
    """One robot file's robot of `body`: itself ("grid"), or (sheet) a 2D pattern laid flat
    or a sheet as it is.

    Raises:
      InvalidGridError: a sheet asked of a 3D grid that is not one voxel layer between two
        empty ones.
    """
    if body != "sheet":
        return robot
    if robot.dim == 2:
        return Robot(lay_flat(robot.grid))
    if robot.shape[2] != 3:
        raise InvalidGridError(f"not a sheet: a 3D grid of {robot.shape[2]} layers (a sheet "
                               "has one voxel layer between two empty ones)")
    return robot


def body_physics(physics: Physics, body: str) -> Physics:
    """The physics robots of `body` walk in: `physics` (an unset settle rest is the full
    settle), for a sheet with its unset settle and measured times the paper's 2D ones (a
    sheet is a 3D robot, whose defaults are 3D's) and its unset settle rest (`Scene.
    settle_rest` None) SHEET_SETTLE_REST on the voxel pipeline."""
    if body != "sheet":
        return physics
    scene = physics.scene
    rest = scene.settle_rest
    if rest is None:
        rest = SHEET_SETTLE_REST if physics.pipeline.holds_at_rest else 0.0
    settle, measured = scene.timing(2)
    return physics.replace(settle_time=settle, measured_time=measured, settle_rest=rest)
