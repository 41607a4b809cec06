"""The physics of a voxel robot: parameters and presets, the MuJoCo model, the voxel plugin."""

from mjregen.physics.migrate import PHYSICS_FORMAT, migrate_physics
from mjregen.physics.native import NativeBuildError, plugin_library
from mjregen.physics.params import (
    BOND_ELEMENTS, BOND_MODELS, CONTACT_SHAPES, INTEGRATORS, MODE_RATIO, PAPER_TIMES,
    POINT_RADIUS, STEPPERS, TIMESTEP_RULES, WAVEFORMS, MaterialProperties, Physics,
    PhysicsParameterError, Scene, legacy_physics, paper_materials, paper_physics,
    sphere_physics,
)

__all__ = [
    "BOND_ELEMENTS", "BOND_MODELS", "CONTACT_SHAPES", "INTEGRATORS", "MODE_RATIO",
    "PAPER_TIMES", "POINT_RADIUS", "STEPPERS", "TIMESTEP_RULES", "WAVEFORMS",
    "MaterialProperties", "NativeBuildError", "PHYSICS_FORMAT", "Physics", "PhysicsParameterError", "Scene",
    "legacy_physics", "migrate_physics", "paper_materials", "paper_physics", "plugin_library", "sphere_physics",
]
