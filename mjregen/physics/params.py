"""Physical parameters in SI units: materials, the scene, and `Physics` (them and a pipeline,
`mjregen.physics.pipelines`).

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

from dataclasses import asdict, dataclass, field, fields, replace
from types import MappingProxyType
from typing import Mapping

from mjregen.errors import PhysicsParameterError
from mjregen.grid import Material
from mjregen.physics.checks import check_choice, check_flag, check_range
from mjregen.physics.migrate import PHYSICS_FORMAT, migrate_physics
from mjregen.physics.pipelines import PIPELINES, MujocoPipeline, Pipeline, VoxelPipeline

WAVEFORMS = ("contract", "symmetric")
PAPER_TIMES = {3: (0.05, 0.5), 2: (1.0, 0.25)}  # (settle, measured) s
DEFAULT_START_SHIFT = 1e-4  # voxel lengths (Scene.start_shift; measured in docs/transfer.md)
MAX_START_SHIFT = 0.1  # voxel lengths: beyond this a start is a deformed robot, not a rounding
# voxel lengths: the smallest shift a start keeps; the model holds each start as a keyframe
# whose positions MJCF writes to 6 significant digits (steps of 1e-5 L for positions 1 to 10
# voxel lengths from the origin), so smaller shifts would mostly be rounded away
MIN_START_SHIFT = 1e-5
REST_WINDOW = 0.005  # s every voxel stays below `Scene.settle_rest` before the settle ends


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
        check_range("youngs_modulus", self.youngs_modulus, low=0.0)
        check_range("density", self.density, low=0.0)
        check_range("poisson_ratio", self.poisson_ratio, low=0.0, high=0.5, low_open=False,
               high_open=True)
        check_range("friction", self.friction, low=0.0, low_open=False)
        if self.kinetic_friction is not None:
            check_range("kinetic_friction", self.kinetic_friction, low=0.0, low_open=False)
            if self.kinetic_friction > self.friction:
                raise PhysicsParameterError(
                    f"kinetic_friction {self.kinetic_friction} exceeds friction (the static "
                    f"coefficient) {self.friction}; set both, kinetic <= static")
        check_range("strain_amplitude", self.strain_amplitude, low=0.0, high=1.0, low_open=False,
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
      start_shift: voxel lengths, standard deviation of the seeded random offset of every
        voxel's position at the start (`mjregen.physics.start_state`): a start with no exact
        symmetry, so that no body balances in an equilibrium only exact arithmetic keeps (a
        one-voxel plate on its edge). 1e-4 (0.1 µm at 1 mm voxels) makes such plates fall as
        in the paper's engine and moves the paper's robots less than their time step does
        (docs/transfer.md); 0 starts every voxel exactly at its grid position; between 0 and
        MIN_START_SHIFT (1e-5) is refused (the keyframe's 6 significant digits would round
        it away).
      settle_rest: 1/s: the settle ends at rest, once every voxel has moved slower than
        this many voxel lengths/s and turned slower than this many rad/s for REST_WINDOW
        (5 ms); the robot is then held still (velocities zero, no force) until the muscles
        start, which the voxel plugin does in the model itself, so plain MuJoCo holds it
        too. Not a same-numbers option: the walk starts from the rest state without its
        residual motion. 0 = the full settle; None = the robot's body decides
        (`mjregen.tasks.bodies.body_physics`: 1e-6 for sheets, else 0). Voxel pipeline only.
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
    start_shift: float = DEFAULT_START_SHIFT
    settle_rest: float | None = None

    def __post_init__(self) -> None:
        check_range("voxel_size", self.voxel_size, low=0.0)
        check_range("gravity", self.gravity, low=0.0, low_open=False)
        check_range("frequency", self.frequency, low=0.0)
        for name in ("settle_time", "measured_time"):
            value = getattr(self, name)
            if value is not None:
                check_range(name, value, low=0.0, low_open=False)
        check_range("bond_damping_ratio", self.bond_damping_ratio, low=0.0, low_open=False)
        check_range("drag_ratio", self.drag_ratio, low=0.0, low_open=False)
        check_range("timestep_safety", self.timestep_safety, low=0.0)
        check_range("start_shift (voxel lengths)", self.start_shift, low=0.0,
                    high=MAX_START_SHIFT, low_open=False, high_open=False)
        if 0.0 < self.start_shift < MIN_START_SHIFT:
            raise PhysicsParameterError(
                f"start_shift {self.start_shift!r} voxel lengths is below {MIN_START_SHIFT:g}: "
                "a start is a keyframe of the model, whose 6 significant digits would round "
                "such a shift away; use 0 (the exact start) or at least that")
        if self.settle_rest is not None:
            check_range("settle_rest (1/s)", self.settle_rest, low=0.0, low_open=False)
        check_choice("waveform", self.waveform, WAVEFORMS)
        check_flag("floor", self.floor)

    @property
    def rest_threshold(self) -> float:
        """1/s: the settle's rest threshold (`settle_rest`), 0 for the full settle."""
        return self.settle_rest or 0.0

    def timing(self, dim: int) -> tuple[float, float]:
        """(settle_time, measured_time) in s for a `dim`-dimensional robot."""
        settle = self.settle_time if self.settle_time is not None else PAPER_TIMES[dim][0]
        measured = self.measured_time if self.measured_time is not None else PAPER_TIMES[dim][1]
        return settle, measured


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
        if self.scene.rest_threshold > 0.0 and not self.pipeline.holds_at_rest:
            raise PhysicsParameterError(
                f"settle_rest {self.scene.settle_rest!r}: the settle's rest is the voxel "
                f"plugin's; the {self.pipeline.name} pipeline settles for the full time (use 0)")
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
