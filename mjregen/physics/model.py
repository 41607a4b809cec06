"""A robot grid and its physics as arrays, before MuJoCo: voxels, bonds, tendons, beams.

One code path for 2D and 3D. Voxels are in `Robot.voxels()` order (the body order of the
model); the robot starts with its lowest voxel's bottom face at z = `elevation` and its
centre of mass at x = y = 0. Face neighbours are bonded; bonds touching a muscle come first.

Bonds (`robot_bonds` -> `RobotBonds`): as tendon bundles (`mjregen.physics.tendons`) and as
beam elements (`BeamTable`: one per bond; with beam_law "tendons" the bundle's linear
stiffness, with "engine" the paper engine's beam: linear axial spring, torsion G·J/L).

The tendons' damping is stiffness-proportional: c = 2ζ sqrt(m k), m the mean voxel mass; the
beams' follows `VoxelPipeline.beam_damping`. Muscles: a bond's axial rest length is
L·(s₁+s₂)/2 with sᵢ the voxels' linear scales; each tendon's is sqrt((L s̄)² + d²), d its
fixed lateral extent. Tendon values are rounded as MJCF writes them (`round_like_mjcf`), so
the pure-MuJoCo model's file reproduces its tendons bit for bit.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from mjregen.errors import CompileError, PhysicsParameterError
from mjregen.grid import Material, Robot
from mjregen.physics.params import Physics
from mjregen.physics.pipelines import VoxelPipeline
from mjregen.physics.rounding import round_like_mjcf
from mjregen.physics.tendons import (
    WORLD_AXES,
    BondTable,
    MuscleTendons,
    bond_geometry,
    bond_tendon_values,
)

# the paper engine damps each voxel's angular momentum with ten times its slow damping ratio
ENGINE_ROTATIONAL_DRAG = 10.0


def voxel_name(index: Sequence[int]) -> str:
    """Body name of the voxel at grid `index`: ``voxel_<x>_<y>_<z>`` (2D ``voxel_<x>_<z>``)."""
    return "voxel_" + "_".join(str(int(k)) for k in index)


@dataclass(frozen=True)
class BeamTable:
    """Every face bond of a robot as one beam element (``bond_element="beam"``), with the
    linear stiffness of the bond's tendons (module docstring), their law along the bond's
    axis, and their damping ratio.

    Bonds touching a muscle are rows ``0 .. len(muscle_weights)-1``; a bond's rest length is
    L (1 + w₊ e₊ + w₋ e₋), as for its tendons.

    Attributes:
      ends: ``(n, 2)`` int, voxels (body order) i and j, j the neighbour of i along +axis.
      axis: ``(n,)`` int, the bond's axis (0, 1, 2 = x, y, z) in the voxels' rest frames.
      stiffness: ``(n, 4)`` float: axial E·L and transverse G_b·L in N/m (G_b the
        bond_model's: E shear-rigid, G Timoshenko), bending E·L³/12 and torsion in N·m/rad
        (beam_law "engine": G·L³/6, the engine's G·J/L; "tendons": G_b·L³/3), E and G of
        the bond (harmonic means of its voxels').
      axial_law: ``(n, 3)`` float, the axial force at centre distance l,
        k₀ (l − l₀) + k_d (s − s₀) l / s with s = sqrt(l² + D²), s₀ = sqrt(l₀² + D²): k₀
        (N/m), k_d (N/m), D² (m²). beam_law "engine": linear, k₀ = E·L, k_d = 0; "tendons":
        the bond's straight tendons k₀ and diagonals k_d with lateral extent D (slope E·L
        at l₀ = L, stiffening in tension, softening in compression).
      beta: ``(n, 3)`` s, damping per stiffness of the force rows, the bending and the
        torsion (`VoxelPipeline.beam_damping`).
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
        return len(self.ends)


@dataclass(frozen=True)
class RobotBonds:
    """A robot's face bonds in the forms its models take (module docstring).

    Attributes:
      tendons: every bond as its tendon bundle (``bond_element="tendons"`` and the
        pure-MuJoCo pipeline).
      beams: every bond as one beam element (``bond_element="beam"``); its axial laws and
        muscle weights serve either element (the time step's muscle stiffening).
      muscles: the driven bonds' tendons (their rest lengths follow the muscles), or None
        (no muscles).
      stiffest_rate: s⁻², the largest bond stiffness per voxel mass (E·L over the lighter
        voxel's mass; without bonds, of the stiffest material present): the stiffest-bond
        time step's.
    """

    tendons: BondTable
    beams: BeamTable
    muscles: MuscleTendons | None
    stiffest_rate: float

    @property
    def count(self) -> int:
        """Face bonds."""
        return self.beams.count


@dataclass(frozen=True)
class RobotLayout:
    """The robot's voxels in body order and its face bonds (module docstring)."""

    dim: int
    voxels: list  # [(grid index tuple, Material)]
    names: list  # [str]: each voxel's body name (`voxel_name`)
    index_of: dict  # grid index -> voxel number
    grid_index: np.ndarray  # (n, dim) int
    masses: np.ndarray  # (n,) kg
    centres: np.ndarray  # (n, 3) m, initial body positions
    surface: np.ndarray  # (n,) bool: a face neighbour is missing
    bonds: list  # [(i, j, world axis)], bonds touching a muscle first
    clamped: set


def robot_layout(robot: Robot, physics: Physics, clamped: set, elevation: float) -> RobotLayout:
    """Voxels, masses, initial centres and bonds of `robot`.

    Raises:
      CompileError: a clamped index that is not a voxel.
    """
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
    plus, minus = _neighbours(grid_index)  # a voxel missing a face neighbour is surface
    bonds = _face_bonds(plus, dim)
    is_muscle = [physics.materials[m].is_muscle for _, m in voxels]
    bonds.sort(key=lambda bond: not (is_muscle[bond[0]] or is_muscle[bond[1]]))
    return RobotLayout(dim=dim, voxels=voxels, names=[voxel_name(index) for index, _ in voxels],
                       index_of=index_of, grid_index=grid_index,
                       masses=masses, centres=centres,
                       surface=np.any((plus < 0) | (minus < 0), axis=1), bonds=bonds,
                       clamped=clamped)


def robot_bonds(layout: RobotLayout, physics: Physics) -> RobotBonds:
    """The robot's bonds as tendons and as beams, its driven tendons, and its stiffest
    bond's rate.

    Raises:
      PhysicsParameterError: the robot's materials have different Poisson ratios.
    """
    scene, pipeline = physics.scene, physics.pipeline
    voxel_pipeline = isinstance(pipeline, VoxelPipeline)  # the MuJoCo one has no beams
    engine_beam = voxel_pipeline and pipeline.beam_law == "engine"
    engine_damping = voxel_pipeline and pipeline.beam_damping == "engine"
    L = scene.voxel_size
    ratios = {physics.materials[m].poisson_ratio for _, m in layout.voxels}
    if len(ratios) > 1:
        raise PhysicsParameterError(
            f"the robot's materials have different Poisson ratios {sorted(ratios)}; bond "
            "geometry needs one ratio per robot")
    a, b = bond_geometry(ratios.pop(), L, bond_model=pipeline.bond_model)
    rows, of_pair = [], {}  # a row depends only on its voxels' materials and masses
    for i, j, _ in layout.bonds:
        pair = (layout.voxels[i][1], layout.voxels[j][1], layout.masses[i], layout.masses[j])
        if pair not in of_pair:
            of_pair[pair] = _beam_row(layout, physics, i, j, engine_beam=engine_beam,
                                      engine_damping=engine_damping)
        rows.append(of_pair[pair])
    max_k_per_m = max((row.k_per_m for row in rows), default=0.0)
    if not layout.bonds:
        present = {m for _, m in layout.voxels}
        max_k_per_m = max(physics.materials[m].youngs_modulus * L / physics.voxel_mass(m)
                          for m in present)
    kinds: dict[tuple, int] = {}  # robots have few distinct bonds: build each kind once
    kind_tendons: list[dict[str, np.ndarray]] = []
    kind_of_bond = []
    for (_, _, axis), row in zip(layout.bonds, rows):
        key = (axis, row.e_bond, row.g_bond, row.damping_per_stiffness)
        if key not in kinds:
            kinds[key] = len(kind_tendons)
            kind_tendons.append(_tendon_kind(axis, layout.dim, L, a, b, row))
        kind_of_bond.append(kinds[key])
    bond_ends = np.array([(i, j) for i, j, _ in layout.bonds], dtype=int).reshape(-1, 2)
    table, counts = _tendon_table(bond_ends, kind_tendons, kind_of_bond)
    stiffness = np.array([row.stiffness for row in rows], dtype=float).reshape(-1, 4)
    if engine_beam:  # linear: k₀ = E·L, no diagonals
        axial_law = np.zeros((len(stiffness), 3))
        axial_law[:, 0] = stiffness[:, 0]
    else:
        axial_law = np.array([kind_tendons[k]["law"] for k in kind_of_bond],
                             dtype=float).reshape(-1, 3)
    weights = [row.muscle_weights for row in rows if row.muscle_weights is not None]
    beams = BeamTable(ends=bond_ends, axis=np.array([axis for _, _, axis in layout.bonds],
                                                     dtype=int),
                      stiffness=stiffness, axial_law=axial_law,
                      beta=np.array([row.beta for row in rows], dtype=float).reshape(-1, 3),
                      muscle_weights=np.array(weights, dtype=float).reshape(-1, 2))
    muscles = None
    if weights:  # driven bonds come first (`robot_layout`), so do their tendons
        driven_counts = counts[: len(weights)]
        muscles = MuscleTendons(weights=np.repeat(beams.muscle_weights, driven_counts, axis=0),
                                lateral=table.lateral[: driven_counts.sum()], voxel_size=L)
    return RobotBonds(tendons=table, beams=beams, muscles=muscles, stiffest_rate=max_k_per_m)


@dataclass(frozen=True)
class _BeamRow:
    """One bond's constants (`robot_bonds`)."""

    e_bond: float  # Pa, the voxels' moduli in series
    g_bond: float  # Pa, the bond model's shear modulus
    k_per_m: float  # s⁻², E·L over the lighter voxel's mass
    damping_per_stiffness: float  # s
    stiffness: tuple  # a `BeamTable.stiffness` row
    beta: tuple  # a `BeamTable.beta` row
    muscle_weights: list | None  # (w₊, w₋), None for a bond without a muscle


def _beam_row(layout: RobotLayout, physics: Physics, i: int, j: int, *, engine_beam: bool,
              engine_damping: bool) -> _BeamRow:
    scene, bond_model, L = physics.scene, physics.pipeline.bond_model, physics.scene.voxel_size
    masses = layout.masses
    p_i, p_j = physics.materials[layout.voxels[i][1]], physics.materials[layout.voxels[j][1]]
    e_bond = _series(p_i.youngs_modulus, p_j.youngs_modulus)
    g_bond = (e_bond if bond_model == "euler_bernoulli"
              else _series(p_i.shear_modulus, p_j.shear_modulus))
    k_bond = e_bond * L
    m_bond = 0.5 * (masses[i] + masses[j])
    damping_per_stiffness = 2.0 * scene.bond_damping_ratio * math.sqrt(m_bond / k_bond)
    shear = _series(p_i.shear_modulus, p_j.shear_modulus)
    bond_weights = [0.0, 0.0]
    for props in (p_i, p_j):
        if props.is_muscle:
            bond_weights[0 if props.phase_sign > 0 else 1] += 0.5 * props.strain_amplitude
    torsion = shear * L**3 / 6.0 if engine_beam else g_bond * L**3 / 3.0
    if engine_damping:
        zeta = scene.bond_damping_ratio
        beta = (damping_per_stiffness, zeta * math.sqrt(m_bond / k_bond),
                zeta * math.sqrt(m_bond / (shear * L)))
    else:
        beta = (damping_per_stiffness,) * 3
    return _BeamRow(e_bond=e_bond, g_bond=g_bond, k_per_m=k_bond / min(masses[i], masses[j]),
                    damping_per_stiffness=damping_per_stiffness,
                    stiffness=(e_bond * L, g_bond * L, e_bond * L**3 / 12.0, torsion), beta=beta,
                    muscle_weights=bond_weights if p_i.is_muscle or p_j.is_muscle else None)


def _tendon_kind(axis: int, dim: int, L: float, a: float, b: float,
                 row: _BeamRow) -> dict[str, np.ndarray]:
    """The tendons of one kind of bond as arrays: law, offsets, stiffness, damping, rest,
    lateral (`tendons.bond_tendon_values`)."""
    law, tendons = bond_tendon_values(axis, dim, L, a, b, row.e_bond, row.g_bond,
                                      row.damping_per_stiffness)
    return {"law": np.array(law, dtype=float),
            "offsets": np.array([t[2:4] for t in tendons], dtype=float),
            **{name: np.array([t[k] for t in tendons], dtype=float)
               for k, name in ((4, "stiffness"), (5, "damping"), (6, "rest"), (7, "lateral"))}}


def _tendon_table(bond_ends: np.ndarray, kind_tendons: list[dict[str, np.ndarray]],
                  kind_of_bond: list[int]) -> tuple[BondTable, np.ndarray]:
    """Every bond's tendons in bond order, and ``(n_bonds,)`` tendons per bond."""
    counts = np.array([len(kind_tendons[k]["stiffness"]) for k in kind_of_bond], dtype=int)
    tendon_bond = np.repeat(np.arange(len(kind_of_bond)), counts)

    def per_tendon(name: str, shape: tuple) -> np.ndarray:
        parts = [kind_tendons[k][name] for k in kind_of_bond]
        return np.concatenate(parts) if parts else np.zeros((0, *shape))

    table = BondTable(ends=bond_ends[tendon_bond], offsets=per_tendon("offsets", (2, 3)),
                      stiffness=per_tendon("stiffness", ()), damping=per_tendon("damping", ()),
                      rest=per_tendon("rest", ()), bond=tendon_bond,
                      lateral=per_tendon("lateral", ()))
    return table, counts


def engine_floor_constants(layout: RobotLayout, physics: Physics
                           ) -> tuple[np.ndarray, np.ndarray]:
    """``(n_voxels,)`` N/m and N·s/m: the engine floor's spring floor_stiffness·E·L and
    damper floor_damping·2 sqrt(m E L) on each voxel (the voxel pipeline's parameters)."""
    pipeline, L = physics.pipeline, physics.scene.voxel_size
    EL = np.array([physics.materials[m].youngs_modulus * L for _, m in layout.voxels])
    return (pipeline.floor_stiffness * EL,
            pipeline.floor_damping * 2.0 * np.sqrt(layout.masses * EL))


def collision_constants(layout: RobotLayout, physics: Physics
                        ) -> tuple[np.ndarray, np.ndarray]:
    """``(n_voxels,)`` N/m and N·s/m: each voxel's self-collision spring
    collision_stiffness·E·L and damper collision_damping·2 sqrt(m E L); a colliding pair
    takes the harmonic mean of its two (the engine's pair: the harmonic-mean modulus)."""
    pipeline, L = physics.pipeline, physics.scene.voxel_size
    EL = np.array([physics.materials[m].youngs_modulus * L for _, m in layout.voxels])
    return (pipeline.collision_stiffness * EL,
            pipeline.collision_damping * 2.0 * np.sqrt(layout.masses * EL))


def drag_viscosity(physics: Physics) -> float:
    """Pa·s: the viscosity whose Stokes drag on a voxel (3πμL) is the scene's drag,
    2·drag_ratio·sqrt(m E L) of a soft voxel (0: none)."""
    scene = physics.scene
    if scene.drag_ratio <= 0.0:
        return 0.0
    L = scene.voxel_size
    soft = physics.materials[Material.SOFT]
    drag = 2.0 * scene.drag_ratio * math.sqrt(physics.voxel_mass(Material.SOFT)
                                              * soft.youngs_modulus * L)
    return round_like_mjcf(drag / (3.0 * math.pi * L))


def voxel_drag(layout: RobotLayout, physics: Physics) -> tuple[np.ndarray, np.ndarray]:
    """``(n_voxels,)`` N·s/m and N·m·s: each voxel's linear and rotational drag under the
    voxel pipeline's `drag_law` (see `VoxelPipeline`), from the scene's drag_ratio ζ."""
    scene, L = physics.scene, physics.scene.voxel_size
    n = len(layout.voxels)
    if scene.drag_ratio <= 0.0:
        return np.zeros(n), np.zeros(n)
    if physics.pipeline.drag_law == "stokes":
        viscosity = drag_viscosity(physics)
        return (np.full(n, 3.0 * math.pi * L * viscosity),
                np.full(n, math.pi * L**3 * viscosity))
    E = np.array([physics.materials[m].youngs_modulus for _, m in layout.voxels])
    inertia = layout.masses * L**2 / 6.0
    return (2.0 * scene.drag_ratio * np.sqrt(layout.masses * E * L),
            2.0 * ENGINE_ROTATIONAL_DRAG * scene.drag_ratio * np.sqrt(inertia * E * L**3))


def _neighbours(grid_index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(n, dim)`` int each: the voxel one step along (+) and against (−) each grid axis
    of each voxel, -1 where there is none."""
    n, dim = grid_index.shape
    slots = np.full(tuple(grid_index.max(axis=0) + 3), -1, dtype=np.int64)  # padded by 1
    slots[tuple((grid_index + 1).T)] = np.arange(n)
    out = []
    for step in (1, -1):
        found = np.empty((n, dim), dtype=np.int64)
        for axis in range(dim):
            shifted = grid_index + 1
            shifted[:, axis] += step
            found[:, axis] = slots[tuple(shifted.T)]
        out.append(found)
    return out[0], out[1]


def near_pairs(grid_index: np.ndarray, index_of: dict) -> list[tuple[int, int]]:
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


def _series(x: float, y: float) -> float:
    """Modulus of two equal half-lengths in series: 2xy/(x+y)."""
    return 2.0 * x * y / (x + y)


def _face_bonds(plus: np.ndarray, dim: int) -> list[tuple[int, int, int]]:
    """(i, j, world axis) for each face-neighbour pair, j the +axis neighbour of i (`plus`
    of `_neighbours`), in voxel order and grid-axis order within a voxel."""
    return [(int(i), int(plus[i, a]), WORLD_AXES[dim][a]) for i, a in np.argwhere(plus >= 0)]
