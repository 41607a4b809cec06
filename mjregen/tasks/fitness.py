"""The paper's locomotion fitness of a simulated walk (the locomotion task's rule)."""

from __future__ import annotations

from mjregen.physics.simulation import Result

VOXEL_COST = 0.0583  # 3D fitness penalty per voxel (≈ 20/343, the paper's)
EMPTY_FITNESS = {3: -20.0, 2: 0.0}  # the paper's score of a robot without voxels
UNSTABLE_FITNESS = {3: -21.0, 2: -1.0}  # below every stable robot and the empty one


def locomotion_fitness(result: Result) -> float:
    """3D: distance − 0.0583·voxels; 2D: distance (voxel lengths). An empty robot scores
    −20 (3D) or 0 (2D), an unstable run −21 (3D) or −1 (2D)."""
    if result.n_voxels == 0:
        return EMPTY_FITNESS[result.dim]
    if not result.stable:
        return UNSTABLE_FITNESS[result.dim]
    if result.dim == 3:
        return result.distance - VOXEL_COST * result.n_voxels
    return result.distance
