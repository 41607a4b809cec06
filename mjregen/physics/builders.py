"""What each physics pipeline does to a model and to its simulation, behind one interface.

`builder_for(pipeline)` chooses the builder once, from the pipeline's type; `compile_robot` and
`Simulation` call it and never branch on the pipeline's name:

- `VoxelBuilder` (`VoxelPipeline`): the voxel plugin computes every force and drives the
  muscles; the plugin's native stepper advances the state where the pipeline's ``stepper``
  allows.
- `MujocoBuilder` (`MujocoPipeline`): MuJoCo's tendons and contacts; Python drives the muscle
  tendons (`MuscleTendons`); ``mj_step`` advances the state.
"""

from __future__ import annotations

import mujoco

from mjregen.errors import CompileError, PhysicsParameterError
from mjregen.physics import mjcf, voxel_plugin
from mjregen.physics.model import RobotBonds, RobotLayout
from mjregen.physics.params import Physics
from mjregen.physics.pipelines import MujocoPipeline, VoxelPipeline
from mjregen.physics.stepper import NativeStepper, unsupported_on


class VoxelBuilder:
    """The voxel plugin's part of a model (one ``mjregen.voxels`` instance, id 0) and its
    stepper."""

    plugin_instance: int | None = 0
    drives_muscle_tendons = False  # the plugin drives the muscles itself

    def add_forces(self, spec: mujoco.MjSpec, bodies: list, layout: RobotLayout,
                   physics: Physics, bonds: RobotBonds, drive: str) -> None:
        """Add the plugin instance that computes every force (`mjcf.add_voxel_plugin`)."""
        voxel_plugin.library()  # registers the plugin with MuJoCo
        mjcf.add_voxel_plugin(spec, layout, physics, bonds, drive)

    def rates_model(self, model: mujoco.MjModel, layout: RobotLayout, physics: Physics,
                    bonds: RobotBonds) -> tuple[mujoco.MjModel, Physics]:
        """The model (and its physics) whose plugin forces give the network rule's rates:
        this one."""
        return model, physics

    def stepper(self, model: mujoco.MjModel, data: mujoco.MjData, physics: Physics,
                plugin_instance: int | None) -> NativeStepper | None:
        """The `NativeStepper` of the plugin instance `plugin_instance` (None: the model has
        none) that the pipeline's ``stepper`` asks for, or None (``mj_step``)."""
        choice = physics.pipeline.stepper
        if choice == "mujoco":
            return None
        reason = ("the model has no voxel plugin" if plugin_instance is None
                  else unsupported_on(model, data, plugin_instance))
        if not reason:
            return NativeStepper(model, data, instance=plugin_instance, checked=True)
        if choice == "native":
            raise PhysicsParameterError(f"stepper 'native' cannot step this model: {reason}")
        return None


class MujocoBuilder:
    """MuJoCo's own part of a model: bond tendons, contacts, viscosity; no plugin."""

    plugin_instance: int | None = None
    drives_muscle_tendons = True  # `Simulation` rewrites the muscle tendons' rest lengths

    def add_forces(self, spec: mujoco.MjSpec, bodies: list, layout: RobotLayout,
                   physics: Physics, bonds: RobotBonds, drive: str) -> None:
        """Add the bond tendons and contacts (`mjcf.add_mujoco_bonds`)."""
        if drive == "ctrl":
            raise CompileError("drive 'ctrl' needs the voxel pipeline")
        mjcf.add_mujoco_bonds(spec, bodies, layout, physics, bonds.tendons)

    def rates_model(self, model: mujoco.MjModel, layout: RobotLayout, physics: Physics,
                    bonds: RobotBonds) -> tuple[mujoco.MjModel, Physics]:
        """The same robot's plugin model with its tendons, floor off (MuJoCo's contacts are
        not the engine floor), and its physics: its plugin forces give the network rule's
        rates."""
        if not voxel_plugin.available():
            raise PhysicsParameterError(
                "timestep_rule 'network' computes the step from the voxel plugin's bond "
                "forces, whose library needs a C compiler; use timestep_rule 'stiffest_bond' "
                "(sphere_physics() and box_physics() do)")
        physics = physics.replace(pipeline=VoxelPipeline(
            bond_element="tendons", bond_model=physics.pipeline.bond_model,
            collision_radius=0.0), floor=False)
        spec, _ = mjcf.voxel_bodies(layout, physics)
        mjcf.add_voxel_plugin(spec, layout, physics, bonds, "waveform")
        return spec.compile(), physics

    def stepper(self, model: mujoco.MjModel, data: mujoco.MjData, physics: Physics,
                plugin_instance: int | None) -> NativeStepper | None:
        """None: ``mj_step`` steps MuJoCo's own forces."""
        return None


BUILDERS = {VoxelPipeline: VoxelBuilder(), MujocoPipeline: MujocoBuilder()}


def builder_for(pipeline: VoxelPipeline | MujocoPipeline) -> VoxelBuilder | MujocoBuilder:
    """The builder of `pipeline`'s type."""
    return BUILDERS[type(pipeline)]
