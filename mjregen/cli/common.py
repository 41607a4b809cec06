"""Helpers shared by the command modules."""

from __future__ import annotations

from mjregen.grid import Material, Robot


def material_counts(robot: Robot) -> dict[str, int]:
    """Voxels per material, by lower-case name, empty left out."""
    return {m.name.lower(): n for m, n in robot.material_counts().items() if m != Material.EMPTY}
