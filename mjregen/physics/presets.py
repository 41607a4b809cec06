"""Named physics: the paper engine's (the default) and two pure-MuJoCo models."""

from __future__ import annotations

from dataclasses import replace

from mjregen.physics.params import Physics, Scene, paper_materials
from mjregen.physics.pipelines import MujocoPipeline, VoxelPipeline


def paper_physics() -> Physics:
    """The paper's engine (evosoro's Voxelyze) as closely as MuJoCo allows: the voxel
    pipeline with its defaults, `Physics()`, each law the engine's own (docs/fidelity.md):
    - floor: a penalty spring 2·E·L and damper 0.8·2 sqrt(m E L) on each voxel's centre
      below its current half size, static friction 1.0 from rest, kinetic friction 0.5
      until the step's friction impulse would stop the voxel;
    - bonds: the engine's beam element, one per bond: shear-rigid ("euler_bernoulli",
      transverse stiffness E·L = 12EI/L³), a linear axial spring E·L, torsion G·J/L; its
      damping, ζ 0.5 on the force rows and half of it on the moments (the engine's
      BondDampingZ 1, which it halves);
    - self-collision: surface voxels more than 3 bonds apart repel as spheres of diameter
      1.5 L with an undamped spring E·L;
    - the engine's "slow" drag ζ = 0.001 on each voxel with its own modulus, and ten times
      it on each voxel's rotation.
    """
    materials = {m: replace(p, friction=1.0, kinetic_friction=0.5)
                 for m, p in paper_materials().items()}
    return Physics(materials=materials, scene=Scene(bond_damping_ratio=0.5, drag_ratio=0.001),
                   pipeline=VoxelPipeline())


def sphere_physics() -> Physics:
    """Pure MuJoCo, no C compiler: sphere contacts (one per voxel, spring 2·E·L, damping
    1.2 because MuJoCo's contact cannot pull), friction 1.0, Timoshenko tendon bonds, ζ 0.4,
    drag 0.001, no self-collision, the stiffest-bond time step (docs/fidelity.md: 0.28–0.64
    of the engine's distances)."""
    materials = {m: replace(p, friction=1.0) for m, p in paper_materials().items()}
    return Physics(materials=materials, scene=Scene(bond_damping_ratio=0.4, drag_ratio=0.001),
                   pipeline=MujocoPipeline(contact_shape="sphere", contact_stiffness=2.0,
                                           contact_damping=1.2))


def box_physics() -> Physics:
    """Pure MuJoCo with box contacts of solref (0.3 ms, 1), friction 0.5, bond damping ratio
    1, no drag, no self-collision, Timoshenko tendon bonds, the stiffest-bond time step."""
    materials = {m: replace(p, friction=0.5) for m, p in paper_materials().items()}
    return Physics(materials=materials, scene=Scene(bond_damping_ratio=1.0, drag_ratio=0.0),
                   pipeline=MujocoPipeline(contact_shape="box", contact_stiffness=None))
