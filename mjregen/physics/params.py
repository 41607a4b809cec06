"""Physical parameters of materials and of the scene, in SI units; the time-step rule.

Defaults follow the paper's code (Voxelyze settings, see SEED_CODE_FACTS.md): 1 mm voxels of
1 g, E = 1e7 Pa (soft and muscle) or 5e7 Pa (hard), Poisson ratio 0.35, gravity 27.468 m/s²
downwards, 40 Hz actuation with ±14 % linear strain, contract-only; and the modelling choices
that make the paper's robots walk here as in the paper engine (docs/fidelity.md): the
engine's floor (static/kinetic friction 1.0/0.5), shear-rigid beam bonds, self-collision,
bond damping ratio 0.4, drag 0.001. The default *is* `paper_physics()`; `sphere_physics`
and `legacy_physics` are the earlier models, kept for comparison.
The time step is ours: 0.75 of semi-implicit Euler's stability limit for the bond network
(`Physics.timestep`); the paper engine's rule is unstable for these bonds with ζ = 1.

Everything here is plain, frozen data validated on construction; MuJoCo appears only in
`mjregen.compile`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace
from types import MappingProxyType
from typing import Mapping

from mjregen.errors import PhysicsParameterError
from mjregen.grid import Material
from mjregen.physics.migrate import PHYSICS_FORMAT, migrate_physics

WAVEFORMS = ("contract", "symmetric")
INTEGRATORS = ("euler", "rk4")
BOND_MODELS = ("timoshenko", "euler_bernoulli")
CONTACT_SHAPES = ("box", "sphere", "point", "engine")
BOND_ELEMENTS = ("beam", "tendons")
STEPPERS = ("auto", "native", "mujoco")
TIMESTEP_RULES = ("network", "stiffest_bond")
MODE_RATIO = 2.7  # fastest bond-network mode / a Timoshenko bond's sqrt(k/m) (`Physics.timestep`)
POINT_RADIUS = 1e-6  # contact_shape "point": radius of the centre sphere, in voxel lengths


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
      friction: Coulomb coefficient against the floor (>= 0). With contact_shape "engine"
        (the default) the static coefficient (the engine's 1.0) and `kinetic_friction` the
        sliding one; MuJoCo's contact shapes have one coefficient, this one.
      kinetic_friction: sliding coefficient of the "engine" floor (the paper engine's 0.5);
        None = `friction`. Other contact shapes use `friction` only (MuJoCo has one).
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
    """World, actuation, timing and numerical settings.

    Attributes:
      voxel_size: edge length L in m.
      gravity: downward acceleration in m/s² (>= 0; 0 switches gravity off).
      frequency: actuation frequency in Hz.
      waveform: "contract" (the paper's build: the scale is clamped at 1, so muscles only
        contract, red in the second half of each period, green in the first) or
        "symmetric" (scale = 1 ± amplitude, unclamped).
      settle_time: s without actuation before the measurement; None = the paper's (3D
        0.05 s, 2D 1.0 s).
      measured_time: s of actuation that the distance counts; None = the paper's (3D 0.5 s,
        2D 0.25 s).
      bond_damping_ratio: ζ of the bonds, relative to one voxel's mass (the paper's
        convention: c = 2 ζ sqrt(m k)).
      integrator: "euler" (MuJoCo's semi-implicit Euler) or "rk4".
      timestep_safety: fraction of semi-implicit Euler's stability limit of the damped bond
        network that the time step is (`timestep_rule` says which limit); the default 0.75
        keeps a margin for what the linear limit leaves out (contacts, large strains).
      floor: whether the floor plane (z = 0) exists.
      contact_timeconst: s, MuJoCo solref time constant of voxel–floor contacts.
      contact_dampratio: MuJoCo solref damping ratio of voxel–floor contacts.
      contact_width: m, MuJoCo solimp width (penetration over which the contact stiffens).
      bond_model: "timoshenko" (a bond's shear stiffness is G·L from the Poisson ratio, so
        cube-shaped segments add shear compliance to bending) or "euler_bernoulli" (the
        paper engine's beam bond: transverse stiffness 12EI/L³ = E·L, no shear compliance).
      drag_ratio: ζ of a drag on every voxel, force −2ζ sqrt(m E_soft L)·v (the paper
        engine's "slow" global damping, ζ = 0.001); implemented as MuJoCo's viscosity
        (Stokes drag of each voxel's inertia box), so one coefficient for all materials,
        set from the soft/muscle modulus. 0 = off.
      contact_shape: "box" (MuJoCo box–plane contacts, up to 4 corner points per voxel) or
        "sphere" (one contact per voxel below its centre, radius L/2, like the paper engine:
        the normal force acts through the centre whatever the voxel's orientation) or
        "point" (the paper engine's floor: one contact per voxel at its centre, touching
        when the centre is lower than L/2, so the normal force and the friction act on the
        centre and exert no moment; with "sphere" the friction acts at the sphere's bottom,
        so a voxel whose contact sticks can still roll its centre along). "point" uses a
        hidden collision plane at height L/2 (minus POINT_RADIUS·L) and a tiny sphere of
        radius POINT_RADIUS·L at each voxel's centre.
        "engine": the paper engine's floor computed in the native bond loop
        (`mjregen.bonds_native`), no MuJoCo contact at all: a voxel touches when its centre
        is lower than its current half size (L/2, shrinking with its own muscle strain),
        the normal force contact_stiffness·E·L·penetration − damping·v_z acts on the
        centre (no moment; the damper may pull, as in the engine), and friction has two
        regimes: a sticking voxel keeps its place until the other horizontal forces exceed
        `friction`·N (static), a sliding one feels `kinetic_friction`·N and sticks again
        when that would stop it within a step (a sticking voxel whose velocity is set from
        outside, a kick, is released). With it, self-collision (spring and damper of the
        floor's constants, repulsion only) and drag are computed natively as well. Needs the
        native backend (the exported MJCF approximates it with "point" contacts, MuJoCo
        collision spheres and viscosity, the nearest plain MuJoCo has).
      contact_stiffness: None (use contact_timeconst / dampratio / width) or the floor's
        penalty stiffness per voxel in units of the voxel's E·L (the paper engine: 2).
      contact_damping: with contact_stiffness, the floor's damping in units of
        2 sqrt(m E L) of the voxel (the paper engine's collision damping: 0.8).
      self_collision: voxels that are not face, edge or corner neighbours in the grid
        collide with each other as spheres (the paper engine's self-collision).
      collision_radius: radius of the self-collision spheres in voxel lengths (0.5 = the
        voxel's half size; the paper engine's collision envelope is 0.625, so its voxels
        repel from a centre distance of 1.25 L). Face, edge and corner neighbours never
        collide (their spheres overlap at rest).
      bond_element: how a bond's stiffness is built (the same linear stiffness and damping
        either way, to 1e-5): "beam" (the default: one co-rotated beam element per bond,
        linear in shear, bending and torsion in the bond's mid frame like the paper
        engine's beam, along its axis the tendons' law; about half the CPU time per 3D
        evaluation; native backend only; docs/fidelity.md, docs/performance.md) or
        "tendons" (8 spatial tendons per 3D bond, 4 in 2D, geometrically exact; the
        default before issue #8, and the model the exported MJCF always contains).
      stepper: what advances the state each step: "mujoco" (``mj_step``), "native" (MuJoCo's
        Euler step for independent voxel bodies in one C loop, `mjregen.stepping`: the same
        equations with MuJoCo's own mass matrix and gravity, to rounding, about half the
        CPU time of a 3D step; needs the native bond backend and the engine's contacts, so
        that MuJoCo has nothing to do but integrate) or "auto" (the default: native where
        the model qualifies, else ``mj_step``). Descriptions without this field (older runs
        and asset manifests) load as "mujoco", so they replay bit for bit.
      timestep_rule: what `timestep_safety` is a fraction of: "network" (the default: the
        limit of the robot's own bond network, from the largest eigenvalues of its
        linearised stiffness and damping, `mjregen.modes`; exact for the linear network — a
        kicked block runs at 1.0 of it and diverges at 1.02 —, about the old step for
        blocks, 1.5–2.3× longer for the paper's robots; needs the native library) or
        "stiffest_bond" (the limit of a block of the robot's stiffest bond, the stiffest
        topology, `Physics.timestep`; the rule before issue #8, and what descriptions
        without this field load as).
    """

    voxel_size: float = 1e-3
    gravity: float = 27.468
    frequency: float = 40.0
    waveform: str = "contract"
    settle_time: float | None = None
    measured_time: float | None = None
    bond_damping_ratio: float = 0.4
    integrator: str = "euler"
    timestep_safety: float = 0.75
    floor: bool = True
    contact_timeconst: float = 3e-4
    contact_dampratio: float = 1.0
    contact_width: float = 1e-5
    bond_model: str = "euler_bernoulli"
    drag_ratio: float = 0.001
    contact_shape: str = "engine"
    contact_stiffness: float | None = 2.0
    contact_damping: float = 0.8
    self_collision: bool = True
    collision_radius: float = 0.625
    bond_element: str = "beam"
    stepper: str = "auto"
    timestep_rule: str = "network"

    def __post_init__(self) -> None:
        _check("voxel_size", self.voxel_size, low=0.0)
        _check("gravity", self.gravity, low=0.0, low_open=False)
        _check("frequency", self.frequency, low=0.0)
        for name in ("settle_time", "measured_time"):
            value = getattr(self, name)
            if value is not None:
                _check(name, value, low=0.0, low_open=False)
        _check("bond_damping_ratio", self.bond_damping_ratio, low=0.0, low_open=False)
        _check("timestep_safety", self.timestep_safety, low=0.0)
        _check("contact_timeconst", self.contact_timeconst, low=0.0)
        _check("contact_dampratio", self.contact_dampratio, low=0.0)
        _check("contact_width", self.contact_width, low=0.0)
        _check("drag_ratio", self.drag_ratio, low=0.0, low_open=False)
        _check("collision_radius", self.collision_radius, low=0.0, high=math.sqrt(2.0) / 2,
               high_open=True)
        if self.contact_stiffness is not None:
            _check("contact_stiffness", self.contact_stiffness, low=0.0)
        _check("contact_damping", self.contact_damping, low=0.0, low_open=False)
        for name, allowed in (("bond_model", BOND_MODELS), ("contact_shape", CONTACT_SHAPES),
                              ("bond_element", BOND_ELEMENTS), ("stepper", STEPPERS),
                              ("timestep_rule", TIMESTEP_RULES)):
            if getattr(self, name) not in allowed:
                raise PhysicsParameterError(
                    f"{name} must be one of {allowed}, got {getattr(self, name)!r}")
        if self.waveform not in WAVEFORMS:
            raise PhysicsParameterError(
                f"waveform must be one of {WAVEFORMS}, got {self.waveform!r}")
        if self.integrator not in INTEGRATORS:
            raise PhysicsParameterError(
                f"integrator must be one of {INTEGRATORS}, got {self.integrator!r} "
                "(MuJoCo's implicit integrators mis-handle damped tendons between free bodies)")
        if self.contact_shape == "engine":
            if self.integrator != "euler":
                raise PhysicsParameterError(
                    "contact_shape 'engine' is the voxel plugin's floor, stepped with "
                    "MuJoCo's Euler integrator: set integrator 'euler'")
            if self.contact_stiffness is None:
                raise PhysicsParameterError(
                    "contact_shape 'engine' needs contact_stiffness (the engine's floor is a "
                    "penalty spring; the paper's: 2.0 E·L)")
        if self.bond_element == "beam" and self.contact_shape != "engine":
            raise PhysicsParameterError(
                "bond_element 'beam' is computed by the voxel plugin (contact_shape "
                "'engine'); the pure-MuJoCo pipeline's bonds are bond_element 'tendons'")
        if self.stepper == "native" and self.contact_shape != "engine":
            raise PhysicsParameterError(
                "stepper 'native' is the fast path of the voxel plugin's model (contact_shape "
                "'engine'); use stepper 'auto' or 'mujoco'")
        for name in ("floor", "self_collision"):
            if not isinstance(getattr(self, name), bool):
                raise PhysicsParameterError(
                    f"{name} must be True or False, got {getattr(self, name)!r}")

    def timing(self, dim: int) -> tuple[float, float]:
        """(settle_time, measured_time) in s for a `dim`-dimensional robot."""
        settle = self.settle_time if self.settle_time is not None else PAPER_TIMES[dim][0]
        measured = self.measured_time if self.measured_time is not None else PAPER_TIMES[dim][1]
        return settle, measured


PAPER_TIMES = {3: (0.05, 0.5), 2: (1.0, 0.25)}


@dataclass(frozen=True)
class Physics:
    """Materials (one per non-empty `Material` code) and the scene."""

    materials: Mapping[Material, MaterialProperties] = field(default_factory=paper_materials)
    scene: Scene = field(default_factory=Scene)

    def __post_init__(self) -> None:
        missing = [m.name for m in Material if m != Material.EMPTY and m not in self.materials]
        if missing:
            raise PhysicsParameterError(f"materials missing for {', '.join(missing)}")
        for material, props in self.materials.items():
            if not isinstance(props, MaterialProperties):
                raise PhysicsParameterError(
                    f"materials[{material!r}] must be MaterialProperties, got {type(props)}")
        object.__setattr__(self, "materials", MappingProxyType(dict(self.materials)))

    def __reduce__(self) -> tuple:
        # The read-only mapping proxy does not pickle; rebuild from a plain dict (workers).
        return (Physics, (dict(self.materials), self.scene))

    def to_dict(self) -> dict:
        """JSON-ready description: its format, materials by lower-case name, the scene."""
        return {
            "format": PHYSICS_FORMAT,
            "materials": {m.name.lower(): asdict(p) for m, p in sorted(self.materials.items())},
            "scene": asdict(self.scene),
        }

    @classmethod
    def from_dict(cls, values: dict) -> Physics:
        """Inverse of `to_dict`, for a description of any format (`migrate_physics`),
        validated like any construction."""
        values = migrate_physics(values)
        try:
            materials = {Material[name.upper()]: MaterialProperties(**props)
                         for name, props in values["materials"].items()}
            return cls(materials=materials, scene=Scene(**values["scene"]))
        except (KeyError, TypeError) as error:
            raise PhysicsParameterError(f"invalid physics description: {error}") from None

    def replace_scene(self, **changes: object) -> Physics:
        """A copy with some `Scene` fields changed (validated)."""
        values = {f.name: getattr(self.scene, f.name) for f in fields(Scene)}
        values.update(changes)
        return Physics(materials=self.materials, scene=Scene(**values))

    def voxel_mass(self, material: Material) -> float:
        """Mass of one voxel of `material` in kg."""
        return self.materials[material].density * self.scene.voxel_size ** 3

    def timestep(self, stiffness_per_mass: float) -> float:
        """Time step in s for the stiffest bond present (`Scene.timestep_rule`
        "stiffest_bond", and robots without bonds): `timestep_safety` × the stability limit
        of semi-implicit Euler for the fastest mode of a block of that bond.

        A bond of stiffness k between voxels of mass m has frequency ω_b = sqrt(k/m)
        (`stiffness_per_mass` = k/m in s⁻², the largest over the robot's bonds). The network's
        fastest mode is ω = r·ω_b, and stiffness-proportional damping (c = 2ζ sqrt(mk)) gives
        it the damping ratio ζ·r. Semi-implicit Euler on x'' + 2ζr·ω x' + ω² x = 0 is stable
        iff dt·ω < 2 (sqrt(1 + (ζr)²) − ζr), so

            dt = safety × 2 (sqrt(1 + (ζr)²) − ζr) / (r ω_b).

        r = MODE_RATIO (2.7) for Timoshenko bonds, measured from where 4³ and 5³ blocks
        (interior voxels with 6 bonds: the stiffest topology) diverge at ζ = 1 and 2; shear-
        rigid bonds ("euler_bernoulli") have diagonals 2(1+ν) times stiffer, so r grows by
        sqrt(2(1+ν)) (measured: 4.4 from the limit at ζ = 0.4; predicted 4.44). The paper
        engine's rule, 0.9/(2π ω_b), ignores damping and the network; with ζ = 1 it diverges
        here (docs/accuracy.md).
        """
        _check("stiffness_per_mass", stiffness_per_mass, low=0.0)
        ratio = MODE_RATIO
        if self.scene.bond_model == "euler_bernoulli":
            poisson = max(p.poisson_ratio for p in self.materials.values())
            ratio *= math.sqrt(2.0 * (1.0 + poisson))
        damped = self.scene.bond_damping_ratio * ratio
        limit = 2.0 * (math.sqrt(1.0 + damped * damped) - damped) / ratio
        return self.scene.timestep_safety * limit / math.sqrt(stiffness_per_mass)


def paper_physics() -> Physics:
    """The paper's engine (Voxelyze, evosoro build) as closely as this MuJoCo model allows.

    Measured on its reference cases (docs/fidelity.md):
    - floor: the engine's own ("engine" contact shape, computed in the native loop): a
      penalty spring 2·E·L and damper 0.8·2 sqrt(m E L) on each voxel's centre below its
      current half size, static friction 1.0 with a stick state, kinetic friction 0.5;
    - bonds: shear-rigid beams ("euler_bernoulli"), the engine's beam element (transverse
      stiffness E·L = 12EI/L³); with Timoshenko bonds the multiped's legs sag and it walks
      a fifth as far; one beam element per bond ("beam", issue #8: as close to the engine
      as the tendon bundle, half the CPU time);
    - self-collision on, spheres of radius 0.625 L (the engine's collision envelope);
    - bond damping ratio 0.4: the engine damps half the relative velocity of a bond
      (ζ = 1 there ≈ 0.5 here); 0.4 reproduces the 3×3×3 block's rebound (restitution 0.35);
    - the engine's "slow" drag, ζ = 0.001.
    """
    materials = {m: replace(p, friction=1.0, kinetic_friction=0.5)
                 for m, p in paper_materials().items()}
    return Physics(materials=materials, scene=Scene(
        contact_shape="engine", contact_stiffness=2.0, contact_damping=0.8,
        bond_model="euler_bernoulli", self_collision=True, collision_radius=0.625,
        bond_damping_ratio=0.4, drag_ratio=0.001, bond_element="beam"))


def sphere_physics() -> Physics:
    """The first `paper_physics` (before the engine floor): MuJoCo sphere contacts (one per
    voxel, spring 2·E·L, damping 1.2 because MuJoCo's contact cannot pull), friction 1.0,
    Timoshenko tendon bonds, ζ 0.4, drag 0.001, no self-collision, the stiffest-bond time
    step; works with the tendon backend (no C compiler needed)."""
    materials = {m: replace(p, friction=1.0) for m, p in paper_materials().items()}
    return Physics(materials=materials, scene=Scene(
        contact_shape="sphere", contact_stiffness=2.0, contact_damping=1.2,
        bond_model="timoshenko", self_collision=False, bond_damping_ratio=0.4,
        drag_ratio=0.001, bond_element="tendons", timestep_rule="stiffest_bond"))


def legacy_physics() -> Physics:
    """The physics before the fidelity study (issue #10): box contacts solref (0.3 ms, 1),
    friction 0.5, bond damping ratio 1, no drag, no self-collision, tendon bonds, the
    stiffest-bond time step."""
    materials = {m: replace(p, friction=0.5) for m, p in paper_materials().items()}
    return Physics(materials=materials, scene=Scene(
        contact_shape="box", contact_stiffness=None, bond_model="timoshenko",
        bond_damping_ratio=1.0, drag_ratio=0.0, self_collision=False, bond_element="tendons",
        timestep_rule="stiffest_bond"))
