"""Behaviour descriptors of grown robots: where a robot sits in a quality-diversity archive.

Each descriptor is a number computed from a robot grid alone (no simulation), with a fixed
range for the grid's shape, so that an archive's cells mean the same in every run (counts
span -0.5 .. maximum + 0.5, so that with one cell per value each count has its own cell):

  voxels      filled cells                          0 .. interior cells (3D 343, 2D 25)
  muscle      muscle voxels / voxels                0 .. 1 (0 for an empty robot)
  height      filled z-layers, bottom to top        0 .. interior height (voxel lengths)
  footprint   cells of the floor the robot covers   0 .. 1 (its x-y shadow / interior x-y
              seen from above, / interior x-y cells    cells; 2D: its x shadow)
  feet        separate contact patches of its       0 .. the most a layer can hold (3D 7x7:
              lowest layer (face-connected)            25, 2D 5: 3)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from mjregen.grid import Material, count_pieces


@dataclass(frozen=True)
class Descriptor:
    """One behaviour descriptor: `measure(grid) -> float` and its range for a grid shape."""

    name: str
    summary: str
    measure: Callable[[np.ndarray], float]
    upper: Callable[[tuple[int, ...]], float]  # grid shape (border included) -> maximum
    counts: bool  # whole numbers (else a fraction in 0..1)


def _interior(shape: tuple[int, ...]) -> tuple[int, ...]:
    return tuple(n - 2 for n in shape)


def _voxels(grid: np.ndarray) -> float:
    return float(np.count_nonzero(grid))


def _muscle(grid: np.ndarray) -> float:
    voxels = np.count_nonzero(grid)
    muscles = np.count_nonzero((grid == Material.MUSCLE_PLUS) | (grid == Material.MUSCLE_MINUS))
    return muscles / voxels if voxels else 0.0


def _filled_layers(grid: np.ndarray) -> np.ndarray:
    """z-indices of the layers that hold a voxel, ascending."""
    return np.flatnonzero(np.any(grid != 0, axis=tuple(range(grid.ndim - 1))))


def _height(grid: np.ndarray) -> float:
    layers = _filled_layers(grid)
    return float(layers[-1] - layers[0] + 1) if len(layers) else 0.0


def _footprint(grid: np.ndarray) -> float:
    shadow = np.any(grid != 0, axis=-1)
    return np.count_nonzero(shadow) / np.prod(_interior(shadow.shape))


def _lowest_layer(grid: np.ndarray) -> np.ndarray:
    """bool ``(X, Y)`` (2D: ``(X,)``): the filled cells of the robot's lowest filled layer."""
    layers = _filled_layers(grid)
    if not len(layers):
        return np.zeros(grid.shape[:-1], dtype=bool)
    return grid[..., layers[0]] != 0


def _feet(grid: np.ndarray) -> float:
    return float(count_pieces(_lowest_layer(grid)))


def _most_patches(shape: tuple[int, ...]) -> float:
    """Separate face-connected patches a layer of `shape`'s interior can hold at most (a
    checkerboard)."""
    cells = int(np.prod(_interior(shape)[:-1]))
    return float((cells + 1) // 2)


DESCRIPTORS: dict[str, Descriptor] = {
    d.name: d for d in (
        Descriptor("voxels", "filled cells", _voxels,
                   lambda shape: float(np.prod(_interior(shape))), counts=True),
        Descriptor("muscle", "muscle voxels / voxels", _muscle, lambda shape: 1.0,
                   counts=False),
        Descriptor("height", "filled z-layers (voxel lengths)", _height,
                   lambda shape: float(_interior(shape)[-1]), counts=True),
        Descriptor("footprint", "floor cells covered from above / interior floor cells",
                   _footprint, lambda shape: 1.0, counts=False),
        Descriptor("feet", "separate patches of the lowest layer", _feet, _most_patches,
                   counts=True),
    )
}


def check_descriptors(names: Sequence[str]) -> tuple[str, ...]:
    """`names` as a tuple, checked: known, not repeated, at least one.

    Raises:
      ValueError: naming the unknown or repeated descriptor.
    """
    names = tuple(names)
    if not names:
        raise ValueError("name at least one behaviour descriptor: "
                         + ", ".join(DESCRIPTORS))
    for name in names:
        if name not in DESCRIPTORS:
            raise ValueError(f"unknown behaviour descriptor {name!r}; known: "
                             + ", ".join(DESCRIPTORS))
    if len(set(names)) != len(names):
        raise ValueError(f"behaviour descriptors repeat: {', '.join(names)}")
    return names


def descriptor_ranges(names: Sequence[str], grid_shape: tuple[int, ...]) -> list[tuple[float, float]]:
    """(low, high) of each named descriptor for robots of `grid_shape` (border included):
    fractions 0 .. 1, counts -0.5 .. maximum + 0.5."""
    ranges = []
    for name in check_descriptors(names):
        descriptor = DESCRIPTORS[name]
        upper = descriptor.upper(tuple(grid_shape))
        ranges.append((-0.5, upper + 0.5) if descriptor.counts else (0.0, upper))
    return ranges


def default_cells(names: Sequence[str], grid_shape: tuple[int, ...]) -> tuple[int, ...]:
    """Cells per named descriptor: one per value for counts with at most 20 values, else
    20; 10 for fractions."""
    cells = []
    for name in check_descriptors(names):
        descriptor = DESCRIPTORS[name]
        values = int(descriptor.upper(tuple(grid_shape))) + 1
        cells.append(min(values, 20) if descriptor.counts else 10)
    return tuple(cells)


def describe(grids: np.ndarray, names: Sequence[str]) -> np.ndarray:
    """The named descriptors of each robot: float64 ``(P, len(names))`` from int8 grids
    ``(P, *grid_shape)``."""
    names = check_descriptors(names)
    grids = np.asarray(grids)
    return np.array([[DESCRIPTORS[name].measure(grid) for name in names] for grid in grids],
                    dtype=np.float64).reshape(len(grids), len(names))
