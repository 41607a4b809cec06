"""Robot grid + physics -> MuJoCo model (`MjSpec` -> `MjModel`), and MJCF export.

Model, one code path for 2D and 3D:

- Every voxel is a body with a box geom of edge L and mass density·L³ (cube inertia). In 3D it
  has a free joint; in 2D it moves in the x–z plane (slide x, slide z, hinge y). Clamped
  voxels get no joint (welded to the world). The robot starts with its lowest voxel's bottom
  face at z = `elevation` and its centre of mass at x = y = 0.
- Each pair of face neighbours is bonded by spatial tendons between sites fixed in the two
  bodies, from one voxel centre's cross-section to the other's (length ≈ L, never zero).
  For a bond along axis x with lateral axes P (one in 2D, two in 3D):

  * diagonals: for each lateral axis q and each offset ±a along the other lateral axes
    (none in 2D), a crossed pair from −b to +b along q (and +b to −b), each of stiffness
    k_d; they carry shear and, in 3D, bending;
  * axial tendons at all lateral offsets (±a, ±a) with total stiffness k_ax (2D only).

  Linearised, with s, c the sine and cosine of a diagonal's angle to the bond axis, the bond
  has axial stiffness k_ax + n·2ⁿ k_d c², shear stiffness 2ⁿ k_d s² and bending stiffness
  k_ax a² (2D) or 4 k_d c² a² (3D), n = number of lateral axes. Beam theory asks for E·A/L =
  E·L, G·A/L = G·L and E·I/L = E·L³/12. Choosing b = L·sqrt(G/2E) = L / (2 sqrt(1+ν)) makes
  the 3D bond exact with k_ax = 0 (8 tendons), and the same b with a = L/√6 makes the 2D
  bond exact with k_ax = E·L/2 (2 axial + 2 diagonal tendons). E and G of a bond are the
  two voxels' half-lengths in series (2 E₁E₂/(E₁+E₂)); so every material of a robot must
  share one Poisson ratio.
- Bond damping is stiffness-proportional: each tendon's damping = its stiffness ×
  2ζ sqrt(m/k_bond) with m the mean voxel mass, i.e. c = 2ζ sqrt(m k) axially (the paper
  engine's convention).
- Muscles: a bond's axial rest length is L·(s₁+s₂)/2 with sᵢ the voxels' linear scales;
  each tendon of the bond gets the rest length sqrt((L s̄)² + d²), d its fixed lateral
  extent, so the bond is unstressed at centre distance L s̄ (scaling the whole tendon
  length would over-contract bonds whose diagonals cannot shrink sideways). The tendons
  of bonds touching a muscle come first in the model; `simulate` rewrites their
  `tendon_lengthspring` every step (`MuscleTendons`). The geom boxes keep size L.
- Contacts: only voxel–floor pairs (all geoms have contype = conaffinity = 0), with the
  scene's solref/solimp set on the pair, so MuJoCo's metre-scale defaults never mix in.
- Bond backends (`Scene.bond_backend`): "tendon" compiles the tendons above into the
  model; "native" compiles the same bodies, joints and contact pairs without sites,
  tendons or actuators (`CompiledRobot.native_model`) and `simulate` adds the very same
  tendon forces (`CompiledRobot.bonds`, values rounded like the MJCF) from one C loop in
  MuJoCo's passive callback (`mjregen.bonds_native`); the tendon spec/model, still what
  `to_xml` exports, is then built on first access.
- The time step is `Scene.timestep_safety` × semi-implicit Euler's stability limit of the
  robot's own bond network (`mjregen.modes`, `Scene.timestep_rule` "network"), or of a
  block of its stiffest bond ("stiffest_bond", `Physics.timestep`, also used for robots
  without bonds: the stiffest voxel's E·L/m).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Iterable, Sequence

import mujoco
import numpy as np

from mjregen.errors import MjregenError
from mjregen.grid import Material, Robot
from mjregen.physics import POINT_RADIUS, Physics, PhysicsParameterError

WORLD_AXES = {2: (0, 2), 3: (0, 1, 2)}  # grid axis -> world axis
FLOOR = "floor"
POINT_FLOOR = "floor_centres"  # contact_shape "point": the plane that voxel centres touch


class CompileError(MjregenError, ValueError):
    """A robot cannot be compiled with the given options (e.g. empty, bad clamp index)."""


@dataclass(frozen=True)
class MuscleTendons:
    """The tendons that muscles drive: model tendons ``0 .. count-1``.

    A tendon's rest length at time t is ``sqrt((L (1 + w_plus e₊(t) + w_minus e₋(t)))² +
    lateral²)``, with e± the signed waveforms of the two muscle phases (see `simulate`).

    Attributes:
      weights: ``(count, 2)`` float, columns (w_plus, w_minus): half the strain amplitude of
        each of the bond's voxels in that phase, summed.
      lateral: ``(count,)`` float, m, the tendon's fixed lateral extent d.
      voxel_size: L in m.
      damping: ``(count,)`` float, N·s/m, the tendons' damping c when the model has one
        actuator per driven tendon (actuator k on tendon k, gain 1) through which
        `Simulation` adds c·dl₀/dt, so the damper acts on d(l − l₀)/dt (scene
        `damp_strain_rate`); None otherwise.
    """

    weights: np.ndarray
    lateral: np.ndarray
    voxel_size: float
    damping: np.ndarray | None = None

    @property
    def count(self) -> int:
        return len(self.lateral)


@dataclass(frozen=True)
class BondTable:
    """Every bond tendon of a robot as arrays (the native bond backend's input).

    Values are the ones the tendon model gets (rounded like MJCF), so both backends compute
    the same forces. Driven tendons (`MuscleTendons`) are rows ``0 .. muscles.count-1``.

    Attributes:
      ends: ``(n, 2)`` int, the voxels (body order) of the tendon's two sites.
      offsets: ``(n, 2, 3)`` float, m, the sites' positions in their voxels' frames.
      stiffness: ``(n,)`` N/m.
      damping: ``(n,)`` N·s/m.
      rest: ``(n,)`` m, the rest length without actuation.
    """

    ends: np.ndarray
    offsets: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    rest: np.ndarray

    @property
    def count(self) -> int:
        return len(self.stiffness)


@dataclass(frozen=True)
class BeamTable:
    """Every face bond of a robot as one beam element (`Scene.bond_element` "beam"), with the
    linear stiffness of the bond's tendons (module docstring), their law along the bond's
    axis, and their damping ratio.

    Bonds touching a muscle are rows ``0 .. len(muscle_weights)-1``; a bond's rest length is
    L (1 + w₊ e₊ + w₋ e₋), as for its tendons.

    Attributes:
      ends: ``(n, 2)`` int, voxels (body order) i and j, j the neighbour of i along +axis.
      axis: ``(n,)`` int, the bond's axis (0, 1, 2 = x, y, z) in the voxels' rest frames.
      stiffness: ``(n, 4)`` float: axial E·L and transverse G·L in N/m, bending E·L³/12 and
        torsion G·L³/3 in N·m/rad (E, G of the bond, as its tendons).
      axial_law: ``(n, 3)`` float, the bond's tendons along its axis: total stiffness of
        the straight tendons k₀ (N/m), of the diagonals k_d (N/m), and the diagonals' lateral
        extent squared D² (m²); the axial force at centre distance l is
        k₀ (l − l₀) + k_d (s − s₀) l / s, s = sqrt(l² + D²), s₀ = sqrt(l₀² + D²), whose slope
        at l₀ = L is stiffness[:, 0]. Stiffening in tension, softening in compression.
      beta: ``(n,)`` s, damping per stiffness 2ζ sqrt(m/(E·L)) (C = beta·K, as the tendons).
      muscle_weights: ``(m, 2)`` float, (w₊, w₋) of the driven bonds.
    """

    ends: np.ndarray
    axis: np.ndarray
    stiffness: np.ndarray
    axial_law: np.ndarray
    beta: np.ndarray
    muscle_weights: np.ndarray

    @property
    def count(self) -> int:
        return len(self.beta)


@dataclass(frozen=True)
class EngineContacts:
    """What the native loop computes besides the bonds with `Scene.contact_shape` "engine":
    the paper engine's floor, its self-collision and its drag (voxels in body order).

    Attributes (``(n_voxels,)`` float unless stated):
      stiffness: N/m, floor penalty spring contact_stiffness·E·L (self-collision: the
        harmonic mean of the two voxels').
      damping: N·s/m, contact_damping·2 sqrt(m E L) (likewise).
      static_friction, kinetic_friction: floor friction coefficients.
      mass: kg.
      half_plus, half_minus: m, L/2 × the voxel's muscle strain amplitude if it is a "+" /
        "−" muscle (its half size is L/2 + half_plus·e₊ + half_minus·e₋), else 0.
      floor: whether the floor exists.
      grid_index: ``(n_voxels, 3)`` int, grid indices (2D: z in the last column).
      surface: ``(n_voxels,)`` bool, voxels that self-collide (a face neighbour missing).
      collision_radius: m, self-collision sphere radius at nominal size; 0 = off.
      drag_linear: N·s/m, drag on each centre (MuJoCo's Stokes drag of a cube, 3π L μ).
      drag_rotational: N·m·s, its rotational part (π L³ μ).
    """

    stiffness: np.ndarray
    damping: np.ndarray
    static_friction: np.ndarray
    kinetic_friction: np.ndarray
    mass: np.ndarray
    half_plus: np.ndarray
    half_minus: np.ndarray
    floor: bool
    grid_index: np.ndarray
    surface: np.ndarray
    collision_radius: float
    drag_linear: float
    drag_rotational: float


def _engine_contacts(physics: Physics, materials: list[Material], masses: np.ndarray,
                  grid_index: np.ndarray, surface: np.ndarray, viscosity: float) -> EngineContacts:
    """`EngineContacts` of voxels with these materials, masses and grid places."""
    scene = physics.scene
    L = scene.voxel_size
    props = [physics.materials[m] for m in materials]
    EL = np.array([p.youngs_modulus * L for p in props])
    amplitude = np.array([0.5 * L * p.strain_amplitude for p in props])
    sign = np.array([p.phase_sign for p in props])
    index3 = np.zeros((len(materials), 3), dtype=np.int32)
    index3[:, 3 - grid_index.shape[1]:] = grid_index
    return EngineContacts(
        stiffness=scene.contact_stiffness * EL,
        damping=scene.contact_damping * 2.0 * np.sqrt(masses * EL),
        static_friction=np.array([p.friction for p in props], dtype=float),
        kinetic_friction=np.array([p.friction if p.kinetic_friction is None
                                   else p.kinetic_friction for p in props], dtype=float),
        mass=np.asarray(masses, dtype=float),
        half_plus=np.where(sign > 0, amplitude, 0.0),
        half_minus=np.where(sign < 0, amplitude, 0.0),
        floor=scene.floor, grid_index=index3, surface=np.asarray(surface, dtype=bool),
        collision_radius=scene.collision_radius * L if scene.self_collision else 0.0,
        drag_linear=3.0 * math.pi * L * viscosity, drag_rotational=math.pi * L**3 * viscosity)


@dataclass(frozen=True)
class CompiledRobot:
    """A robot compiled to MuJoCo.

    Attributes:
      robot, physics: what was compiled.
      spec: the `mujoco.MjSpec` of the tendon model (owns the exported MJCF).
      model: the compiled tendon model `mujoco.MjModel` (bonds as spatial tendons).
      voxel_index: ``(n_voxels, dim)`` int grid indices, in body order.
      body_ids: ``(n_voxels,)`` int MuJoCo body ids of the voxels (same in both models).
      masses: ``(n_voxels,)`` float, kg.
      muscles: the driven tendons, or None when the robot has no muscles.
      n_bonds: number of face bonds.
      bonds: every bond tendon as arrays (`BondTable`).
      beams: every bond as one beam element (`BeamTable`).
      bond_backend: "tendon" or "native", the backend `simulation_of` uses (the scene's
        `bond_backend` resolved).
      native_model: with the native backend, the model that `simulation_of` steps: the same
        bodies, joints and contacts without sites, tendons or actuators (bond forces come
        from `mjregen.bonds_native`); None with the tendon backend.
      engine_contacts: with contact_shape "engine" (native backend), what the native loop computes
        besides the bonds: floor, self-collision, drag (`EngineContacts`); else None.

    With the native backend the tendon `spec` and `model` are built on first access.
    """

    robot: Robot
    physics: Physics
    voxel_index: np.ndarray
    body_ids: np.ndarray
    masses: np.ndarray
    muscles: MuscleTendons | None
    n_bonds: int
    bonds: BondTable
    beams: BeamTable
    bond_backend: str = "tendon"
    native_model: mujoco.MjModel | None = None
    engine_contacts: EngineContacts | None = None
    _tendon: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def spec(self) -> mujoco.MjSpec:
        return self._tendon_model()[0]

    @property
    def model(self) -> mujoco.MjModel:
        return self._tendon_model()[1]

    def _tendon_model(self) -> tuple[mujoco.MjSpec, mujoco.MjModel]:
        if "model" not in self._tendon:
            build = self._tendon.pop("build")
            self._tendon["spec"], self._tendon["model"] = build()
        return self._tendon["spec"], self._tendon["model"]

    @property
    def simulation_model(self) -> mujoco.MjModel:
        """The model `simulation_of` steps: `native_model`, or the tendon `model`."""
        return self.native_model if self.native_model is not None else self.model

    @property
    def native_bonds(self) -> BondTable | BeamTable:
        """What the native loop computes the bonds from: `beams` or `bonds` (tendons), by
        the scene's `bond_element`."""
        return self.beams if self.physics.scene.bond_element == "beam" else self.bonds

    @property
    def timestep(self) -> float:
        return float(self.simulation_model.opt.timestep)

    def to_xml(self) -> str:
        """MJCF text that plain `mujoco.MjModel.from_xml_string` loads into the same model
        (the tendon model, whatever the backend). With contact_shape "engine" its floor is
        MuJoCo "point" contacts with the same stiffness, damping and static friction, the
        nearest plain MuJoCo has (no kinetic friction, no pulling damper)."""
        return self.spec.to_xml()


def resolve_bond_backend(scene) -> str:
    """"tendon" or "native" for a scene's `bond_backend` ("auto": native when the library
    builds here and the integrator is Euler, else tendon; always native for beam bonds and
    the engine floor).

    Raises:
      NativeBuildError: "native" asked for and the library cannot be built.
    """
    if scene.bond_backend == "tendon":
        return "tendon"
    from mjregen import bonds_native

    if (scene.bond_backend == "native" or scene.bond_element == "beam"
            or (scene.contact_shape == "engine" and scene.floor)):
        bonds_native._load()  # beams and the engine floor exist only natively: no fallback
        return "native"
    return "native" if scene.integrator == "euler" and bonds_native.available() else "tendon"


def bond_geometry(poisson_ratio: float, voxel_size: float, *,
                  bond_model: str = "timoshenko") -> tuple[float, float]:
    """(a, b) in m: tendon-site offsets calibrated to beam theory (see module docstring).

    b = L·sqrt(G/2E): G = E/(2(1+ν)) for "timoshenko"; G = E for "euler_bernoulli" (a
    transverse stiffness of E·L = 12EI/L³, the shear-rigid beam of the paper's engine).
    """
    shear_ratio = 1.0 if bond_model == "euler_bernoulli" else 1.0 / (2.0 * (1.0 + poisson_ratio))
    return voxel_size / math.sqrt(6.0), voxel_size * math.sqrt(shear_ratio / 2.0)


def compile_robot(
    robot: Robot,
    *,
    physics: Physics | None = None,
    clamped: Iterable[Sequence[int]] = (),
    elevation: float = 0.0,
    _backend: str | None = None,
    _timestep: float | None = None,
) -> CompiledRobot:
    """Build the MuJoCo model of `robot`.

    Args:
      robot: a non-empty `Robot` (2D or 3D).
      physics: materials and scene; None = the paper's (`Physics()`).
      clamped: grid indices of voxels fixed to the world (no joint), e.g. a cantilever's root.
      elevation: m, height of the lowest voxel's bottom face above the floor (>= 0).
    Raises:
      CompileError: empty robot, a clamped index that is not a voxel, negative elevation.
      PhysicsParameterError: the robot's materials have different Poisson ratios.
      NativeBuildError: the scene asks for bond_backend "native" and it cannot be built.
    """
    physics = Physics() if physics is None else physics
    if not isinstance(robot, Robot):
        raise CompileError(f"compile_robot needs a Robot, got {type(robot).__name__}")
    if robot.is_empty:
        raise CompileError("cannot compile an empty robot (it has no voxels)")
    if not (math.isfinite(elevation) and elevation >= 0.0):
        raise CompileError(f"elevation must be a finite height >= 0 m, got {elevation!r}")
    scene = physics.scene
    dim = robot.dim
    L = scene.voxel_size
    voxels = list(robot.voxels())
    index_of = {index: i for i, (index, _) in enumerate(voxels)}
    clamped_set = {tuple(int(i) for i in c) for c in clamped}
    for c in clamped_set:
        if c not in index_of:
            raise CompileError(f"clamped index {c} is not a voxel of the robot")
    present = {m for _, m in voxels}
    ratios = {physics.materials[m].poisson_ratio for m in present}
    if len(ratios) > 1:
        raise PhysicsParameterError(
            f"the robot's materials have different Poisson ratios {sorted(ratios)}; bond "
            "geometry needs one ratio per robot")
    poisson = ratios.pop()
    backend = _backend or resolve_bond_backend(scene)
    tendons = backend == "tendon"
    a, b = bond_geometry(poisson, L, bond_model=scene.bond_model)

    masses = np.array([physics.voxel_mass(m) for _, m in voxels])
    grid_index = np.array([index for index, _ in voxels])
    centres = np.zeros((len(voxels), 3))
    centres[:, WORLD_AXES[dim]] = (grid_index + 0.5) * L
    centres[:, :2] -= masses @ centres[:, :2] / masses.sum()
    centres[:, 2] += elevation - (centres[:, 2].min() - L / 2)
    centres = np.round(centres, 12)  # to the picometre: no 1e-19 residues of the centring

    spec = mujoco.MjSpec()
    spec.modelname = "mjregen_robot"
    spec.option.gravity = _mjcf([0.0, 0.0, -scene.gravity])
    spec.option.integrator = {"euler": mujoco.mjtIntegrator.mjINT_EULER,
                              "rk4": mujoco.mjtIntegrator.mjINT_RK4}[scene.integrator]
    # "engine" contacts on the native backend: floor, self-collision and drag in the C loop
    engine = scene.contact_shape == "engine" and not tendons
    engine_floor = engine and scene.floor
    viscosity = 0.0
    if scene.drag_ratio > 0.0:
        soft = physics.materials[Material.SOFT]
        mass = physics.voxel_mass(Material.SOFT)
        drag = 2.0 * scene.drag_ratio * math.sqrt(mass * soft.youngs_modulus * L)
        viscosity = _mjcf(drag / (3.0 * math.pi * L))  # Stokes: 3πμd, d = L
        if not engine:
            spec.option.viscosity = viscosity
    point = scene.contact_shape == "point" or (scene.contact_shape == "engine" and tendons)
    floor_geom = FLOOR
    if scene.floor:
        spec.worldbody.add_geom(name=FLOOR, type=mujoco.mjtGeom.mjGEOM_PLANE,
                                size=[0.0, 0.0, L], contype=0, conaffinity=0)
        if point:
            # the engine's floor acts on voxel centres lower than L/2: a hidden plane there
            floor_geom = POINT_FLOOR
            spec.worldbody.add_geom(name=POINT_FLOOR, type=mujoco.mjtGeom.mjGEOM_PLANE,
                                    size=[0.0, 0.0, L], contype=0, conaffinity=0, group=3,
                                    pos=[0.0, 0.0, _mjcf(L / 2 - POINT_RADIUS * L)])
    surface = _surface(grid_index, index_of, dim)
    bodies = []
    for i, ((index, material), centre) in enumerate(zip(voxels, centres)):
        name = "v" + "_".join(str(k) for k in index)
        body = spec.worldbody.add_body(name=name, pos=_mjcf(centre))
        if index not in clamped_set:
            _add_joints(body, dim)
        body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, size=_mjcf([L / 2] * 3),
                      mass=_mjcf(masses[i]), contype=0, conaffinity=0)
        bodies.append(body)
        props = physics.materials[material]
        solref, solimp = _contact_solver(scene, props, masses[i])
        contact_geom = name
        collide = int(scene.self_collision and surface[i] and not engine)
        # contact geoms are massless and hidden (group 3): the box keeps mass, inertia, looks
        if scene.contact_shape == "sphere" or (collide and scene.collision_radius == 0.5):
            # one sphere of radius L/2 serves the floor ("sphere") and self-collision
            contact_geom = "c" + name
            body.add_geom(name=contact_geom, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                          size=_mjcf([L / 2, 0.0, 0.0]), mass=0.0,
                          contype=int(collide and scene.collision_radius == 0.5),
                          conaffinity=int(collide and scene.collision_radius == 0.5),
                          condim=1, group=3, solref=solref, solimp=solimp)
        if collide and scene.collision_radius != 0.5:
            body.add_geom(name="s" + name, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                          size=_mjcf([scene.collision_radius * L, 0.0, 0.0]), mass=0.0,
                          contype=1, conaffinity=1, condim=1, group=3, solref=solref,
                          solimp=solimp)
        if scene.contact_shape == "box":
            contact_geom = name
        elif point:
            contact_geom = "p" + name
            body.add_geom(name=contact_geom, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                          size=_mjcf([POINT_RADIUS * L, 0.0, 0.0]), mass=0.0, contype=0,
                          conaffinity=0, group=3)
        if scene.floor and index not in clamped_set and not engine_floor:
            spec.add_pair(geomname1=floor_geom, geomname2=contact_geom, condim=3,
                          friction=_mjcf([props.friction, props.friction, 0.0, 0.0, 0.0]),
                          solref=solref, solimp=solimp)
    if scene.self_collision and not engine:
        for i, j in _near_pairs(grid_index, index_of):
            spec.add_exclude(bodyname1=bodies[i].name, bodyname2=bodies[j].name)

    bonds = _face_bonds(grid_index, index_of, dim)
    is_muscle = [physics.materials[m].is_muscle for _, m in voxels]
    bonds.sort(key=lambda bond: not (is_muscle[bond[0]] or is_muscle[bond[1]]))
    sites: dict[tuple[int, tuple[float, ...]], str] = {}
    weights, lateral = [], []
    ends, offsets, stiffnesses, dampings, rests = [], [], [], [], []
    beam_stiffness, beam_law, beam_beta, beam_weights = [], [], [], []
    max_k_per_m = 0.0
    bond_kinds: dict[tuple, tuple] = {}
    for i, j, axis in bonds:
        p_i, p_j = physics.materials[voxels[i][1]], physics.materials[voxels[j][1]]
        e_bond = _series(p_i.youngs_modulus, p_j.youngs_modulus)
        g_bond = (e_bond if scene.bond_model == "euler_bernoulli"
                  else _series(p_i.shear_modulus, p_j.shear_modulus))
        k_bond = e_bond * L
        max_k_per_m = max(max_k_per_m, k_bond / min(masses[i], masses[j]))
        damping_per_stiffness = (2.0 * scene.bond_damping_ratio
                                 * math.sqrt(0.5 * (masses[i] + masses[j]) / k_bond))
        bond_weights = [0.0, 0.0]
        for voxel, props in ((i, p_i), (j, p_j)):
            if props.is_muscle:
                bond_weights[0 if props.phase_sign > 0 else 1] += 0.5 * props.strain_amplitude
        beam_stiffness.append((e_bond * L, g_bond * L, e_bond * L**3 / 12.0, g_bond * L**3 / 3.0))
        beam_beta.append(damping_per_stiffness)
        if is_muscle[i] or is_muscle[j]:
            beam_weights.append(bond_weights)
        key = (axis, e_bond, g_bond, damping_per_stiffness)
        if key not in bond_kinds:  # robots have few distinct bonds: build each kind once
            bond_kinds[key] = _bond_tendon_values(axis, dim, L, a, b, e_bond, g_bond,
                                                  damping_per_stiffness)
        law, bond_tendons = bond_kinds[key]
        for offset_i, offset_j, site_i, site_j, k_tendon, c_tendon, rest, extent \
                in bond_tendons:
            if tendons:
                tendon = spec.add_tendon(name=f"t{len(stiffnesses)}")
                tendon.wrap_site(_site(bodies[i], i, offset_i, sites))
                tendon.wrap_site(_site(bodies[j], j, offset_j, sites))
                tendon.stiffness = [k_tendon, 0.0, 0.0]
                tendon.damping = [c_tendon, 0.0, 0.0]
                tendon.springlength = [rest, rest]
            ends.append((i, j))
            offsets.append((site_i, site_j))
            stiffnesses.append(k_tendon)
            dampings.append(c_tendon)
            rests.append(rest)
            if is_muscle[i] or is_muscle[j]:
                weights.append(bond_weights)
                lateral.append(extent)
        beam_law.append(law)
    if not bonds:
        max_k_per_m = max(physics.materials[m].youngs_modulus * L / physics.voxel_mass(m)
                          for m in present)
    rate_drive = bool(weights) and scene.damp_strain_rate
    if rate_drive and tendons:
        for k in range(len(weights)):
            spec.add_actuator(name=f"m{k}", trntype=mujoco.mjtTrn.mjTRN_TENDON, target=f"t{k}",
                              gainprm=[1.0] + [0.0] * 9)
    network_rule = scene.timestep_rule == "network" and bool(bonds) and _timestep is None
    if network_rule and tendons:
        from mjregen import bonds_native

        if not bonds_native.available():
            raise PhysicsParameterError(
                "timestep_rule 'network' computes the step from the native bond forces, which "
                "need a C compiler; use timestep_rule 'stiffest_bond' (sphere_physics() and "
                "legacy_physics() do)")
        # the rule needs the native forces: take the step of the same robot's native build
        _timestep = compile_robot(robot, physics=physics, clamped=clamped_set,
                                  elevation=elevation, _backend="native").timestep
        network_rule = False
    spec.option.timestep = _mjcf(physics.timestep(max_k_per_m)) if _timestep is None \
        else _timestep
    if engine:
        spec.nuserdata = len(voxels)  # the floor's stick flags
        # floor, self-collision and drag are native: MuJoCo has no contact or constraint to
        # find or solve, so skip those stages (bit-identical results, ~15 % less per step)
        spec.option.disableflags |= (mujoco.mjtDisableBit.mjDSBL_CONTACT
                                     | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    model = spec.compile()
    table = BondTable(ends=np.array(ends, dtype=int).reshape(-1, 2),
                      offsets=np.array(offsets, dtype=float).reshape(-1, 2, 3),
                      stiffness=np.array(stiffnesses, dtype=float),
                      damping=np.array(dampings, dtype=float), rest=np.array(rests, dtype=float))
    beams = BeamTable(ends=np.array([(i, j) for i, j, _ in bonds], dtype=int).reshape(-1, 2),
                      axis=np.array([axis for _, _, axis in bonds], dtype=int),
                      stiffness=np.array(beam_stiffness, dtype=float).reshape(-1, 4),
                      axial_law=np.array(beam_law, dtype=float).reshape(-1, 3),
                      beta=np.array(beam_beta, dtype=float),
                      muscle_weights=np.array(beam_weights, dtype=float).reshape(-1, 2))
    muscles = None
    if weights:
        muscles = MuscleTendons(weights=np.array(weights), lateral=np.array(lateral),
                                voxel_size=L,
                                damping=table.damping[: len(weights)].copy() if rate_drive
                                else None)
    body_ids = np.array([model.body(body.name).id for body in bodies])
    contacts = _engine_contacts(physics, [m for _, m in voxels], masses, grid_index, surface,
                                viscosity) if engine else None
    if network_rule:
        from mjregen.modes import network_rates, stable_step, strain_stiffening

        stiffness, damping = network_rates(
            model, beams if scene.bond_element == "beam" else table, voxel_bodies=body_ids,
            dim=dim, muscles=muscles, scene=scene, floor=contacts)
        stiffening = strain_stiffening(beams, scene)
        model.opt.timestep = _mjcf(scene.timestep_safety * stable_step(
            stiffening * stiffness, stiffening * damping))
    lazy: dict = {"spec": spec, "model": model}
    if not tendons:
        timestep = float(model.opt.timestep)

        def build_tendon_model() -> tuple[mujoco.MjSpec, mujoco.MjModel]:
            tendon = compile_robot(robot, physics=physics, clamped=clamped_set,
                                   elevation=elevation, _backend="tendon", _timestep=timestep)
            return tendon.spec, tendon.model
        lazy = {"build": build_tendon_model}
    return CompiledRobot(
        robot=robot, physics=physics, voxel_index=grid_index,
        body_ids=body_ids,
        masses=masses, muscles=muscles, n_bonds=len(bonds), bonds=table, beams=beams,
        bond_backend=backend, native_model=None if tendons else model,
        engine_contacts=contacts,
        _tendon=lazy)


def _mjcf(values: float | Sequence[float] | np.ndarray) -> float | list[float]:
    """`values` rounded to the 6 significant digits that MJCF export writes.

    Every number the model gets passes through here, so the exported XML reproduces the
    compiled model bit for bit.
    """
    if np.ndim(values) == 0:
        return float(f"{float(values):.6g}")
    return [float(f"{float(v):.6g}") for v in values]


def _contact_solver(scene, props, mass: float) -> tuple[list[float], list[float]]:
    """(solref, solimp) of a voxel's contacts.

    Without `contact_stiffness`: the scene's time constant, damping ratio and width. With
    it: MuJoCo's direct form solref = (−k/m, −c/m), a spring k = contact_stiffness·E·L and a
    damper c = contact_damping·2 sqrt(m E L) per contact, with a constant impedance 0.99
    so the contact acts as that spring–damper on the voxel's mass.
    """
    if scene.contact_stiffness is None:
        return (_mjcf([scene.contact_timeconst, scene.contact_dampratio]),
                _mjcf([0.9, 0.95, scene.contact_width, 0.5, 2.0]))
    EL = props.youngs_modulus * scene.voxel_size
    k = scene.contact_stiffness * EL
    c = scene.contact_damping * 2.0 * math.sqrt(mass * EL)
    return _mjcf([-k / mass, -c / mass]), _mjcf([0.99, 0.99, scene.contact_width, 0.5, 2.0])


def _surface(grid_index: np.ndarray, index_of: dict, dim: int) -> np.ndarray:
    """(n_voxels,) bool: the voxel misses at least one face neighbour."""
    out = np.zeros(len(grid_index), dtype=bool)
    for i, index in enumerate(grid_index):
        for grid_axis in range(dim):
            for step in (-1, 1):
                neighbour = list(int(k) for k in index)
                neighbour[grid_axis] += step
                if tuple(neighbour) not in index_of:
                    out[i] = True
    return out


def _near_pairs(grid_index: np.ndarray, index_of: dict) -> list[tuple[int, int]]:
    """(i, j), i < j: voxels that are face, edge or corner neighbours (exempt from
    self-collision: their spheres touch or overlap at rest, and bonds hold them)."""
    pairs = []
    dim = grid_index.shape[1]
    for i, index in enumerate(grid_index):
        for step in itertools.product((-1, 0, 1), repeat=dim):
            if not any(step):
                continue
            j = index_of.get(tuple(int(k) + d for k, d in zip(index, step)))
            if j is not None and i < j:
                pairs.append((i, j))
    return pairs


def _add_joints(body: mujoco.MjsBody, dim: int) -> None:
    """Free joint in 3D; slide x, slide z, hinge y in 2D."""
    if dim == 3:
        body.add_freejoint()
        return
    body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1.0, 0.0, 0.0])
    body.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, 0.0, 1.0])
    body.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 1.0, 0.0])


def _series(x: float, y: float) -> float:
    """Modulus of two equal half-lengths in series: 2xy/(x+y)."""
    return 2.0 * x * y / (x + y)


def _face_bonds(grid_index: np.ndarray, index_of: dict, dim: int) -> list[tuple[int, int, int]]:
    """(i, j, world axis) for each face-neighbour pair, j the +axis neighbour of i."""
    bonds = []
    for i, index in enumerate(grid_index):
        for grid_axis in range(dim):
            neighbour = list(index)
            neighbour[grid_axis] += 1
            j = index_of.get(tuple(int(k) for k in neighbour))
            if j is not None:
                bonds.append((i, j, WORLD_AXES[dim][grid_axis]))
    return bonds


def _bond_tendons(axis: int, dim: int, L: float, a: float, b: float, e_bond: float,
                  g_bond: float) -> list[tuple[tuple[float, ...], tuple[float, ...], float]]:
    """(site offset in voxel i, site offset in voxel j, stiffness N/m) of a bond's tendons.

    Offsets are 3-vectors relative to the voxel centres, perpendicular to `axis`.
    """
    lateral_axes = [w for w in WORLD_AXES[dim] if w != axis]
    n = len(lateral_axes)
    sin2 = 4 * b * b / (L * L + 4 * b * b)
    k_diagonal = g_bond * L / (2 ** n * sin2)
    k_axial_total = e_bond * L * (1.0 - n / 2.0)

    def vector(components: dict[int, float]) -> tuple[float, ...]:
        v = [0.0, 0.0, 0.0]
        for w, value in components.items():
            v[w] = value
        return tuple(v)

    tendons = []
    for q in lateral_axes:
        others = [w for w in lateral_axes if w != q]
        for signs in itertools.product((-1.0, 1.0), repeat=len(others)):
            base = {w: s * a for w, s in zip(others, signs)}
            for direction in (-1.0, 1.0):
                tendons.append((vector({**base, q: -direction * b}),
                                vector({**base, q: direction * b}), k_diagonal))
    if k_axial_total > 0.0:
        for signs in itertools.product((-1.0, 1.0), repeat=n):
            offset = vector({w: s * a for w, s in zip(lateral_axes, signs)})
            tendons.append((offset, offset, k_axial_total / 2 ** n))
    return tendons


def _bond_tendon_values(axis: int, dim: int, L: float, a: float, b: float, e_bond: float,
                        g_bond: float, damping_per_stiffness: float) -> tuple[list, list]:
    """A bond's axial law [k straight N/m, k diagonal N/m, diagonals' lateral extent² m²] and
    its tendons as (offset_i, offset_j, site_i, site_j, k N/m, c N s/m, rest m, extent m),
    site offsets and numbers rounded as the MJCF stores them (`_mjcf`)."""
    law = [0.0, 0.0, 0.0]
    out = []
    for offset_i, offset_j, stiffness in _bond_tendons(axis, dim, L, a, b, e_bond, g_bond):
        lateral2 = float(np.sum(np.subtract(offset_j, offset_i) ** 2))
        law[0 if lateral2 == 0.0 else 1] += stiffness
        law[2] = max(law[2], lateral2)  # the same for all diagonals of a bond
        site_i, site_j = _mjcf(offset_i), _mjcf(offset_j)
        extent = float(np.linalg.norm(np.subtract(site_j, site_i)))
        out.append((offset_i, offset_j, site_i, site_j, _mjcf(stiffness),
                    _mjcf(stiffness * damping_per_stiffness),
                    _mjcf(math.sqrt(L * L + extent * extent)), extent))
    return law, out


def _site(body: mujoco.MjsBody, voxel: int, offset: tuple[float, ...],
          sites: dict[tuple[int, tuple[float, ...]], str]) -> str:
    """Name of the site at `offset` in `body`, added on first use."""
    key = (voxel, tuple(round(x, 15) for x in offset))
    if key not in sites:
        sites[key] = f"s{len(sites)}"
        body.add_site(name=sites[key], pos=_mjcf(offset))
    return sites[key]
