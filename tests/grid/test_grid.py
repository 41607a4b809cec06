"""Robot grids: validation, the paper's cleaning, similarity, damage, files, text view."""

import itertools
from pathlib import Path

import numpy as np
import pytest

from mjregen.errors import GridFileError, InvalidGridError
from mjregen.grid import Material, Robot, clean_grids, lay_flat

PAPER_ROBOTS = Path(__file__).resolve().parents[2] / "assets" / "robots" / "paper"


def _grid3(*voxels: tuple[int, int, int], size: int = 9, code: int = 1) -> np.ndarray:
    grid = np.zeros((size,) * 3, dtype=np.int8)
    for voxel in voxels:
        grid[voxel] = code
    return grid


# --- the paper's cleaning, literally as its code does it (the oracle) ----------------------


def _neighbour_offsets(dim: int) -> tuple[list[tuple[int, ...]], list[tuple[int, ...]]]:
    offsets = [o for o in itertools.product((-1, 0, 1), repeat=dim) if any(o)]
    face = [o for o in offsets if sum(map(abs, o)) == 1]
    other = [o for o in offsets if sum(map(abs, o)) > 1]
    return face, other


def _literal_clean(grid: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """The paper's loop: sweep A then sweep B, in index order, in place, until A removes
    nothing. Returns the cleaned grid and how many cells each sweep A removed."""
    grid = grid.copy()
    face, other = _neighbour_offsets(grid.ndim)
    interior = itertools.product(*(range(1, s - 1) for s in grid.shape))
    cells = list(interior)
    removed_by_a = []
    while True:
        removed = 0
        for cell in cells:
            if grid[cell]:
                n_face = sum(grid[tuple(c + o for c, o in zip(cell, off))] != 0 for off in face)
                n_other = sum(grid[tuple(c + o for c, o in zip(cell, off))] != 0 for off in other)
                if n_face == 0 and n_other != 0:
                    grid[cell] = 0
                    removed += 1
        for cell in cells:
            if grid[cell]:
                if all(grid[tuple(c + o for c, o in zip(cell, off))] == 0 for off in face + other):
                    grid[cell] = 0
        removed_by_a.append(removed)
        if removed == 0:
            return grid, removed_by_a


# --- validation -------------------------------------------------------------------------


@pytest.mark.parametrize(
    "values, message",
    [
        (np.zeros(9), "2D .* or 3D"),
        (np.zeros((3, 3, 3, 3)), "2D .* or 3D"),
        (np.zeros((9, 2, 9)), "too small"),
        (np.full((5, 5), np.nan), "NaN"),
        (np.where(np.pad(np.ones((3, 3)), 1) > 0, 1.5, 0.0), "non-integer"),
        (np.pad(np.full((3, 3), 5), 1), "unknown material code 5"),
        (np.pad(np.full((3, 3), -1), 1), "unknown material code -1"),
        (np.full((5, 5), "a"), "dtype"),
        (np.zeros((5, 5), dtype=bool), "dtype"),
        ([[0, 0, 0], [0, 1]], "rectangular"),
        (np.ones((5, 5), dtype=np.int8), "border"),
    ],
)
def test_bad_grids_raise_clear_errors(values, message):
    with pytest.raises(InvalidGridError, match=message):
        Robot(values)


def test_integral_floats_are_accepted_and_stored_as_int8():
    robot = Robot(np.pad(np.array([[1.0, 2.0], [3.0, 4.0]]), 1))
    assert robot.grid.dtype == np.int8
    assert robot.grid[1:3, 1:3].tolist() == [[1, 2], [3, 4]]


def test_robot_is_an_immutable_copy():
    source = _grid3((4, 4, 4))
    robot = Robot(source)
    source[4, 4, 4] = 0
    assert robot.n_voxels == 1
    with pytest.raises(ValueError):
        robot.grid[4, 4, 4] = 2


def test_from_body_pads_one_empty_cell_per_side():
    robot = Robot.from_body(np.ones((2, 3, 1), dtype=int))
    assert robot.shape == (4, 5, 3)
    assert robot.n_voxels == 6
    assert robot.grid[0].sum() == 0 and robot.grid[:, :, 0].sum() == 0


def test_counts():
    grid = _grid3((1, 1, 1), (1, 1, 2))
    grid[2, 1, 1] = Material.HARD
    grid[3, 1, 1] = Material.MUSCLE_MINUS
    robot = Robot(grid)
    counts = robot.material_counts()
    assert robot.n_voxels == 4 and not robot.is_empty
    assert counts[Material.SOFT] == 2 and counts[Material.HARD] == 1
    assert counts[Material.MUSCLE_PLUS] == 0 and counts[Material.MUSCLE_MINUS] == 1
    assert counts[Material.EMPTY] == 729 - 4
    assert list(robot.voxels())[2] == ((2, 1, 1), Material.HARD)
    assert Robot(np.zeros((9, 9, 9))).is_empty


# --- cleaning ------------------------------------------------------------------------------


def test_cleaning_removes_diagonal_only_cells():
    # Two cells touching along an edge, two touching at a corner: all four go.
    grid = _grid3((2, 2, 2), (3, 3, 2), (5, 5, 5), (6, 6, 6))
    assert Robot(grid).cleaned().is_empty


def test_cleaning_removes_isolated_cells_and_keeps_face_connected_pieces():
    grid = _grid3((1, 1, 1), (1, 1, 2), (6, 6, 6), (7, 6, 6), (4, 4, 4))
    cleaned = Robot(grid).cleaned().grid
    assert cleaned[4, 4, 4] == 0  # alone
    # two separate face-connected pairs both stay (only isolated cells are removed)
    assert cleaned[1, 1, 1] and cleaned[1, 1, 2] and cleaned[6, 6, 6] and cleaned[7, 6, 6]


def test_cleaning_removes_a_cell_hanging_on_an_edge_of_a_block():
    grid = _grid3(*itertools.product(range(2, 5), repeat=3))
    grid[5, 5, 4] = Material.HARD  # touches the block's edge at (4, 4, 4) only
    cleaned = Robot(grid).cleaned()
    assert cleaned.n_voxels == 27 and cleaned.grid[5, 5, 4] == 0


def test_cleaning_in_place_order_effect_and_result():
    # (1,1,1) and (2,2,1) touch only each other, along an edge. In place, sweep A removes
    # (1,1,1) first; (2,2,1) then touches nothing, so sweep A skips it and sweep B removes
    # it. A simultaneous sweep A would remove both. The result is the same: both gone.
    grid = _grid3((1, 1, 1), (2, 2, 1))
    cleaned, removed_by_a = _literal_clean(grid)
    assert removed_by_a == [1, 0]
    assert not cleaned.any()
    assert np.array_equal(clean_grids(grid, 3), cleaned)


def test_cleaning_2d():
    grid = np.zeros((7, 7), dtype=np.int8)
    grid[1, 1] = grid[2, 2] = 1  # diagonal-only pair
    grid[4, 4] = grid[4, 5] = 3  # face pair
    grid[1, 5] = 2  # isolated
    cleaned = Robot(grid).cleaned().grid
    assert cleaned.sum() == 6 and cleaned[4, 4] == 3 and cleaned[4, 5] == 3


@pytest.mark.parametrize("dim, size", [(3, 9), (2, 7)])
def test_fast_cleaning_equals_the_papers_sweeps_on_random_grids(dim, size):
    rng = np.random.default_rng(7)
    grids = []
    for density in (0.05, 0.15, 0.3, 0.5):
        for _ in range(25):
            body = rng.integers(1, 5, size=(size - 2,) * dim) * (rng.random((size - 2,) * dim) < density)
            grids.append(np.pad(body, 1).astype(np.int8))
    batch = clean_grids(np.stack(grids), dim)
    for grid, fast in zip(grids, batch):
        assert np.array_equal(fast, _literal_clean(grid)[0])


def test_paper_robots_are_already_clean():
    expected = {"biped": (233, 44, 2, 187, 0), "tripod": (68, 0, 22, 46, 0), "multiped": (203, 0, 24, 174, 5)}
    for name, (voxels, *materials) in expected.items():
        robot = Robot.load(PAPER_ROBOTS / f"{name}.npy")
        counts = robot.material_counts()
        assert (robot.n_voxels, *[counts[m] for m in list(Material)[1:]]) == (voxels, *materials)
        assert robot.cleaned() == robot, name


# --- similarity and damage -----------------------------------------------------------------


def test_similarity_counts_equal_cells_out_of_the_grid():
    a = Robot(_grid3((4, 4, 4), (4, 4, 5)))
    b = Robot(_grid3((4, 4, 4), (4, 5, 4)))
    assert a.similarity(a) == 729
    assert a.similarity(b) == 727
    with pytest.raises(InvalidGridError, match="shapes"):
        a.similarity(Robot(np.zeros((7, 7))))


def test_half_space_damage_removes_exactly_that_half():
    robot = Robot(np.pad(np.ones((7, 7, 7), dtype=np.int8), 1))
    cut = robot.remove_half_space("x < 4")  # the paper's cut: x indices 0..3
    assert cut.grid[:4].sum() == 0 and np.array_equal(cut.grid[4:], robot.grid[4:])
    assert cut.n_voxels == 343 - 3 * 49
    assert robot.similarity(cut) == 729 - 3 * 49
    top = robot.remove_half_space("z >= 6")
    assert top.n_voxels == 343 - 2 * 49 and top.grid[:, :, 6:].sum() == 0
    flat = Robot(np.pad(np.ones((5, 5), dtype=np.int8), 1)).remove_half_space("z>3")
    assert flat.n_voxels == 5 * 3


@pytest.mark.parametrize("condition, message", [("y < 2", "does not exist in 2D"), ("x 4", "cannot read")])
def test_bad_half_space(condition, message):
    with pytest.raises(InvalidGridError, match=message):
        Robot(np.zeros((7, 7))).remove_half_space(condition)


# --- files ---------------------------------------------------------------------------------


def test_npy_round_trip(tmp_path):
    robot = Robot(_grid3((4, 4, 4), (4, 4, 5), code=3))
    path = robot.save(tmp_path / "sub" / "robot.npy")
    loaded = Robot.load(path)
    assert loaded == robot and hash(loaded) == hash(robot)
    assert np.load(path).dtype == np.int8


def test_save_never_clobbers(tmp_path):
    first, second = Robot(_grid3((4, 4, 4))), Robot(_grid3((3, 3, 3), code=2))
    path = first.save(tmp_path / "robot.npy")
    with pytest.raises(FileExistsError, match="overwrite"):
        second.save(path)
    assert Robot.load(path) == first
    second.save(path, overwrite=True)
    assert Robot.load(path) == second
    assert [p.name for p in tmp_path.iterdir()] == ["robot.npy"]  # no temporary left


def test_load_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="not found"):
        Robot.load(tmp_path / "missing.npy")
    with pytest.raises(GridFileError, match=".npy"):
        Robot.load(tmp_path / "robot.txt")
    corrupt = tmp_path / "corrupt.npy"
    corrupt.write_bytes(b"\x93NUMPY garbage")
    with pytest.raises(GridFileError, match="not a valid"):
        Robot.load(corrupt)
    pickled = tmp_path / "object.npy"
    np.save(pickled, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(GridFileError, match="not a valid"):
        Robot.load(pickled)
    nan = tmp_path / "nan.npy"
    np.save(nan, np.full((5, 5), np.nan))
    with pytest.raises(InvalidGridError, match="nan.npy.*NaN"):
        Robot.load(nan)
    with pytest.raises(GridFileError, match=".npy"):
        Robot(np.zeros((5, 5))).save(tmp_path / "robot.txt")


# --- text view -----------------------------------------------------------------------------


def test_text_view_shows_layers_top_first_with_symbols():
    grid = _grid3((1, 1, 1), size=5)
    grid[2, 1, 1] = Material.HARD
    grid[1, 2, 1] = Material.MUSCLE_PLUS
    grid[1, 1, 2] = Material.MUSCLE_MINUS
    lines = Robot(grid).to_text().splitlines()
    assert "4 voxels" in lines[0]
    layer2 = lines.index("z = 2")
    layer1 = lines.index("z = 1")
    assert layer2 < layer1  # top layer first
    # rows run from high y to low y; x left to right
    assert lines[layer1 + 1:layer1 + 6] == [
        "  y=4  . . . . .",
        "  y=3  . . . . .",
        "  y=2  . + . . .",
        "  y=1  . s H . .",
        "  y=0  . . . . .",
    ]
    assert lines[layer2 + 4] == "  y=1  . - . . ."


def test_text_view_2d():
    grid = np.zeros((5, 4), dtype=np.int8)
    grid[1, 1] = grid[2, 1] = 1
    grid[1, 2] = 2
    lines = Robot(grid).to_text().splitlines()
    assert lines[2:] == ["  z=3  . . . . .", "  z=2  . H . . .", "  z=1  . s s . .", "  z=0  . . . . ."]


def test_mirror_axes_of_a_body_are_found_in_its_bounding_box():
    plate = np.zeros((7, 7, 7), dtype=np.int8)
    plate[2:5, 2, 1:3] = 3  # one voxel thick in y, off-centre in the grid
    assert Robot(plate).mirror_axes() == ("x", "y")
    plate[2, 2, 1] = 4  # a different material at one end: no longer mirrored in x
    assert Robot(plate).mirror_axes() == ("y",)
    plate[2:5, 3, 1] = 1  # a second, partial layer: no mirror plane across y either
    assert Robot(plate).mirror_axes() == ()


def test_mirror_axes_are_horizontal_only():
    """A 2D robot mirrors across x only (z is up: a body symmetric top to bottom is not a
    symmetry of its walk); an empty robot has none."""
    sheet = np.zeros((7, 7), dtype=np.int8)
    sheet[2:5, 1:4] = 1  # symmetric in x and in z
    assert Robot(sheet).mirror_axes() == ("x",)
    sheet[2, 1] = 3
    assert Robot(sheet).mirror_axes() == ()
    assert Robot(np.zeros((9, 9, 9), dtype=np.int8)).mirror_axes() == ()


def test_a_pattern_laid_flat_is_one_layer_on_the_floor():
    pattern = np.zeros((7, 7), dtype=np.int8)
    pattern[1:6, 2] = Material.MUSCLE_PLUS
    pattern[3, 1:6] = Material.HARD
    sheet = lay_flat(pattern)
    assert sheet.shape == (7, 7, 3) and sheet.dtype == np.int8
    assert np.array_equal(sheet[:, :, 1], pattern)
    assert not sheet[:, :, 0].any() and not sheet[:, :, 2].any()
    robot = Robot(sheet)
    assert robot.dim == 3 and robot.n_voxels == np.count_nonzero(pattern)
    batch = lay_flat(np.stack([pattern, pattern.T]))
    assert batch.shape == (2, 7, 7, 3) and np.array_equal(batch[1, :, :, 1], pattern.T)
    with pytest.raises(InvalidGridError, match=r"needs 2 axes \[x, y\], got shape \(7,\)"):
        lay_flat(pattern[0])
