"""Physical parameters in SI units: materials, the scene, and the two pipelines.

Defaults follow the paper's code (Voxelyze settings): 1 mm voxels of 1 g, E = 1e7 Pa (soft
and muscle) or 5e7 Pa (hard), Poisson ratio 0.35, gravity 27.468 m/s² downwards, 40 Hz
actuation with ±14 % linear strain, contract-only; and the paper engine's own laws (evosoro's
Voxelyze; docs/fidelity.md): its floor (static/kinetic friction 1.0/0.5), its shear-rigid
beam element and dampers (bond damping ratio 0.5), its self-collision and its drag (ζ 0.001,
ten times it on rotations). The default *is* `mjregen.physics.presets.paper_physics()`.

A `Physics` is materials, a `Scene` (what every pipeline shares: the world, the actuation,
the timing, the bonds' damping) and one pipeline with its own parameters:
`VoxelPipeline` (the default: the voxel plugin computes every force inside MuJoCo's step)
or `MujocoPipeline` (MuJoCo tendons and contacts only; no C compiler needed). Everything
here is plain, frozen data validated on construction.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace
from types import MappingProxyType
from typing import ClassVar, Mapping

from mjregen.errors import PhysicsParameterError
from mjregen.grid import Material
from mjregen.physics.migrate import PHYSICS_FORMAT, migrate_physics

WAVEFORMS = ("contract", "symmetric")
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
PAPER_TIMES = {3: (0.05, 0.5), 2: (1.0, 0.25)}  # (settle, measured) s


def _check(name: str, value: float, *, low: float, high: float = math.inf,
           low_open: bool = True, high_open: bool = False) -> None:
    """Raise PhysicsParameterError unless `value` is a finite real number in the range."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PhysicsParameterError(f"{name} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise PhysicsParameterError(f"{name} must be finite, got {value!r}")
    too_low = value <= low if low_open else value < low
    too_high = value >= high if high_open else value > high
    if too_low or too_high:
        left = "(" if low_open else "["
        right = ")" if high_open else "]"
        raise PhysicsParameterError(
            f"{name} = {value!r} is outside its valid range {left}{low}, {high}{right}"
        )


@dataclass(frozen=True)
class MaterialProperties:
    """Bulk properties of one voxel material.

    Attributes:
      youngs_modulus: E in Pa (> 0).
      density: kg/m³ (> 0); a voxel's mass is density × voxel_size³.
      poisson_ratio: ν in [0, 0.5); sets the shear modulus G = E / (2 (1 + ν)).
      friction: Coulomb coefficient against the floor (>= 0): the voxel pipeline's static
        coefficient (the engine's 1.0), the pure-MuJoCo pipeline's only one.
      kinetic_friction: the voxel pipeline's sliding coefficient (the paper engine's 0.5);
        None = `friction`. The pure-MuJoCo pipeline uses `friction` only (MuJoCo has one).
      strain_amplitude: muscle linear strain amplitude (0 = passive, < 1); the voxel's
        linear scale is 1 + amplitude × phase_sign × sin(2π f t) (clamped, see `Scene`).
      phase_sign: +1, −1 (counter-phase) or 0 (passive).
    """

    youngs_modulus: float
    density: float = 1e6
    poisson_ratio: float = 0.35
    friction: float = 1.0
    kinetic_friction: float | None = 0.5
    strain_amplitude: float = 0.0
    phase_sign: int = 0

    def __post_init__(self) -> None:
        _check("youngs_modulus", self.youngs_modulus, low=0.0)
        _check("density", self.density, low=0.0)
        _check("poisson_ratio", self.poisson_ratio, low=0.0, high=0.5, low_open=False,
               high_open=True)
        _check("friction", self.friction, low=0.0, low_open=False)
        if self.kinetic_friction is not None:
            _check("kinetic_friction", self.kinetic_friction, low=0.0, low_open=False)
            if self.kinetic_friction > self.friction:
                raise PhysicsParameterError(
                    f"kinetic_friction {self.kinetic_friction} exceeds friction (the static "
                    f"coefficient) {self.friction}; set both, kinetic <= static")
        _check("strain_amplitude", self.strain_amplitude, low=0.0, high=1.0, low_open=False,
               high_open=True)
        if self.phase_sign not in (-1, 0, 1) or isinstance(self.phase_sign, bool):
            raise PhysicsParameterError(f"phase_sign must be -1, 0 or +1, got {self.phase_sign!r}")
        if (self.strain_amplitude > 0) != (self.phase_sign != 0):
            raise PhysicsParameterError(
                "a muscle needs both strain_amplitude > 0 and phase_sign ±1; a passive "
                f"material needs both 0 (got amplitude {self.strain_amplitude}, sign "
                f"{self.phase_sign})"
            )

    @property
    def shear_modulus(self) -> float:
        """G = E / (2 (1 + ν)) in Pa."""
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def is_muscle(self) -> bool:
        return self.phase_sign != 0


def paper_materials() -> Mapping[Material, MaterialProperties]:
    """The paper's materials: soft and muscles 1e7 Pa, hard 5e7 Pa, muscles ±14 %."""
    return MappingProxyType({
        Material.SOFT: MaterialProperties(youngs_modulus=1e7),
        Material.HARD: MaterialProperties(youngs_modulus=5e7),
        Material.MUSCLE_PLUS: MaterialProperties(youngs_modulus=1e7, strain_amplitude=0.14,
                                                 phase_sign=1),
        Material.MUSCLE_MINUS: MaterialProperties(youngs_modulus=1e7, strain_amplitude=0.14,
                                                  phase_sign=-1),
    })


@dataclass(frozen=True)
class Scene:
    """What every pipeline shares: world, actuation, timing, the bonds' damping.

    Attributes:
      voxel_size: edge length L in m.
      gravity: downward acceleration in m/s² (>= 0; 0 switches gravity off).
      frequency: actuation frequency in Hz.
      waveform: "contract" (the paper's build: the scale is clamped at 1, so muscles only
        contract, red in the second half of each period, green in the first) or
        "symmetric" (scale = 1 ± amplitude, unclamped).
      settle_time: s without actuation before the measurement; None = the paper's (3D
        0.05 s, 2D 1.0 s). The muscles start at its end.
      measured_time: s of actuation that the distance counts; None = the paper's (3D 0.5 s,
        2D 0.25 s).
      bond_damping_ratio: ζ of the bonds, relative to one voxel's mass (c = 2 ζ sqrt(m k)
        of a bond's force; the paper engine's BondDampingZ 1 damps with half of it, 0.5).
      drag_ratio: ζ of a drag on every voxel, force −2ζ sqrt(m E_soft L)·v (the paper
        engine's "slow" global damping, ζ = 0.001): MuJoCo's Stokes drag of each voxel's
        inertia box (viscosity), one coefficient for all materials, set from the soft
        modulus. 0 = off.
      floor: whether the floor plane (z = 0) exists.
      timestep_safety: the time step as a fraction of semi-implicit Euler's stability limit
        (the pipeline's `timestep_rule` says which limit); 0.75 keeps a margin for what the
        linear limit leaves out (contacts, large strains).
    """

    voxel_size: float = 1e-3
    gravity: float = 27.468
    frequency: float = 40.0
    waveform: str = "contract"
    settle_time: float | None = None
    measured_time: float | None = None
    bond_damping_ratio: float = 0.5
    drag_ratio: float = 0.001
    floor: bool = True
    timestep_safety: float = 0.75

    def __post_init__(self) -> None:
        _check("voxel_size", self.voxel_size, low=0.0)
        _check("gravity", self.gravity, low=0.0, low_open=False)
        _check("frequency", self.frequency, low=0.0)
        for name in ("settle_time", "measured_time"):
            value = getattr(self, name)
            if value is not None:
                _check(name, value, low=0.0, low_open=False)
        _check("bond_damping_ratio", self.bond_damping_ratio, low=0.0, low_open=False)
        _check("drag_ratio", self.drag_ratio, low=0.0, low_open=False)
        _check("timestep_safety", self.timestep_safety, low=0.0)
        _choice("waveform", self.waveform, WAVEFORMS)
        _flag("floor", self.floor)

    def timing(self, dim: int) -> tuple[float, float]:
        """(settle_time, measured_time) in s for a `dim`-dimensional robot."""
        settle = self.settle_time if self.settle_time is not None else PAPER_TIMES[dim][0]
        measured = self.measured_time if self.measured_time is not None else PAPER_TIMES[dim][1]
        return settle, measured


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
        _choice("bond_element", self.bond_element, BOND_ELEMENTS)
        _choice("beam_law", self.beam_law, BEAM_LAWS)
        _choice("beam_damping", self.beam_damping, BEAM_DAMPINGS)
        _choice("bond_model", self.bond_model, BOND_MODELS)
        _check("floor_stiffness", self.floor_stiffness, low=0.0)
        _check("floor_damping", self.floor_damping, low=0.0, low_open=False)
        _choice("friction_stop", self.friction_stop, FRICTION_STOPS)
        if self.friction_stop_time is not None:
            _check("friction_stop_time", self.friction_stop_time, low=0.0)
        if isinstance(self.collision_hops, bool) or not isinstance(self.collision_hops, int) \
                or self.collision_hops < 0:
            raise PhysicsParameterError(
                f"collision_hops must be an integer >= 0, got {self.collision_hops!r}")
        # face neighbours sit 1 L apart: only the bonds keep them from colliding
        limit = 1.0 if self.collision_hops > 0 else math.sqrt(2.0) / 2
        _check("collision_radius", self.collision_radius, low=0.0, low_open=False,
               high=limit, high_open=True)
        _check("collision_stiffness", self.collision_stiffness, low=0.0)
        _check("collision_damping", self.collision_damping, low=0.0, low_open=False)
        _choice("drag_law", self.drag_law, DRAG_LAWS)
        _choice("timestep_rule", self.timestep_rule, TIMESTEP_RULES)
        _choice("stepper", self.stepper, STEPPERS)


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
        _choice("contact_shape", self.contact_shape, CONTACT_SHAPES)
        _choice("bond_model", self.bond_model, BOND_MODELS)
        if self.contact_stiffness is not None:
            _check("contact_stiffness", self.contact_stiffness, low=0.0)
        _check("contact_damping", self.contact_damping, low=0.0, low_open=False)
        _check("contact_timeconst", self.contact_timeconst, low=0.0)
        _check("contact_dampratio", self.contact_dampratio, low=0.0)
        _check("contact_width", self.contact_width, low=0.0)
        _check("collision_radius", self.collision_radius, low=0.0, low_open=False,
               high=math.sqrt(2.0) / 2, high_open=True)
        _choice("integrator", self.integrator, INTEGRATORS,
                hint=" (MuJoCo's implicit integrators mis-handle damped tendons between free "
                     "bodies)")
        _choice("timestep_rule", self.timestep_rule, TIMESTEP_RULES)


PIPELINES = {VoxelPipeline.name: VoxelPipeline, MujocoPipeline.name: MujocoPipeline}
Pipeline = VoxelPipeline | MujocoPipeline


@dataclass(frozen=True)
class Physics:
    """Materials (one per non-empty `Material` code), the scene and the pipeline."""

    materials: Mapping[Material, MaterialProperties] = field(default_factory=paper_materials)
    scene: Scene = field(default_factory=Scene)
    pipeline: Pipeline = field(default_factory=VoxelPipeline)

    def __post_init__(self) -> None:
        missing = [m.name for m in Material if m != Material.EMPTY and m not in self.materials]
        if missing:
            raise PhysicsParameterError(f"materials missing for {', '.join(missing)}")
        for material, props in self.materials.items():
            if not isinstance(props, MaterialProperties):
                raise PhysicsParameterError(
                    f"materials[{material!r}] must be MaterialProperties, got {type(props)}")
        if not isinstance(self.scene, Scene):
            raise PhysicsParameterError(f"scene must be a Scene, got {type(self.scene)}")
        if not isinstance(self.pipeline, (VoxelPipeline, MujocoPipeline)):
            raise PhysicsParameterError(
                f"pipeline must be VoxelPipeline or MujocoPipeline, got {type(self.pipeline)}")
        object.__setattr__(self, "materials", MappingProxyType(dict(self.materials)))

    def __reduce__(self) -> tuple:
        # The read-only mapping proxy does not pickle; rebuild from a plain dict (workers).
        return (Physics, (dict(self.materials), self.scene, self.pipeline))

    def to_dict(self) -> dict:
        """JSON-ready description: format, materials by lower-case name, scene, pipeline."""
        return {
            "format": PHYSICS_FORMAT,
            "materials": {m.name.lower(): asdict(p) for m, p in sorted(self.materials.items())},
            "scene": asdict(self.scene),
            "pipeline": {"name": self.pipeline.name, **asdict(self.pipeline)},
        }

    @classmethod
    def from_dict(cls, values: dict) -> Physics:
        """Inverse of `to_dict`, for a description of any format (`migrate_physics`),
        validated like any construction."""
        values = migrate_physics(values)
        try:
            materials = {Material[name.upper()]: MaterialProperties(**props)
                         for name, props in values["materials"].items()}
            pipeline = dict(values["pipeline"])
            kind = PIPELINES[pipeline.pop("name")]
            return cls(materials=materials, scene=Scene(**values["scene"]),
                       pipeline=kind(**pipeline))
        except (KeyError, TypeError) as error:
            raise PhysicsParameterError(f"invalid physics description: {error}") from None

    def replace(self, **changes: object) -> Physics:
        """A copy with some fields of the scene or of the pipeline changed (validated).

        ``pipeline="voxel"`` / ``"mujoco"`` (or a pipeline object) switches the pipeline
        first; the other keywords then name `Scene` or pipeline fields.

        Raises:
          PhysicsParameterError: a field neither the scene nor the pipeline has.
        """
        pipeline = changes.pop("pipeline", self.pipeline)
        if isinstance(pipeline, str) and pipeline in PIPELINES:
            pipeline = self.pipeline if pipeline == self.pipeline.name else PIPELINES[pipeline]()
        if not isinstance(pipeline, (VoxelPipeline, MujocoPipeline)):
            raise PhysicsParameterError(
                f"pipeline must be one of {tuple(PIPELINES)} or a VoxelPipeline or "
                f"MujocoPipeline, got {pipeline!r}")
        scene_fields = {f.name for f in fields(Scene)}
        pipeline_fields = {f.name for f in fields(pipeline)}
        unknown = sorted(set(changes) - scene_fields - pipeline_fields)
        if unknown:
            raise PhysicsParameterError(
                f"{', '.join(unknown)}: not a field of the scene or of the {pipeline.name} "
                f"pipeline (scene: {', '.join(sorted(scene_fields))}; {pipeline.name}: "
                f"{', '.join(sorted(pipeline_fields))})")
        scene = replace(self.scene, **{k: v for k, v in changes.items() if k in scene_fields})
        pipeline = replace(pipeline, **{k: v for k, v in changes.items() if k in pipeline_fields})
        return Physics(materials=self.materials, scene=scene, pipeline=pipeline)

    def voxel_mass(self, material: Material) -> float:
        """Mass of one voxel of `material` in kg."""
        return self.materials[material].density * self.scene.voxel_size ** 3


def _choice(name: str, value: object, allowed: tuple, *, hint: str = "") -> None:
    if value not in allowed:
        raise PhysicsParameterError(f"{name} must be one of {allowed}, got {value!r}{hint}")


def _flag(name: str, value: object) -> None:
    if not isinstance(value, bool):
        raise PhysicsParameterError(f"{name} must be True or False, got {value!r}")


