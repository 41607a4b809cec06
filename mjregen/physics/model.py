"""A robot grid and its physics as arrays, before MuJoCo: voxels, bonds, tendons, beams.

One code path for 2D and 3D. Voxels are in `Robot.voxels()` order (the body order of the
model); the robot starts with its lowest voxel's bottom face at z = `elevation` and its
centre of mass at x = y = 0. Face neighbours are bonded; bonds touching a muscle come first.

Bond mechanics. For a bond along axis x with lateral axes P (one in 2D, two in 3D), the
tendon bundle is:

  * diagonals: for each lateral axis q and each offset ±a along the other lateral axes
    (none in 2D), a crossed pair from −b to +b along q (and +b to −b), each of stiffness
    k_d; they carry shear and, in 3D, bending;
  * axial tendons at all lateral offsets (±a, ±a) with total stiffness k_ax (2D only).

Linearised, with s, c the sine and cosine of a diagonal's angle to the bond axis, the bond
has axial stiffness k_ax + n·2ⁿ k_d c², shear stiffness 2ⁿ k_d s² and bending stiffness
k_ax a² (2D) or 4 k_d c² a² (3D), n = number of lateral axes. Beam theory asks for E·A/L =
E·L, G·A/L = G·L and E·I/L = E·L³/12. Choosing b = L·sqrt(G/2E) = L / (2 sqrt(1+ν)) makes
the 3D bond exact with k_ax = 0 (8 tendons), and the same b with a = L/√6 makes the 2D bond
exact with k_ax = E·L/2 (2 axial + 2 diagonal tendons). E and G of a bond are the two
voxels' half-lengths in series (2 E₁E₂/(E₁+E₂)); so every material of a robot must share
one Poisson ratio. `BeamTable` is one beam element per bond: with beam_law "tendons" the
same linear stiffness as the bundle, with "engine" the paper engine's beam (linear axial
spring, torsion G·J/L).

The tendons' damping is stiffness-proportional: c = 2ζ sqrt(m k), m the mean voxel mass; the
beams' follows `VoxelPipeline.beam_damping`. Muscles: a bond's axial rest length is
L·(s₁+s₂)/2 with sᵢ the voxels' linear scales; each tendon's is sqrt((L s̄)² + d²), d its
fixed lateral extent. Tendon
values are rounded as MJCF writes them (`round_like_mjcf`), so the pure-MuJoCo model's file
reproduces its tendons bit for bit.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from mjregen.errors import CompileError, PhysicsParameterError
from mjregen.grid import Material, Robot
from mjregen.physics.params import Physics, VoxelPipeline

WORLD_AXES = {2: (0, 2), 3: (0, 1, 2)}  # grid axis -> world axis
# the paper engine damps each voxel's angular momentum with ten times its slow damping ratio
ENGINE_ROTATIONAL_DRAG = 10.0


def voxel_name(index: Sequence[int]) -> str:
    """Body name of the voxel at grid `index`: ``voxel_<x>_<y>_<z>`` (2D ``voxel_<x>_<z>``)."""
    return "voxel_" + "_".join(str(int(k)) for k in index)


@dataclass(frozen=True)
class MuscleTendons:
    """The tendons that muscles drive: model tendons ``0 .. count-1``.

    A tendon's rest length at time t is ``sqrt((L (1 + w_plus e₊(t) + w_minus e₋(t)))² +
    lateral²)``, with e± the signed waveforms of the two muscle phases
    (`mjregen.physics.simulation`).

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


def bond_geometry(poisson_ratio: float, voxel_size: float, *,
                  bond_model: str = "timoshenko") -> tuple[float, float]:
    """(a, b) in m: tendon-site offsets calibrated to beam theory (see module docstring).

    b = L·sqrt(G/2E): G = E/(2(1+ν)) for "timoshenko"; G = E for "euler_bernoulli" (a
    transverse stiffness of E·L = 12EI/L³, the shear-rigid beam of the paper's engine).
    """
    shear_ratio = 1.0 if bond_model == "euler_bernoulli" else 1.0 / (2.0 * (1.0 + poisson_ratio))
    return voxel_size / math.sqrt(6.0), voxel_size * math.sqrt(shear_ratio / 2.0)


@dataclass(frozen=True)
class RobotLayout:
    """The robot's voxels in body order and its face bonds (module docstring)."""

    dim: int
    voxels: list  # [(grid index tuple, Material)]
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
    return RobotLayout(dim=dim, voxels=voxels, index_of=index_of, grid_index=grid_index,
                   masses=masses, centres=centres,
                   surface=np.any((plus < 0) | (minus < 0), axis=1), bonds=bonds,
                   clamped=clamped)


def bond_tables(layout: RobotLayout, physics: Physics
                ) -> tuple[BondTable, BeamTable, MuscleTendons | None, float]:
    """The bonds as tendons and as beams, the driven tendons, and the largest bond
    stiffness per voxel mass (s⁻², for the stiffest-bond time step).

    Raises:
      PhysicsParameterError: the robot's materials have different Poisson ratios.
    """
    scene, pipeline = physics.scene, physics.pipeline
    bond_model = pipeline.bond_model
    voxel_pipeline = isinstance(pipeline, VoxelPipeline)  # the MuJoCo one has no beams
    engine_beam = voxel_pipeline and pipeline.beam_law == "engine"
    engine_damping = voxel_pipeline and pipeline.beam_damping == "engine"
    L = scene.voxel_size
    ratios = {physics.materials[m].poisson_ratio for _, m in layout.voxels}
    if len(ratios) > 1:
        raise PhysicsParameterError(
            f"the robot's materials have different Poisson ratios {sorted(ratios)}; bond "
            "geometry needs one ratio per robot")
    a, b = bond_geometry(ratios.pop(), L, bond_model=bond_model)
    voxels, masses = layout.voxels, layout.masses
    beam_stiffness, beam_law, beam_beta, beam_weights = [], [], [], []
    max_k_per_m = 0.0
    kinds: dict[tuple, int] = {}  # robots have few distinct bonds: build each kind once
    kind_tendons: list[dict[str, np.ndarray]] = []
    kind_of_bond = []
    for i, j, axis in layout.bonds:
        p_i, p_j = physics.materials[voxels[i][1]], physics.materials[voxels[j][1]]
        e_bond = _series(p_i.youngs_modulus, p_j.youngs_modulus)
        g_bond = (e_bond if bond_model == "euler_bernoulli"
                  else _series(p_i.shear_modulus, p_j.shear_modulus))
        k_bond = e_bond * L
        max_k_per_m = max(max_k_per_m, k_bond / min(masses[i], masses[j]))
        m_bond = 0.5 * (masses[i] + masses[j])
        damping_per_stiffness = 2.0 * scene.bond_damping_ratio * math.sqrt(m_bond / k_bond)
        shear = _series(p_i.shear_modulus, p_j.shear_modulus)
        bond_weights = [0.0, 0.0]
        for props in (p_i, p_j):
            if props.is_muscle:
                bond_weights[0 if props.phase_sign > 0 else 1] += 0.5 * props.strain_amplitude
        torsion = shear * L**3 / 6.0 if engine_beam else g_bond * L**3 / 3.0
        beam_stiffness.append((e_bond * L, g_bond * L, e_bond * L**3 / 12.0, torsion))
        if engine_damping:
            zeta = scene.bond_damping_ratio
            beam_beta.append((damping_per_stiffness, zeta * math.sqrt(m_bond / k_bond),
                              zeta * math.sqrt(m_bond / (shear * L))))
        else:
            beam_beta.append((damping_per_stiffness,) * 3)
        if p_i.is_muscle or p_j.is_muscle:
            beam_weights.append(bond_weights)
        key = (axis, e_bond, g_bond, damping_per_stiffness)
        if key not in kinds:
            law, tendons = _bond_tendon_values(axis, layout.dim, L, a, b, e_bond, g_bond,
                                               damping_per_stiffness)
            kinds[key] = len(kind_tendons)
            kind_tendons.append({"law": np.array(law, dtype=float),
                                 "offsets": np.array([t[2:4] for t in tendons], dtype=float),
                                 **{name: np.array([t[k] for t in tendons], dtype=float)
                                    for k, name in ((4, "stiffness"), (5, "damping"),
                                                    (6, "rest"), (7, "lateral"))}})
        kind_of_bond.append(kinds[key])
    if not layout.bonds:
        present = {m for _, m in voxels}
        max_k_per_m = max(physics.materials[m].youngs_modulus * L / physics.voxel_mass(m)
                          for m in present)
    bond_ends = np.array([(i, j) for i, j, _ in layout.bonds], dtype=int).reshape(-1, 2)
    counts = np.array([len(kind_tendons[k]["stiffness"]) for k in kind_of_bond], dtype=int)
    tendon_bond = np.repeat(np.arange(len(layout.bonds)), counts)

    def per_tendon(name: str, shape: tuple) -> np.ndarray:
        parts = [kind_tendons[k][name] for k in kind_of_bond]
        return np.concatenate(parts) if parts else np.zeros((0, *shape))

    table = BondTable(ends=bond_ends[tendon_bond], offsets=per_tendon("offsets", (2, 3)),
                      stiffness=per_tendon("stiffness", ()), damping=per_tendon("damping", ()),
                      rest=per_tendon("rest", ()), bond=tendon_bond,
                      lateral=per_tendon("lateral", ()))
    stiffness = np.array(beam_stiffness, dtype=float).reshape(-1, 4)
    if engine_beam:  # linear: k₀ = E·L, no diagonals
        axial_law = np.zeros((len(stiffness), 3))
        axial_law[:, 0] = stiffness[:, 0]
    else:
        axial_law = np.array([kind_tendons[k]["law"] for k in kind_of_bond],
                             dtype=float).reshape(-1, 3)
    beams = BeamTable(ends=bond_ends, axis=np.array([axis for _, _, axis in layout.bonds],
                                                     dtype=int),
                      stiffness=stiffness, axial_law=axial_law,
                      beta=np.array(beam_beta, dtype=float).reshape(-1, 3),
                      muscle_weights=np.array(beam_weights, dtype=float).reshape(-1, 2))
    muscles = None
    if beam_weights:  # driven bonds come first (`robot_layout`), so do their tendons
        driven_counts = counts[: len(beam_weights)]
        muscles = MuscleTendons(weights=np.repeat(beams.muscle_weights, driven_counts, axis=0),
                                lateral=table.lateral[: driven_counts.sum()], voxel_size=L)
    return table, beams, muscles, max_k_per_m


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


def round_like_mjcf(values: float | Sequence[float] | np.ndarray) -> float | list[float]:
    """`values` rounded to the 6 significant digits that MJCF export writes.

    Every number the model gets passes through here, so the exported XML reproduces the
    compiled model bit for bit.
    """
    if np.ndim(values) == 0:
        return float(f"{float(values):.6g}")
    return [float(f"{float(v):.6g}") for v in values]


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
    site offsets and numbers rounded as the MJCF stores them (`round_like_mjcf`)."""
    law = [0.0, 0.0, 0.0]
    out = []
    for offset_i, offset_j, stiffness in _bond_tendons(axis, dim, L, a, b, e_bond, g_bond):
        lateral2 = float(np.sum(np.subtract(offset_j, offset_i) ** 2))
        law[0 if lateral2 == 0.0 else 1] += stiffness
        law[2] = max(law[2], lateral2)  # the same for all diagonals of a bond
        site_i, site_j = round_like_mjcf(offset_i), round_like_mjcf(offset_j)
        extent = float(np.linalg.norm(np.subtract(site_j, site_i)))
        out.append((offset_i, offset_j, site_i, site_j, round_like_mjcf(stiffness),
                    round_like_mjcf(stiffness * damping_per_stiffness),
                    round_like_mjcf(math.sqrt(L * L + extent * extent)), extent))
    return law, out
