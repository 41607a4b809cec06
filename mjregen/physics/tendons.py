"""A face bond as a bundle of spring tendons calibrated to beam theory: MuJoCo's tendons in
the pure-MuJoCo pipeline, the voxel plugin's with ``bond_element="tendons"``.

For a bond along axis x with lateral axes P (one in 2D, two in 3D), the tendon bundle is:

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
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from mjregen.physics.rounding import round_like_mjcf

WORLD_AXES = {2: (0, 2), 3: (0, 1, 2)}  # grid axis -> world axis


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


def bond_geometry(poisson_ratio: float, voxel_size: float, *,
                  bond_model: str = "timoshenko") -> tuple[float, float]:
    """(a, b) in m: tendon-site offsets calibrated to beam theory (see module docstring).

    b = L·sqrt(G/2E): G = E/(2(1+ν)) for "timoshenko"; G = E for "euler_bernoulli" (a
    transverse stiffness of E·L = 12EI/L³, the shear-rigid beam of the paper's engine).
    """
    shear_ratio = 1.0 if bond_model == "euler_bernoulli" else 1.0 / (2.0 * (1.0 + poisson_ratio))
    return voxel_size / math.sqrt(6.0), voxel_size * math.sqrt(shear_ratio / 2.0)


def bond_tendons(axis: int, dim: int, L: float, a: float, b: float, e_bond: float,
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


def bond_tendon_values(axis: int, dim: int, L: float, a: float, b: float, e_bond: float,
                        g_bond: float, damping_per_stiffness: float) -> tuple[list, list]:
    """A bond's axial law [k straight N/m, k diagonal N/m, diagonals' lateral extent² m²] and
    its tendons as (offset_i, offset_j, site_i, site_j, k N/m, c N s/m, rest m, extent m),
    site offsets and numbers rounded as the MJCF stores them (`round_like_mjcf`)."""
    law = [0.0, 0.0, 0.0]
    out = []
    for offset_i, offset_j, stiffness in bond_tendons(axis, dim, L, a, b, e_bond, g_bond):
        lateral2 = float(np.sum(np.subtract(offset_j, offset_i) ** 2))
        law[0 if lateral2 == 0.0 else 1] += stiffness
        law[2] = max(law[2], lateral2)  # the same for all diagonals of a bond
        site_i, site_j = round_like_mjcf(offset_i), round_like_mjcf(offset_j)
        extent = float(np.linalg.norm(np.subtract(site_j, site_i)))
        out.append((offset_i, offset_j, site_i, site_j, round_like_mjcf(stiffness),
                    round_like_mjcf(stiffness * damping_per_stiffness),
                    round_like_mjcf(math.sqrt(L * L + extent * extent)), extent))
    return law, out
