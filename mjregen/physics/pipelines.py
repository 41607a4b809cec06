"""The two physics pipelines and their own parameters: `VoxelPipeline` (the voxel plugin,
the default) and `MujocoPipeline` (MuJoCo's tendons and contacts only), chosen by name."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from mjregen.errors import PhysicsParameterError
from mjregen.physics.checks import check_choice, check_range

BOND_MODELS = ("timoshenko", "euler_bernoulli")
BOND_ELEMENTS = ("beam", "tendons")
TIMESTEP_RULES = ("network", "stiffest_bond")
STEPPERS = ("auto", "native", "mujoco")
FRICTION_STOPS = ("momentum", "energy")
DRAG_LAWS = ("engine", "stokes")
BEAM_LAWS = ("engine", "tendons")
BEAM_DAMPINGS = ("engine", "stiffness_proportional")
CONTACT_SHAPES = ("box", "sphere", "point")
INTEGRATORS = ("euler", "rk4")
POINT_RADIUS = 1e-6  # contact_shape "point": radius of the centre sphere, in voxel lengths


@dataclass(frozen=True)
class VoxelPipeline:
    """The voxel plugin: the paper engine's physics inside MuJoCo's step (the default).

    The engine plugin ``mjregen.voxels`` computes the bonds, the muscles, the engine's
    floor, self-collision and drag; MuJoCo's own contacts and constraints are off; the
    integrator is MuJoCo's semi-implicit Euler. Needs a C compiler (the plugin is built on
    first use).

    Attributes:
      bond_element: "beam" (one co-rotated beam element per bond in the bond's mid frame,
        like the paper engine's beam; `beam_law`, `beam_damping`) or "tendons" (8 spring
        tendons per 3D bond, 4 in 2D, calibrated to beam theory, stiffness-proportional
        dampers). Beams cost about half the CPU time.
      beam_law: "engine" (the paper engine's beam element: axial force E·L times the
        strain, linear; torsion G·J/L with J = L⁴/6 and G = E/(2(1+ν))) or "tendons"
        (the tendon bundle's axial law, stiffening in tension, and torsion G_b·L³/3 with
        G_b the bond_model's transverse modulus).
      beam_damping: "engine" (the paper engine's: each force row damped with
        c = 2ζ sqrt(m k), each moment row with half of that, ζ the scene's
        bond_damping_ratio, so the rates of the force rows are damped with
        2ζ sqrt(m/(E·L)) per stiffness, of the bending with ζ sqrt(m/(E·L)), of the
        torsion with ζ sqrt(m/(G·L))) or "stiffness_proportional" (C = βK, one
        β = 2ζ sqrt(m/(E·L)) for every row, as the tendons).
      bond_model: "euler_bernoulli" (shear-rigid: transverse stiffness 12EI/L³ = E·L, the
        paper engine's beam) or "timoshenko" (shear stiffness G·L from the Poisson ratio).
      floor_stiffness: the floor's penalty spring per voxel in units of the voxel's E·L (the
        paper engine: 2). A voxel touches when its centre is lower than its current half
        size (L/2, shrinking with its own muscle strain); the normal force acts on the
        centre; static friction (`MaterialProperties.friction`) holds a sticking voxel,
        kinetic friction slows a sliding one, which sticks again when that would stop it
        within a step.
      floor_damping: the floor's damper in units of 2 sqrt(m E L) (the engine's 0.8; it may
        pull, as in the engine).
      friction_stop: when a sliding voxel sticks: "momentum" (the paper engine: when the
        step's friction impulse μ_k N dt reaches its momentum m|v|; a voxel with no
        horizontal velocity at all is at rest) or "energy" (when the step's friction work
        would exceed its kinetic energy).
      friction_stop_time: s, the time t over which the "momentum" rule takes the friction
        impulse μ_k N t: None = the step (the engine's rule, whose threshold speed μ_k N dt/m
        shrinks with the step), or a fixed time: a rule that does not depend on the step
        (the engine's with its own step fixed, e.g. 2.03e-5 s, its step with hard voxels).
      collision_radius: self-collision sphere radius in voxel lengths, at the voxel's
        current size (the paper engine's 0.75: voxels repel from a centre distance of
        1.5 L). 0 = no self-collision.
      collision_stiffness: a colliding pair's spring in units of E·L, E the harmonic mean of
        the two voxels' moduli (the engine's 1: its bond's axial stiffness).
      collision_damping: a colliding pair's damper in units of 2 sqrt(m E L), harmonic mean
        of the two (the engine's 0: undamped).
      collision_hops: voxels within this many bonds of each other never collide (the
        engine's 3); 0: face, edge and corner grid neighbours never collide.
      drag_law: the drag_ratio ζ's law. "engine" (the paper engine's slow damping): each
        voxel −2ζ sqrt(m E L)·v and −2·10ζ sqrt(I E L³)·ω with its own modulus E (hard
        voxels are damped more) and I = m L²/6; "stokes": one coefficient for all, the
        soft voxel's 2ζ sqrt(m E L), and a cube's Stokes rotational drag (L²/3 of it).
      timestep_rule: "network" (the limit of the robot's own linearised bond network and
        floor: exact for the linear network) or "stiffest_bond" (of a block of its
        stiffest bond: the stiffest topology; smaller steps).
      stepper: "auto" (the fast path of ``mj_step``: MuJoCo's Euler step for independent
        voxel bodies in one C loop, the same motion to rounding at about half the CPU time,
        where the model qualifies; else ``mj_step``), "native" (the fast path, or an error)
        or "mujoco" (``mj_step``).
    """

    name: ClassVar[str] = "voxel"
    integrator: ClassVar[str] = "euler"  # semi-implicit Euler, the paper engine's
    holds_at_rest: ClassVar[bool] = True  # the settle can end at rest (`Scene.settle_rest`)
    bond_element: str = "beam"
    beam_law: str = "engine"
    beam_damping: str = "engine"
    bond_model: str = "euler_bernoulli"
    floor_stiffness: float = 2.0
    floor_damping: float = 0.8
    friction_stop: str = "momentum"
    friction_stop_time: float | None = None
    collision_radius: float = 0.75
    collision_stiffness: float = 1.0
    collision_damping: float = 0.0
    collision_hops: int = 3
    drag_law: str = "engine"
    timestep_rule: str = "network"
    stepper: str = "auto"

    def __post_init__(self) -> None:
        check_choice("bond_element", self.bond_element, BOND_ELEMENTS)
        check_choice("beam_law", self.beam_law, BEAM_LAWS)
        check_choice("beam_damping", self.beam_damping, BEAM_DAMPINGS)
        check_choice("bond_model", self.bond_model, BOND_MODELS)
        check_range("floor_stiffness", self.floor_stiffness, low=0.0)
        check_range("floor_damping", self.floor_damping, low=0.0, low_open=False)
        check_choice("friction_stop", self.friction_stop, FRICTION_STOPS)
        if self.friction_stop_time is not None:
            check_range("friction_stop_time", self.friction_stop_time, low=0.0)
        if isinstance(self.collision_hops, bool) or not isinstance(self.collision_hops, int) \
                or self.collision_hops < 0:
            raise PhysicsParameterError(
                f"collision_hops must be an integer >= 0, got {self.collision_hops!r}")
        # face neighbours sit 1 L apart: only the bonds keep them from colliding
        limit = 1.0 if self.collision_hops > 0 else math.sqrt(2.0) / 2
        check_range("collision_radius", self.collision_radius, low=0.0, low_open=False,
               high=limit, high_open=True)
        check_range("collision_stiffness", self.collision_stiffness, low=0.0)
        check_range("collision_damping", self.collision_damping, low=0.0, low_open=False)
        check_choice("drag_law", self.drag_law, DRAG_LAWS)
        check_choice("timestep_rule", self.timestep_rule, TIMESTEP_RULES)
        check_choice("stepper", self.stepper, STEPPERS)


@dataclass(frozen=True)
class MujocoPipeline:
    """Pure MuJoCo: bonds as MuJoCo spatial tendons (8 per 3D bond), MuJoCo's contacts,
    viscosity for the drag; no C compiler needed. The muscles' tendons are the model's first
    ones; `mjregen.physics.simulation.Simulation` rewrites their rest lengths every step.

    Attributes:
      contact_shape: "box" (box–plane contacts, up to 4 corner points per voxel), "sphere"
        (one contact per voxel below its centre, radius L/2) or "point" (one contact at the
        voxel's centre, touching when the centre is lower than L/2, like the paper engine:
        a hidden plane at L/2 and a tiny sphere of radius POINT_RADIUS·L at each centre).
      bond_model: as `VoxelPipeline.bond_model`.
      contact_stiffness: None (the contacts use contact_timeconst / dampratio / width) or
        the contact's spring per voxel in units of its E·L.
      contact_damping: with contact_stiffness, the contact's damper in units of
        2 sqrt(m E L) (MuJoCo's contact cannot pull).
      contact_timeconst: s, MuJoCo solref time constant (without contact_stiffness).
      contact_dampratio: MuJoCo solref damping ratio (without contact_stiffness).
      contact_width: m, MuJoCo solimp width.
      collision_radius: self-collision sphere radius in voxel lengths (MuJoCo spheres between
        voxels that are not grid neighbours); 0 = no self-collision.
      integrator: "euler" (MuJoCo's semi-implicit Euler) or "rk4".
      timestep_rule: "stiffest_bond", or "network" (needs the voxel plugin's library to
        compute the network's limit).
    """

    name: ClassVar[str] = "mujoco"
    holds_at_rest: ClassVar[bool] = False  # it settles for the full settle time
    contact_shape: str = "sphere"
    bond_model: str = "timoshenko"
    contact_stiffness: float | None = 2.0
    contact_damping: float = 1.2
    contact_timeconst: float = 3e-4
    contact_dampratio: float = 1.0
    contact_width: float = 1e-5
    collision_radius: float = 0.0
    integrator: str = "euler"
    timestep_rule: str = "stiffest_bond"

    def __post_init__(self) -> None:
        check_choice("contact_shape", self.contact_shape, CONTACT_SHAPES)
        check_choice("bond_model", self.bond_model, BOND_MODELS)
        if self.contact_stiffness is not None:
            check_range("contact_stiffness", self.contact_stiffness, low=0.0)
        check_range("contact_damping", self.contact_damping, low=0.0, low_open=False)
        check_range("contact_timeconst", self.contact_timeconst, low=0.0)
        check_range("contact_dampratio", self.contact_dampratio, low=0.0)
        check_range("contact_width", self.contact_width, low=0.0)
        check_range("collision_radius", self.collision_radius, low=0.0, low_open=False,
               high=math.sqrt(2.0) / 2, high_open=True)
        check_choice("integrator", self.integrator, INTEGRATORS,
                hint=" (MuJoCo's implicit integrators mis-handle damped tendons between free "
                     "bodies)")
        check_choice("timestep_rule", self.timestep_rule, TIMESTEP_RULES)


PIPELINES = {VoxelPipeline.name: VoxelPipeline, MujocoPipeline.name: MujocoPipeline}
Pipeline = VoxelPipeline | MujocoPipeline
