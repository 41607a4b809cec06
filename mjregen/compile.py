"""Robot grid + physics -> one MuJoCo model (`MjSpec` -> `MjModel`): what `simulate` runs and
what `to_xml` exports.

One code path for 2D and 3D. Every voxel is a body ``voxel_<x>_<y>_<z>`` (2D:
``voxel_<x>_<z>``) with a box geom of edge L, mass density·L³ and the material of its voxel
(``soft``, ``hard``, ``muscle_plus``, ``muscle_minus``); in 3D it has a free joint, in 2D it
moves in the x–z plane (slide x, slide z, hinge y). Clamped voxels get no joint (welded to
the world). The robot starts with its lowest voxel's bottom face at z = `elevation` and its
centre of mass at x = y = 0. Face neighbours are bonded. There are two pipelines, chosen by
the scene (`pipeline_of`):

- ``"voxel"`` (``contact_shape="engine"``, the default): the model carries one instance of
  the engine plugin ``mjregen.voxels`` (`mjregen.physics.native`), whose configuration
  holds everything its forces need — the voxels (body names, muscle phases and strains),
  the bonds (voxel pairs, axes, stiffness, damping, muscle weights), the floor, self-
  collision and drag — and which adds them all in MuJoCo's passive stage. The muscles start
  at the end of the settle (``start``) and are in the file: plain MuJoCo with the plugin
  library loaded walks the robot with ``mj_step`` alone. MuJoCo's own contacts and
  constraints are disabled (nothing for them to do).
- ``"mujoco"`` (any other contact shape): pure MuJoCo, no C compiler needed: each bond is
  spatial tendons between sites fixed in the two bodies, contacts are MuJoCo's, and the
  muscles' tendons (the first ``muscles.count``) have their rest lengths rewritten every
  step by `mjregen.simulate.Simulation` (MuJoCo has no built-in time-dependent drive).

Bond mechanics (both pipelines). For a bond along axis x with lateral axes P (one in 2D,
two in 3D), the tendon bundle is:

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
  share one Poisson ratio. The voxel plugin computes either these tendons
  (``bond_element="tendons"``) or one co-rotated beam element per bond with the same linear
  stiffness (``"beam"``, `BeamTable`).
- Bond damping is stiffness-proportional: c = 2ζ sqrt(m k) with m the mean voxel mass (the
  paper engine's convention).
- Muscles: a bond's axial rest length is L·(s₁+s₂)/2 with sᵢ the voxels' linear scales; each
  tendon gets the rest length sqrt((L s̄)² + d²), d its fixed lateral extent. Bonds touching
  a muscle come first. The geom boxes keep size L.
- The time step is `Scene.timestep_safety` × semi-implicit Euler's stability limit of the
  robot's own bond network (`mjregen.modes`, ``timestep_rule="network"``), or of a block of
  its stiffest bond (``"stiffest_bond"``, `Physics.timestep`, also for robots without
  bonds); it is decided here once and stored in the model (``opt.timestep``) only.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import mujoco
import numpy as np

from mjregen import modes
from mjregen.errors import MjregenError
from mjregen.grid import Material, Robot
from mjregen.physics import POINT_RADIUS, Physics, PhysicsParameterError
from mjregen.physics import native

WORLD_AXES = {2: (0, 2), 3: (0, 1, 2)}  # grid axis -> world axis
FLOOR = "floor"
POINT_FLOOR = "floor_centres"  # contact_shape "point": the plane that voxel centres touch
PLUGIN_INSTANCE = "robot"  # the voxel plugin's instance name in the model
MATERIAL_NAMES = {Material.SOFT: "soft", Material.HARD: "hard",
                  Material.MUSCLE_PLUS: "muscle_plus", Material.MUSCLE_MINUS: "muscle_minus"}
MATERIAL_RGBA = {Material.SOFT: (0.0, 0.7, 1.0, 1.0), Material.HARD: (0.0, 0.0, 1.0, 1.0),
                 Material.MUSCLE_PLUS: (1.0, 0.0, 0.0, 1.0),
                 Material.MUSCLE_MINUS: (0.0, 0.8, 0.0, 1.0)}  # the paper's colours
DRIVES = ("waveform", "ctrl")


class CompileError(MjregenError, ValueError):
    """A robot cannot be compiled with the given options (e.g. empty, bad clamp index)."""


def pipeline_of(scene) -> str:
    """"voxel" (the voxel plugin: contact_shape "engine") or "mujoco" (MuJoCo tendons and
    contacts)."""
    return "voxel" if scene.contact_shape == "engine" else "mujoco"


def voxel_name(index: Sequence[int]) -> str:
    """Body name of the voxel at grid `index`: ``voxel_<x>_<y>_<z>`` (2D ``voxel_<x>_<z>``)."""
    return "voxel_" + "_".join(str(int(k)) for k in index)


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
    """

    weights: np.ndarray
    lateral: np.ndarray
    voxel_size: float

    @property
    def count(self) -> int:
        return len(self.lateral)


@dataclass(frozen=True)
class BondTable:
    """Every bond tendon of a robot as arrays (the "mujoco" pipeline's tendons, and the voxel
    plugin's with ``bond_element="tendons"``): the same values, rounded like MJCF, in both.
    Driven tendons (`MuscleTendons`) are rows ``0 .. muscles.count-1``.

    Attributes:
      ends: ``(n, 2)`` int, the voxels (body order) of the tendon's two sites.
      offsets: ``(n, 2, 3)`` float, m, the sites' positions in their voxels' frames.
      stiffness: ``(n,)`` N/m.
      damping: ``(n,)`` N·s/m.
      rest: ``(n,)`` m, the rest length without actuation.
      bond: ``(n,)`` int, the bond (`BeamTable` row) each tendon belongs to.
      lateral: ``(n,)`` m, the tendon's lateral extent d between its sites.
    """

    ends: np.ndarray
    offsets: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    rest: np.ndarray
    bond: np.ndarray
    lateral: np.ndarray

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
class CompiledRobot:
    """A robot compiled to MuJoCo.

    Attributes:
      robot, physics: what was compiled.
      pipeline: "voxel" or "mujoco" (module docstring).
      spec: the `mujoco.MjSpec` the model was compiled from (`to_xml` writes it).
      model: the `mujoco.MjModel` that `simulate` runs.
      voxel_index: ``(n_voxels, dim)`` int grid indices, in body order.
      body_ids: ``(n_voxels,)`` int MuJoCo body ids of the voxels.
      masses: ``(n_voxels,)`` float, kg.
      muscles: the "mujoco" pipeline's driven tendons (`Simulation` rewrites their rest
        lengths), or None (no muscles, or the voxel plugin drives them).
      n_bonds: number of face bonds.
      bonds: every bond tendon as arrays (`BondTable`).
      beams: every bond as one beam element (`BeamTable`).
    """

    robot: Robot
    physics: Physics
    pipeline: str
    spec: mujoco.MjSpec
    model: mujoco.MjModel
    voxel_index: np.ndarray
    body_ids: np.ndarray
    masses: np.ndarray
    muscles: MuscleTendons | None
    n_bonds: int
    bonds: BondTable
    beams: BeamTable

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    @property
    def plugin_instance(self) -> int | None:
        """The voxel plugin's instance id in `model`, or None ("mujoco" pipeline)."""
        return 0 if self.pipeline == "voxel" else None

    def to_xml(self) -> str:
        """MJCF of exactly `model`. With the "voxel" pipeline, loading it needs the plugin
        library: ``mujoco.mj_loadPluginLibrary(str(mjregen.plugin_library()))``."""
        return self.spec.to_xml()


def bond_geometry(poisson_ratio: float, voxel_size: float, *,
                  bond_model: str = "timoshenko") -> tuple[float, float]:
    """(a, b) in m: tendon-site offsets calibrated to beam theory (see module docstring).

    b = L·sqrt(G/2E): G = E/(2(1+ν)) for "timoshenko"; G = E for "euler_bernoulli" (a
    transverse stiffness of E·L = 12EI/L³, the shear-rigid beam of the paper's engine).
    """
    shear_ratio = 1.0 if bond_model == "euler_bernoulli" else 1.0 / (2.0 * (1.0 + poisson_ratio))
    return voxel_size / math.sqrt(6.0), voxel_size * math.sqrt(shear_ratio / 2.0)


@dataclass(frozen=True)
class _Layout:
    """The robot's voxels in body order, before MuJoCo (see `compile_robot`)."""

    dim: int
    voxels: list  # [(grid index tuple, Material)]
    index_of: dict  # grid index -> voxel number
    grid_index: np.ndarray  # (n, dim) int
    masses: np.ndarray  # (n,) kg
    centres: np.ndarray  # (n, 3) m, initial body positions
    surface: np.ndarray  # (n,) bool: a face neighbour is missing
    bonds: list  # [(i, j, world axis)], bonds touching a muscle first
    clamped: set


def _layout(robot: Robot, physics: Physics, clamped: set, elevation: float) -> _Layout:
    L = physics.scene.voxel_size
    dim = robot.dim
    voxels = list(robot.voxels())
    index_of = {index: i for i, (index, _) in enumerate(voxels)}
    for c in clamped:
        if c not in index_of:
            raise CompileError(f"clamped index {c} is not a voxel of the robot")
    masses = np.array([physics.voxel_mass(m) for _, m in voxels])
    grid_index = np.array([index for index, _ in voxels])
    centres = np.zeros((len(voxels), 3))
    centres[:, WORLD_AXES[dim]] = (grid_index + 0.5) * L
    centres[:, :2] -= masses @ centres[:, :2] / masses.sum()
    centres[:, 2] += elevation - (centres[:, 2].min() - L / 2)
    centres = np.round(centres, 12)  # to the picometre: no 1e-19 residues of the centring
    bonds = _face_bonds(grid_index, index_of, dim)
    is_muscle = [physics.materials[m].is_muscle for _, m in voxels]
    bonds.sort(key=lambda bond: not (is_muscle[bond[0]] or is_muscle[bond[1]]))
    return _Layout(dim=dim, voxels=voxels, index_of=index_of, grid_index=grid_index,
                   masses=masses, centres=centres,
                   surface=_surface(grid_index, index_of, dim), bonds=bonds, clamped=clamped)


def _bond_tables(layout: _Layout, physics: Physics, poisson: float
                 ) -> tuple[BondTable, BeamTable, MuscleTendons | None, float]:
    """The bonds as tendons and as beams, the driven tendons, and the largest bond
    stiffness per voxel mass (s⁻², for the stiffest-bond time step)."""
    scene = physics.scene
    L = scene.voxel_size
    a, b = bond_geometry(poisson, L, bond_model=scene.bond_model)
    voxels, masses = layout.voxels, layout.masses
    weights, lateral = [], []
    ends, offsets, stiffnesses, dampings, rests, tendon_bond = [], [], [], [], [], []
    beam_stiffness, beam_law, beam_beta, beam_weights = [], [], [], []
    max_k_per_m = 0.0
    bond_kinds: dict[tuple, tuple] = {}
    for bond, (i, j, axis) in enumerate(layout.bonds):
        p_i, p_j = physics.materials[voxels[i][1]], physics.materials[voxels[j][1]]
        e_bond = _series(p_i.youngs_modulus, p_j.youngs_modulus)
        g_bond = (e_bond if scene.bond_model == "euler_bernoulli"
                  else _series(p_i.shear_modulus, p_j.shear_modulus))
        k_bond = e_bond * L
        max_k_per_m = max(max_k_per_m, k_bond / min(masses[i], masses[j]))
        damping_per_stiffness = (2.0 * scene.bond_damping_ratio
                                 * math.sqrt(0.5 * (masses[i] + masses[j]) / k_bond))
        bond_weights = [0.0, 0.0]
        for props in (p_i, p_j):
            if props.is_muscle:
                bond_weights[0 if props.phase_sign > 0 else 1] += 0.5 * props.strain_amplitude
        driven = p_i.is_muscle or p_j.is_muscle
        beam_stiffness.append((e_bond * L, g_bond * L, e_bond * L**3 / 12.0, g_bond * L**3 / 3.0))
        beam_beta.append(damping_per_stiffness)
        if driven:
            beam_weights.append(bond_weights)
        key = (axis, e_bond, g_bond, damping_per_stiffness)
        if key not in bond_kinds:  # robots have few distinct bonds: build each kind once
            bond_kinds[key] = _bond_tendon_values(axis, layout.dim, L, a, b, e_bond, g_bond,
                                                  damping_per_stiffness)
        law, bond_tendons = bond_kinds[key]
        for _, _, site_i, site_j, k_tendon, c_tendon, rest, extent in bond_tendons:
            ends.append((i, j))
            offsets.append((site_i, site_j))
            stiffnesses.append(k_tendon)
            dampings.append(c_tendon)
            rests.append(rest)
            tendon_bond.append(bond)
            if driven:
                weights.append(bond_weights)
                lateral.append(extent)
        beam_law.append(law)
    if not layout.bonds:
        present = {m for _, m in voxels}
        max_k_per_m = max(physics.materials[m].youngs_modulus * L / physics.voxel_mass(m)
                          for m in present)
    table = BondTable(ends=np.array(ends, dtype=int).reshape(-1, 2),
                      offsets=np.array(offsets, dtype=float).reshape(-1, 2, 3),
                      stiffness=np.array(stiffnesses, dtype=float),
                      damping=np.array(dampings, dtype=float), rest=np.array(rests, dtype=float),
                      bond=np.array(tendon_bond, dtype=int),
                      lateral=np.array([np.linalg.norm(np.subtract(*o)) for o in offsets],
                                       dtype=float))
    beams = BeamTable(ends=np.array([(i, j) for i, j, _ in layout.bonds], dtype=int).reshape(-1, 2),
                      axis=np.array([axis for _, _, axis in layout.bonds], dtype=int),
                      stiffness=np.array(beam_stiffness, dtype=float).reshape(-1, 4),
                      axial_law=np.array(beam_law, dtype=float).reshape(-1, 3),
                      beta=np.array(beam_beta, dtype=float),
                      muscle_weights=np.array(beam_weights, dtype=float).reshape(-1, 2))
    muscles = None
    if weights:
        muscles = MuscleTendons(weights=np.array(weights), lateral=np.array(lateral),
                                voxel_size=L)
    return table, beams, muscles, max_k_per_m


def compile_robot(
    robot: Robot,
    *,
    physics: Physics | None = None,
    clamped: Iterable[Sequence[int]] = (),
    elevation: float = 0.0,
    drive: str = "waveform",
) -> CompiledRobot:
    """Build the MuJoCo model of `robot`.

    Args:
      robot: a non-empty `Robot` (2D or 3D).
      physics: materials and scene; None = the paper's (`Physics()`).
      clamped: grid indices of voxels fixed to the world (no joint), e.g. a cantilever's root.
      elevation: m, height of the lowest voxel's bottom face above the floor (>= 0).
      drive: "waveform" (the muscles follow the scene's waveform from the end of the
        settle) or "ctrl" (voxel pipeline: the strains (e₊, e₋) of the two muscle phases
        are the controls of the actuators ``muscle_plus`` and ``muscle_minus``, which apply
        no force themselves).
    Raises:
      CompileError: empty robot, a clamped index that is not a voxel, negative elevation.
      PhysicsParameterError: the robot's materials have different Poisson ratios.
      NativeBuildError: the voxel pipeline, or the network time step, and the plugin
        library cannot be built.
    """
    physics = Physics() if physics is None else physics
    if not isinstance(robot, Robot):
        raise CompileError(f"compile_robot needs a Robot, got {type(robot).__name__}")
    if robot.is_empty:
        raise CompileError("cannot compile an empty robot (it has no voxels)")
    if not (math.isfinite(elevation) and elevation >= 0.0):
        raise CompileError(f"elevation must be a finite height >= 0 m, got {elevation!r}")
    if drive not in DRIVES:
        raise CompileError(f"drive must be one of {DRIVES}, got {drive!r}")
    scene = physics.scene
    pipeline = pipeline_of(scene)
    if drive == "ctrl" and pipeline != "voxel":
        raise CompileError("drive 'ctrl' needs the voxel pipeline (contact_shape 'engine')")
    clamped_set = {tuple(int(i) for i in c) for c in clamped}
    layout = _layout(robot, physics, clamped_set, elevation)
    ratios = {physics.materials[m].poisson_ratio for _, m in layout.voxels}
    if len(ratios) > 1:
        raise PhysicsParameterError(
            f"the robot's materials have different Poisson ratios {sorted(ratios)}; bond "
            "geometry needs one ratio per robot")
    table, beams, muscles, max_k_per_m = _bond_tables(layout, physics, ratios.pop())
    if pipeline == "voxel" or (scene.timestep_rule == "network" and layout.bonds):
        native.library()  # registers the plugin with MuJoCo
    spec, bodies = _bodies(layout, physics)
    if pipeline == "voxel":
        _add_voxel_plugin(spec, layout, physics, table, beams, drive)
    else:
        _add_mujoco_bonds(spec, bodies, layout, physics, table, muscles)
    spec.option.timestep = _mjcf(physics.timestep(max_k_per_m))
    model = spec.compile()
    if scene.timestep_rule == "network" and layout.bonds:
        network = model
        if pipeline != "voxel":  # the rule needs the plugin's forces: the same robot's
            network_spec, _ = _bodies(layout, physics)
            _add_voxel_plugin(network_spec, layout, physics.replace_scene(
                bond_element="tendons"), table, beams, "waveform")
            network = network_spec.compile()
        floor_k = floor_c = None
        if pipeline == "voxel" and scene.floor:
            floor_k, floor_c = _floor_rates(network, layout, physics)
        stiffness, damping = modes.network_rates(network, voxel_size=scene.voxel_size,
                                                 floor_stiffness=floor_k, floor_damping=floor_c)
        stiffening = modes.strain_stiffening(beams, scene)
        spec.option.timestep = _mjcf(scene.timestep_safety * modes.stable_step(
            stiffening * stiffness, stiffening * damping))
        model.opt.timestep = spec.option.timestep
    body_ids = np.array([model.body(body.name).id for body in bodies])
    return CompiledRobot(
        robot=robot, physics=physics, pipeline=pipeline, spec=spec, model=model,
        voxel_index=layout.grid_index, body_ids=body_ids, masses=layout.masses,
        muscles=muscles if pipeline == "mujoco" else None, n_bonds=len(layout.bonds),
        bonds=table, beams=beams)


def _floor_rates(model: mujoco.MjModel, layout: _Layout, physics: Physics
                 ) -> tuple[np.ndarray, np.ndarray]:
    """``(nv,)`` s⁻², s⁻¹: the engine floor's spring and damper per mass on each moving
    voxel's vertical dof, as if every voxel touched the floor (the most any posture adds)."""
    scene = physics.scene
    L = scene.voxel_size
    k, c = np.zeros(model.nv), np.zeros(model.nv)
    vertical = 2 if layout.dim == 3 else 1
    for voxel, (index, material) in enumerate(layout.voxels):
        body = model.body(voxel_name(index)).id
        if model.body_jntnum[body] == 0:
            continue
        dof = model.jnt_dofadr[model.body_jntadr[body]] + vertical
        mass = layout.masses[voxel]
        EL = physics.materials[material].youngs_modulus * L
        k[dof] = scene.contact_stiffness * EL / mass
        c[dof] = scene.contact_damping * 2.0 * math.sqrt(mass * EL) / mass
    return k, c


def _bodies(layout: _Layout, physics: Physics) -> tuple[mujoco.MjSpec, list]:
    """A spec with options, materials, the floor plane and one body per voxel."""
    scene = physics.scene
    L = scene.voxel_size
    spec = mujoco.MjSpec()
    spec.modelname = "mjregen_robot"
    spec.option.gravity = _mjcf([0.0, 0.0, -scene.gravity])
    spec.option.integrator = {"euler": mujoco.mjtIntegrator.mjINT_EULER,
                              "rk4": mujoco.mjtIntegrator.mjINT_RK4}[scene.integrator]
    for material, name in MATERIAL_NAMES.items():
        spec.add_material(name=name, rgba=list(MATERIAL_RGBA[material]))
    if scene.floor:
        spec.worldbody.add_geom(name=FLOOR, type=mujoco.mjtGeom.mjGEOM_PLANE,
                                size=[0.0, 0.0, L], contype=0, conaffinity=0)
    bodies = []
    for i, ((index, material), centre) in enumerate(zip(layout.voxels, layout.centres)):
        name = voxel_name(index)
        body = spec.worldbody.add_body(name=name, pos=_mjcf(centre))
        if index not in layout.clamped:
            _add_joints(body, layout.dim)
        body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, size=_mjcf([L / 2] * 3),
                      mass=_mjcf(layout.masses[i]), contype=0, conaffinity=0,
                      material=MATERIAL_NAMES[material])
        bodies.append(body)
    return spec, bodies


def _numbers(values: Iterable) -> str:
    """Plugin configuration text: numbers written exactly (shortest round-trip repr)."""
    return " ".join(repr(int(v)) if isinstance(v, (int, np.integer)) else repr(float(v))
                    for v in np.asarray(values).ravel().tolist())


def _add_voxel_plugin(spec: mujoco.MjSpec, layout: _Layout, physics: Physics,
                      table: BondTable, beams: BeamTable, drive: str) -> None:
    """The ``mjregen.voxels`` instance that computes every force (contacts and constraints
    of MuJoCo off), and with drive "ctrl" the two strain actuators."""
    scene = physics.scene
    L = scene.voxel_size
    props = [physics.materials[m] for _, m in layout.voxels]
    EL = np.array([p.youngs_modulus * L for p in props])
    masses = layout.masses
    settle, _ = scene.timing(layout.dim)
    n_bonds = len(layout.bonds)
    weights = np.zeros((n_bonds, 2))
    weights[: len(beams.muscle_weights)] = beams.muscle_weights
    drag = _drag(physics)
    grid3 = np.zeros((len(layout.voxels), 3), dtype=int)
    grid3[:, 3 - layout.dim:] = layout.grid_index
    beam = scene.bond_element == "beam"
    config = {
        "dim": str(layout.dim), "voxel_size": repr(L),
        "voxels": " ".join(voxel_name(index) for index, _ in layout.voxels),
        "frequency": repr(scene.frequency), "start": repr(float(settle)),
        "waveform": scene.waveform, "drive": drive,
        "phase": _numbers([p.phase_sign for p in props]),
        "strain": _numbers([p.strain_amplitude for p in props]),
        "element": "beam" if beam else "tendons",
        "bonds": _numbers(beams.ends), "bond_axis": _numbers(beams.axis),
        "bond_muscle": _numbers(weights),
        "floor": str(int(scene.floor)),
        "floor_stiffness": _numbers(scene.contact_stiffness * EL),
        "floor_damping": _numbers(scene.contact_damping * 2.0 * np.sqrt(masses * EL)),
        "static_friction": _numbers([p.friction for p in props]),
        "kinetic_friction": _numbers([p.friction if p.kinetic_friction is None
                                      else p.kinetic_friction for p in props]),
        "collision_radius": repr(scene.collision_radius * L if scene.self_collision else 0.0),
        "collision_skin": repr(COLLISION_SKIN * L),
        "grid": _numbers(grid3), "collides": _numbers(layout.surface.astype(int)),
        "drag_linear": repr(3.0 * math.pi * L * drag),
        "drag_rotational": repr(math.pi * L**3 * drag),
    }
    if beam:
        config.update(bond_stiffness=_numbers(beams.stiffness),
                      bond_axial_law=_numbers(beams.axial_law), bond_beta=_numbers(beams.beta))
    else:
        config.update(tendon_bond=_numbers(table.bond), tendon_sites=_numbers(table.offsets),
                      tendon_stiffness=_numbers(table.stiffness),
                      tendon_damping=_numbers(table.damping), tendon_rest=_numbers(table.rest),
                      tendon_lateral2=_numbers(table.lateral ** 2))
    unknown = set(config) - set(native.ATTRIBUTES)
    if unknown:
        raise AssertionError(f"voxel plugin attributes unknown to the plugin: {sorted(unknown)}")
    spec.activate_plugin(native.PLUGIN_NAME)
    instance = spec.add_plugin(name=PLUGIN_INSTANCE, plugin_name=native.PLUGIN_NAME, active=True)
    instance.config = config
    if drive == "ctrl":
        spec.worldbody.add_site(name="muscles", size=[L / 10, 0.0, 0.0], group=4)
        for name in ("muscle_plus", "muscle_minus"):
            spec.add_actuator(name=name, trntype=mujoco.mjtTrn.mjTRN_SITE, target="muscles",
                              gainprm=[0.0] * 10, biasprm=[0.0] * 10, ctrllimited=True,
                              ctrlrange=[-1.0, 1.0])
    # the plugin is every force: MuJoCo has no contact or constraint to find or solve
    spec.option.disableflags |= (mujoco.mjtDisableBit.mjDSBL_CONTACT
                                 | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)


def _drag(physics: Physics) -> float:
    """Pa·s: the viscosity whose Stokes drag on a voxel (3πμL) is the scene's drag,
    2·drag_ratio·sqrt(m E L) of a soft voxel (0: none)."""
    scene = physics.scene
    if scene.drag_ratio <= 0.0:
        return 0.0
    L = scene.voxel_size
    soft = physics.materials[Material.SOFT]
    drag = 2.0 * scene.drag_ratio * math.sqrt(physics.voxel_mass(Material.SOFT)
                                              * soft.youngs_modulus * L)
    return _mjcf(drag / (3.0 * math.pi * L))


def _add_mujoco_bonds(spec: mujoco.MjSpec, bodies: list, layout: _Layout, physics: Physics,
                      table: BondTable, muscles: MuscleTendons | None) -> None:
    """Pure MuJoCo: bond tendons with sites, MuJoCo contacts with the floor, collision
    spheres and exclusions for self-collision, viscosity for the drag."""
    scene = physics.scene
    L = scene.voxel_size
    spec.option.viscosity = _drag(physics)
    point = scene.contact_shape == "point"
    floor_geom = FLOOR
    if scene.floor and point:
        # the engine's floor acts on voxel centres lower than L/2: a hidden plane there
        floor_geom = POINT_FLOOR
        spec.worldbody.add_geom(name=POINT_FLOOR, type=mujoco.mjtGeom.mjGEOM_PLANE,
                                size=[0.0, 0.0, L], contype=0, conaffinity=0, group=3,
                                pos=[0.0, 0.0, _mjcf(L / 2 - POINT_RADIUS * L)])
    for i, ((index, material), body) in enumerate(zip(layout.voxels, bodies)):
        name = body.name
        props = physics.materials[material]
        solref, solimp = _contact_solver(scene, props, layout.masses[i])
        contact_geom = name
        collide = int(scene.self_collision and layout.surface[i])
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
        if point:
            contact_geom = "p" + name
            body.add_geom(name=contact_geom, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                          size=_mjcf([POINT_RADIUS * L, 0.0, 0.0]), mass=0.0, contype=0,
                          conaffinity=0, group=3)
        if scene.floor and index not in layout.clamped:
            spec.add_pair(geomname1=floor_geom, geomname2=contact_geom, condim=3,
                          friction=_mjcf([props.friction, props.friction, 0.0, 0.0, 0.0]),
                          solref=solref, solimp=solimp)
    if scene.self_collision:
        for i, j in _near_pairs(layout.grid_index, layout.index_of):
            spec.add_exclude(bodyname1=bodies[i].name, bodyname2=bodies[j].name)
    sites: dict[tuple[int, tuple[float, ...]], str] = {}
    for t in range(table.count):
        i, j = table.ends[t]
        tendon = spec.add_tendon(name=f"bond{table.bond[t]}_{t}")
        tendon.wrap_site(_site(bodies[i], int(i), tuple(table.offsets[t, 0]), sites))
        tendon.wrap_site(_site(bodies[j], int(j), tuple(table.offsets[t, 1]), sites))
        tendon.stiffness = [float(table.stiffness[t]), 0.0, 0.0]
        tendon.damping = [float(table.damping[t]), 0.0, 0.0]
        tendon.springlength = [float(table.rest[t])] * 2


COLLISION_SKIN = 0.5  # Verlet-list skin of the plugin's self-collision, in voxel lengths


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
