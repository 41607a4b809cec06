"""The physics of a voxel robot: parameters and presets, the one MuJoCo model, simulation.

Layers, the data flowing one way: `params` and `presets` (plain data) -> `model` (grid to
arrays, no MuJoCo) -> `mjcf` (the `MjSpec`: bodies and the voxel plugin, or MuJoCo's
tendons and contacts) -> `timestep` (decided once) -> `compile` (`compile_robot`) ->
`stepper` (the fast path of ``mj_step``) and `simulation` (`simulate`, the stability
guard, `Result`). `native` builds and loads the plugin library (`plugin/`, C).
"""

from mjregen.physics.compile import CompiledRobot, compile_robot
from mjregen.physics.migrate import PHYSICS_FORMAT, migrate_physics
from mjregen.physics.native import NativeBuildError, plugin_library
from mjregen.physics.params import (
    BOND_ELEMENTS,
    BOND_MODELS,
    CONTACT_SHAPES,
    INTEGRATORS,
    PAPER_TIMES,
    PIPELINES,
    POINT_RADIUS,
    STEPPERS,
    TIMESTEP_RULES,
    WAVEFORMS,
    MaterialProperties,
    MujocoPipeline,
    Physics,
    PhysicsParameterError,
    Scene,
    VoxelPipeline,
    paper_materials,
)
from mjregen.physics.presets import legacy_physics, paper_physics, sphere_physics
from mjregen.physics.simulation import Result, Simulation, simulate, simulation_of

__all__ = [
    "BOND_ELEMENTS", "BOND_MODELS", "CONTACT_SHAPES", "INTEGRATORS", "PAPER_TIMES",
    "PHYSICS_FORMAT", "PIPELINES", "POINT_RADIUS", "STEPPERS", "TIMESTEP_RULES", "WAVEFORMS",
    "CompiledRobot", "MaterialProperties", "MujocoPipeline", "NativeBuildError", "Physics",
    "PhysicsParameterError", "Result", "Scene", "Simulation", "VoxelPipeline",
    "compile_robot", "legacy_physics", "migrate_physics", "paper_materials", "paper_physics",
    "plugin_library", "simulate", "simulation_of", "sphere_physics",
]
