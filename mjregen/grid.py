"""Robot grids: material codes, validation, the paper's cleaning, similarity, damage, I/O.

A robot is a full voxel grid, numpy int8, indexed ``[x, y, z]`` in 3D and ``[x, z]`` in 2D
(z up), including a one-cell empty border (the NCA's 9×9×9 / 7×7 grid). The border keeps
shapes stable between growth, files and regeneration.
"""

from __future__ import annotations

import os
import re
from enum import IntEnum
from pathlib import Path
from typing import Iterator

import numpy as np
from numpy.typing import ArrayLike

from mjregen.errors import GridFileError, InvalidGridError
from mjregen.fileio import atomic_open


class Material(IntEnum):
    """Cell codes of a robot grid (the paper's colours in brackets)."""

    EMPTY = 0
    SOFT = 1  # passive soft (light blue)
    HARD = 2  # passive hard (dark blue)
    MUSCLE_PLUS = 3  # muscle, phase + (red)
    MUSCLE_MINUS = 4  # muscle, phase - (green)


N_MATERIALS = len(Material)
SYMBOLS = {
    Material.EMPTY: ".",
    Material.SOFT: "s",
    Material.HARD: "H",
    Material.MUSCLE_PLUS: "+",
    Material.MUSCLE_MINUS: "-",
}
AXIS_NAMES = {2: ("x", "z"), 3: ("x", "y", "z")}


def validate_grid(values: ArrayLike) -> np.ndarray:
    """Check a robot grid and return it as a new read-only int8 array.

    Args:
      values: array-like of shape ``(X, Z)`` or ``(X, Y, Z)``, each axis >= 3, integer codes
        0..4 (integral floats are accepted), with an empty one-cell border.

    Raises:
      InvalidGridError: naming the first problem found (type, ndim, shape, NaN, non-integer
        values, unknown codes, voxels on the border).
    """
    try:
        array = np.asarray(values)
    except ValueError as error:  # ragged nested lists
        raise InvalidGridError(f"robot grid is not a rectangular array: {error}") from None
    if array.dtype == bool or not (
        np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)
    ):
        raise InvalidGridError(
            f"robot grid must hold integer material codes 0..4, got dtype {array.dtype}"
        )
    if array.ndim not in AXIS_NAMES:
        raise InvalidGridError(
            f"robot grid must be 2D [x, z] or 3D [x, y, z], got {array.ndim} dimensions "
            f"(shape {array.shape})"
        )
    if min(array.shape) < 3:
        raise InvalidGridError(
            f"robot grid shape {array.shape} is too small: every axis needs at least 3 cells "
            "(voxels plus the one-cell empty border)"
        )
    if np.issubdtype(array.dtype, np.floating):
        if not np.all(np.isfinite(array)):
            raise InvalidGridError("robot grid contains NaN or infinite values")
        if not np.all(array == np.round(array)):
            raise InvalidGridError("robot grid contains non-integer values; codes are 0..4")
    unknown = (array < 0) | (array >= N_MATERIALS)
    if np.any(unknown):
        where = tuple(int(i) for i in np.argwhere(unknown)[0])
        raise InvalidGridError(
            f"unknown material code {array[where].item()!r} at {where}; valid codes are "
            + ", ".join(f"{m.value} {m.name.lower()}" for m in Material)
        )
    grid = array.astype(np.int8)
    on_border = (grid != 0) & ~_interior_mask(grid.shape)
    if np.any(on_border):
        where = tuple(int(i) for i in np.argwhere(on_border)[0])
        raise InvalidGridError(
            f"voxel on the grid border at {where}: robot grids keep a one-cell empty border "
            "(Robot.from_body pads a body for you)"
        )
    grid.flags.writeable = False
    return grid


def _interior_mask(shape: tuple[int, ...]) -> np.ndarray:
    """Boolean array of `shape`, True except on the one-cell border."""
    mask = np.zeros(shape, dtype=bool)
    mask[tuple(slice(1, -1) for _ in shape)] = True
    return mask


def face_neighbour_count(filled: np.ndarray, dim: int) -> np.ndarray:
    """Number of filled face neighbours of every cell.

    Args:
      filled: bool array ``(..., *grid_shape)``; the last `dim` axes are spatial.
      dim: 2 or 3.
    Returns:
      int array of the same shape (cells outside the grid count as empty).
    """
    count = np.zeros(filled.shape, dtype=np.int8)
    for axis in range(filled.ndim - dim, filled.ndim):
        lower = [slice(None)] * filled.ndim
        upper = [slice(None)] * filled.ndim
        lower[axis], upper[axis] = slice(None, -1), slice(1, None)
        count[tuple(upper)] += filled[tuple(lower)]
        count[tuple(lower)] += filled[tuple(upper)]
    return count


def count_pieces(filled: np.ndarray) -> int:
    """Face-connected pieces of the True cells of `filled` (bool, any number of axes)."""
    labels = np.zeros(filled.shape, dtype=np.int32)
    count = 0
    for start in zip(*np.nonzero(filled)):
        if labels[start]:
            continue
        count += 1
        labels[start] = count
        stack = [start]
        while stack:
            cell = stack.pop()
            for axis in range(filled.ndim):
                for step in (-1, 1):
                    near = list(cell)
                    near[axis] += step
                    near = tuple(near)
                    if 0 <= near[axis] < filled.shape[axis] and filled[near] and not labels[near]:
                        labels[near] = count
                        stack.append(near)
    return count


def clean_grids(grids: np.ndarray, dim: int) -> np.ndarray:
    """The paper's cleaning of grown robots, for one grid or a whole batch.

    The paper's code repeats, until sweep A removes nothing: sweep A (in index order, in
    place) removes each filled cell with no filled face neighbour but a filled edge or
    corner neighbour; sweep B (same order, in place) removes each filled cell with no filled
    neighbour at all. Its result is exactly "remove every cell without a filled face
    neighbour": such cells never gain one (removing a cell that has no face neighbours
    cannot take a face neighbour away from anyone), sweep A removes every one of them that
    still touches something when visited, and whatever it skipped is left touching nothing,
    so sweep B removes it. Cells with a face neighbour are never removed. The sweep order
    therefore changes which sweep removes a cell, never the result, and the whole procedure
    is one vectorised step here (tests check it against the literal sweeps).

    Args:
      grids: int array ``(..., *grid_shape)``; the last `dim` axes are spatial.
      dim: 2 or 3.
    Returns:
      A new array of the same shape and dtype with the isolated cells emptied.
    """
    filled = grids != 0
    keep = face_neighbour_count(filled, dim) > 0
    return np.where(keep, grids, 0).astype(grids.dtype)


def lay_flat(patterns: np.ndarray) -> np.ndarray:
    """2D patterns laid flat on the floor: each a one-voxel-thick sheet, the pattern's axes
    becoming x and y (the paper's 2D robots: its code writes the grown 7 x 7 pattern into
    Voxelyze as one layer, Z_Voxels 1, and walks it in 3D).

    Args:
      patterns: int array ``(..., X, Y)`` of material codes, each with its empty border.
    Returns:
      A new int8 array ``(..., X, Y, 3)``: layer z = 1 holds the pattern, z = 0 and z = 2
      are the empty border.

    Raises:
      InvalidGridError: `patterns` has fewer than two axes.
    """
    array = np.asarray(patterns)
    if array.ndim < 2:
        raise InvalidGridError(f"a pattern to lay flat needs 2 axes [x, y], got shape "
                               f"{array.shape}")
    sheets = np.zeros(array.shape + (3,), dtype=np.int8)
    sheets[..., 1] = array
    return sheets


class Robot:
    """A validated, immutable robot grid (see the module docstring for the convention).

    `Robot(grid)` validates and copies `grid`; `robot.grid` is a read-only int8 array.
    Robots compare and hash by grid, so identical robots can be cached.
    """

    __slots__ = ("_grid",)

    def __init__(self, grid: ArrayLike) -> None:
        self._grid = validate_grid(grid)

    @classmethod
    def from_body(cls, body: ArrayLike) -> Robot:
        """Robot from a grid without its border: pads one empty cell on every side."""
        array = np.asarray(body)
        if array.ndim not in AXIS_NAMES:
            raise InvalidGridError(
                f"robot body must be 2D [x, z] or 3D [x, y, z], got {array.ndim} dimensions"
            )
        return cls(np.pad(array, 1))

    @classmethod
    def box(cls, shape: tuple[int, ...], material: int = Material.SOFT) -> Robot:
        """A solid box of one material (a `Material` code, default soft), `shape` voxels
        per axis (``(x, y, z)`` or ``(x, z)``), with the empty border around it."""
        return cls.from_body(np.full(shape, int(material), dtype=np.int8))

    @property
    def grid(self) -> np.ndarray:
        """Read-only int8 array ``(X, Y, Z)`` or ``(X, Z)``."""
        return self._grid

    @property
    def dim(self) -> int:
        """2 or 3."""
        return self._grid.ndim

    @property
    def shape(self) -> tuple[int, ...]:
        return self._grid.shape

    @property
    def n_voxels(self) -> int:
        """Number of non-empty cells."""
        return int(np.count_nonzero(self._grid))

    @property
    def is_empty(self) -> bool:
        return self.n_voxels == 0

    def material_counts(self) -> dict[Material, int]:
        """Number of cells of each material, empty included."""
        counts = np.bincount(self._grid.ravel(), minlength=N_MATERIALS)
        return {material: int(counts[material]) for material in Material}

    def voxels(self) -> Iterator[tuple[tuple[int, ...], Material]]:
        """Yield ``(index, material)`` of every voxel in C index order."""
        for index in np.argwhere(self._grid):
            key = tuple(int(i) for i in index)
            yield key, Material(int(self._grid[key]))

    def cleaned(self) -> Robot:
        """This robot after the paper's cleaning (see `clean_grids`)."""
        return Robot(clean_grids(self._grid, self.dim))

    def similarity(self, other: Robot) -> int:
        """Number of cells (border included) whose material equals `other`'s.

        The paper's regeneration fitness: out of ``grid.size`` (729 in 3D, 49 in 2D).
        """
        if other.shape != self.shape:
            raise InvalidGridError(
                f"cannot compare robots of shapes {self.shape} and {other.shape}"
            )
        return int(np.count_nonzero(self._grid == other._grid))

    def mirror_axes(self) -> tuple[str, ...]:
        """The horizontal axes ("x", "y"; 2D: "x") whose reversal maps the body (its
        bounding box, materials included) onto itself: the body is its own mirror image
        across the plane normal to each. () for an empty robot."""
        if self.is_empty:
            return ()
        box = tuple(slice(i.min(), i.max() + 1) for i in np.nonzero(self._grid))
        body = self._grid[box]
        horizontal = AXIS_NAMES[self.dim][:-1]
        return tuple(name for axis, name in enumerate(horizontal)
                     if np.array_equal(body, np.flip(body, axis=axis)))

    def remove_half_space(self, condition: str) -> Robot:
        """Damage: empty every cell whose index satisfies `condition`.

        Args:
          condition: ``"<axis> <op> <index>"`` with axis x/y/z (x/z in 2D), op one of
            ``< <= > >=``, index an integer grid index, e.g. ``"x < 4"`` (the paper's cut of
            the 9-grid: x indices 0..3).
        """
        return Robot(np.where(half_space_mask(self.shape, condition), 0, self._grid))

    def save(self, path: str | os.PathLike, *, overwrite: bool = False) -> Path:
        """Write the grid to a `.npy` file atomically; never clobbers unless `overwrite`."""
        path = Path(path)
        if path.suffix != ".npy":
            raise GridFileError(f"robot files are .npy files; got {str(path)!r}")
        with atomic_open(path, overwrite=overwrite) as handle:
            np.save(handle, np.asarray(self._grid), allow_pickle=False)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> Robot:
        """Read a robot saved by `save` (any `.npy` int grid that validates)."""
        path = Path(path)
        if path.suffix != ".npy":
            raise GridFileError(f"robot files are .npy files; got {str(path)!r}")
        if not path.is_file():
            raise FileNotFoundError(f"robot file not found: {path}")
        try:
            array = np.load(path, allow_pickle=False)
        except (ValueError, OSError, EOFError) as error:
            reason = ("it is not a numeric array (numpy reads it as pickled objects, which "
                      "mjregen never loads)" if "pickle" in str(error) else str(error))
            raise GridFileError(f"{path} is not a valid .npy robot file: {reason}") from None
        if not isinstance(array, np.ndarray):
            raise GridFileError(f"{path} holds several arrays; a robot file holds one grid")
        try:
            return cls(array)
        except InvalidGridError as error:
            raise InvalidGridError(f"{path}: {error}") from None

    def to_text(self) -> str:
        """Readable layer-by-layer view: top layer first, rows of y (high first) in 3D."""
        counts = self.material_counts()
        size = "×".join(str(s) for s in self.shape)
        lines = [
            f"robot {size} ({self.dim}D), {self.n_voxels} voxels: "
            + ", ".join(f"{m.name.lower()} {counts[m]}" for m in list(Material)[1:]),
            "legend: " + "  ".join(f"{SYMBOLS[m]} {m.name.lower()}" for m in Material),
        ]
        if self.dim == 2:
            lines += _render_layer(self._grid, row_name="z")
            return "\n".join(lines)
        for z in reversed(range(self.shape[2])):
            layer = self._grid[:, :, z]
            if np.any(layer):
                lines.append(f"z = {z}")
                lines += _render_layer(layer, row_name="y")
        if self.is_empty:
            lines.append("(empty)")
        return "\n".join(lines)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Robot):
            return NotImplemented
        return self.shape == other.shape and bool(np.array_equal(self._grid, other._grid))

    def __hash__(self) -> int:
        return hash((self.shape, self._grid.tobytes()))

    def __repr__(self) -> str:
        return f"Robot(shape={self.shape}, voxels={self.n_voxels})"


def _render_layer(layer: np.ndarray, row_name: str) -> list[str]:
    """Rows of a 2D slice ``[x, row]``: highest row first, x left to right."""
    width = len(str(layer.shape[1] - 1))
    rows = []
    for row in reversed(range(layer.shape[1])):
        cells = " ".join(SYMBOLS[Material(int(code))] for code in layer[:, row])
        rows.append(f"  {row_name}={row:>{width}}  {cells}")
    return rows


def half_space_mask(shape: tuple[int, ...], condition: str) -> np.ndarray:
    """Bool array of `shape`, True where the cell index satisfies `condition`.

    Args:
      condition: ``"<axis> <op> <index>"``, axis x/y/z (x/z in 2D), op one of ``< <= > >=``,
        e.g. ``"x < 4"``.
    """
    axis, operator, index = _parse_half_space(condition, len(shape))
    coordinate = np.indices(shape)[axis]
    return {
        "<": coordinate < index,
        "<=": coordinate <= index,
        ">": coordinate > index,
        ">=": coordinate >= index,
    }[operator]


_HALF_SPACE = re.compile(r"^\s*([a-z])\s*(<=|>=|<|>)\s*(-?\d+)\s*$")


def _parse_half_space(condition: str, dim: int) -> tuple[int, str, int]:
    match = _HALF_SPACE.match(condition.lower())
    if match is None:
        raise InvalidGridError(
            f"cannot read half-space {condition!r}; write it like 'x < 4' (axis, one of "
            "< <= > >=, grid index)"
        )
    name, operator, index = match.groups()
    if name not in AXIS_NAMES[dim]:
        raise InvalidGridError(
            f"axis {name!r} does not exist in {dim}D; axes are {', '.join(AXIS_NAMES[dim])}"
        )
    return AXIS_NAMES[dim].index(name), operator, int(index)
