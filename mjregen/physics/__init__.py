"""The physics of a voxel robot: parameters and presets, the one MuJoCo model, simulation.

Modules, the data flowing one way: `checks`, `pipelines`, `params` and `presets` (plain
data) -> `model` (grid to arrays, no MuJoCo; the tendon bundle in `tendons`, MJCF's
rounding in `rounding`) -> `mjcf` (the `MjSpec`: bodies and the voxel plugin, or MuJoCo's
tendons and contacts) -> `timestep` (decided once) -> `compile` (`compile_robot`) ->
`stepper` (the native stepper: the C fast path of ``mj_step``) and `simulation`
(`simulate`, the stability guard, `Result`). `voxel_plugin` builds and loads the plugin's
library (`plugin/`, C). The cases recorded from the paper's engine are re-run by
`mjregen.validation.reference`.
"""

from mjregen.errors import PhysicsParameterError
from mjregen.physics.compile import CompiledRobot, compile_robot
from mjregen.physics.migrate import PHYSICS_FORMAT, migrate_physics
from mjregen.physics.params import (
    PAPER_TIMES,
    WAVEFORMS,
    MaterialProperties,
    Physics,
    Scene,
    paper_materials,
)
from mjregen.physics.pipelines import (
    BOND_ELEMENTS,
    BOND_MODELS,
    CONTACT_SHAPES,
    INTEGRATORS,
    PIPELINES,
    POINT_RADIUS,
    STEPPERS,
    TIMESTEP_RULES,
    MujocoPipeline,
    VoxelPipeline,
)
from mjregen.physics.presets import box_physics, paper_physics, sphere_physics
from mjregen.physics.simulation import Result, Simulation, simulate, simulation_of
from mjregen.physics.voxel_plugin import NativeBuildError, plugin_library

__all__ = [
    "BOND_ELEMENTS", "BOND_MODELS", "CONTACT_SHAPES", "INTEGRATORS", "PAPER_TIMES",
    "PHYSICS_FORMAT", "PIPELINES", "POINT_RADIUS", "STEPPERS", "TIMESTEP_RULES", "WAVEFORMS",
    "CompiledRobot", "MaterialProperties", "MujocoPipeline", "NativeBuildError", "Physics",
    "PhysicsParameterError", "Result", "Scene", "Simulation", "VoxelPipeline",
    "compile_robot", "box_physics", "migrate_physics", "paper_materials", "paper_physics",
    "plugin_library", "simulate", "simulation_of", "sphere_physics",
]
