"""The paper's locomotion fitness of a simulated walk (the locomotion task's rule)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mjregen.physics.simulation import Result

VOXEL_COST = 0.0583  # 3D fitness penalty per voxel (≈ 20/343, the paper's)
EMPTY_FITNESS = {3: -20.0, 2: 0.0}  # the paper's score of a robot without voxels
UNSTABLE_FITNESS = {3: -21.0, 2: -1.0}  # below every stable robot and the empty one


def locomotion_fitness(result: Result, *, rule: int | None = None) -> float:
    """3D rule: distance − 0.0583·voxels; 2D rule: distance (voxel lengths). An empty robot
    scores −20 (3D) or 0 (2D), an unstable run −21 (3D) or −1 (2D). `rule`: 2 or 3, the
    rule to apply; None = the robot's dimension (a 2D sheet walked in 3D takes rule 2)."""
    dim = result.dim if rule is None else rule
    if dim not in EMPTY_FITNESS:
        raise ValueError(f"no locomotion fitness rule for dimension {dim!r} (2 or 3)")
    if result.n_voxels == 0:
        return EMPTY_FITNESS[dim]
    if not result.stable:
        return UNSTABLE_FITNESS[dim]
    if dim == 3:
        return result.distance - VOXEL_COST * result.n_voxels
    return result.distance


def starts_fitness(results: Sequence[Result], *, rule: int | None = None) -> float:
    """The fitness of a robot walked from several starts: the mean of their
    `locomotion_fitness`, or the unstable one's when any start was unstable (one unstable
    start makes the robot unstable)."""
    unstable = [r for r in results if not r.stable]
    if unstable:
        return locomotion_fitness(unstable[0], rule=rule)
    return float(np.mean([locomotion_fitness(r, rule=rule) for r in results]))
