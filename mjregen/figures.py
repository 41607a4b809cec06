"""Figures of robot grids: the paper's material colours, growth sequences and galleries of a
MAP-Elites archive's elites, as PNG."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

import numpy as np

from mjregen.fileio import atomic_open
from mjregen.grid import Material, Robot
from mjregen.physics import Physics
from mjregen.physics.mjcf import MATERIAL_RGBA

if TYPE_CHECKING:
    from mjregen.search.map_elites import ArchiveSnapshot


def growth_figure(states: np.ndarray, path: str | os.PathLike, *, overwrite: bool = False,
                  columns: int = 6, titles: Sequence[str] | None = None) -> Path:
    """PNG of the grid at every growth step (3D: voxel plots; 2D: images, z up).

    Args:
      states: int ``(T, X, Y, Z)`` or ``(T, X, Z)`` material codes, e.g.
        ``nca.grow().states[0]``; T >= 1.
      path: ``.png`` file to write (atomically).
      overwrite: replace an existing file.
      columns: panels per row.
      titles: one per state; None = "step k".
    Raises:
      InvalidGridError: a state is not a valid grid.
      ValueError: `path` is not ``.png``, `states` has the wrong number of dimensions, or
        `titles` the wrong length.
      OutputExistsError: `path` exists and not `overwrite`.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from mjregen.grid import validate_grid

    path = Path(path)
    if path.suffix != ".png":
        raise ValueError(f"growth figures are .png files; got {str(path)!r}")
    states = np.asarray(states)
    if states.ndim not in (3, 4) or len(states) == 0:
        raise ValueError(f"states must be (steps, *grid) of 2D or 3D grids, got {states.shape}")
    grids = [validate_grid(state) for state in states]
    titles = [f"step {k}" for k in range(len(grids))] if titles is None else list(titles)
    if len(titles) != len(grids):
        raise ValueError(f"{len(titles)} titles for {len(grids)} states")
    dim = grids[0].ndim
    rgba = np.zeros((len(Material), 4))
    rgba[Material.EMPTY] = (1.0, 1.0, 1.0, 1.0)
    for material, colour in MATERIAL_RGBA.items():
        rgba[material] = colour
    columns = min(columns, len(grids))
    rows = -(-len(grids) // columns)
    figure = Figure(figsize=(2.4 * columns, 2.6 * rows))
    FigureCanvasAgg(figure)
    for step, (grid, name) in enumerate(zip(grids, titles)):
        title = f"{name}: {np.count_nonzero(grid)} voxels"
        if dim == 3:
            ax = figure.add_subplot(rows, columns, step + 1, projection="3d")
            ax.voxels(grid != 0, facecolors=rgba[grid], edgecolor=(0, 0, 0, 0.3), linewidth=0.3)
            ax.set(xlim=(0, grid.shape[0]), ylim=(0, grid.shape[1]), zlim=(0, grid.shape[2]),
                   xticks=[], yticks=[], zticks=[])
            ax.set_box_aspect(grid.shape)
        else:
            ax = figure.add_subplot(rows, columns, step + 1)
            ax.imshow(rgba[grid.T], origin="lower", interpolation="nearest")
            ax.set(xticks=[], yticks=[], xlabel="x", ylabel="z")
        ax.set_title(title, fontsize=9)
    figure.tight_layout()
    with atomic_open(path, overwrite=overwrite) as handle:
        figure.savefig(handle, format="png", dpi=100)
    return path


def regrowth_figures(robots: dict[str, Robot], regrowth_states: np.ndarray,
                     folder: str | os.PathLike) -> list[Path]:
    """A regrowth run's pictures in `folder` (replaced if present): ``robots.png`` (the
    original, damaged and regrown robots) and ``regrowth.png`` (the regrowth's steps).

    Args:
      robots: {role: robot}, e.g. `mjregen.experiments.regrowth.RegrowthRun.robots`.
      regrowth_states: int ``(T, ...)`` grids of the regrowth's steps, e.g.
        ``run.regrowth.states[0]``.
    """
    folder = Path(folder)
    steps = growth_figure(regrowth_states, folder / "regrowth.png", overwrite=True,
                          titles=[f"regrowth step {i}" for i in range(len(regrowth_states))])
    trio = growth_figure(np.stack([robot.grid for robot in robots.values()]),
                         folder / "robots.png", overwrite=True,
                         titles=[f"{role}: {robot.n_voxels} voxels"
                                 for role, robot in robots.items()])
    return [trio, steps]


def pick_elites(snapshot: ArchiveSnapshot, count: int) -> list[int]:
    """Rows of up to `count` elites (robots with voxels, its extra field "grid") spread
    across the map: the map's first two descriptor axes cut into about `count` tiles, the
    fittest elite of each tile (the fittest tiles' when more are filled), ordered by the
    first descriptor."""
    if len(snapshot.index) == 0 or count < 1:
        return []
    coords = np.stack(np.unravel_index(snapshot.index, snapshot.cells), axis=1)[:, :2]
    shape = snapshot.cells[:2]
    per_axis = max(1, int(np.ceil(count ** (1.0 / len(shape)))))
    tiles = [tuple(c * per_axis // n for c, n in zip(row, shape)) for row in coords]
    robots = snapshot.extra["grid"].reshape(len(coords), -1)
    best: dict[tuple, int] = {}
    for row, tile in enumerate(tiles):
        if not robots[row].any():  # an empty robot is no morphology
            continue
        if tile not in best or snapshot.fitness[row] > snapshot.fitness[best[tile]]:
            best[tile] = row
    rows = sorted(best.values(), key=lambda r: -snapshot.fitness[r])[:count]
    return sorted(rows, key=lambda r: (snapshot.descriptors[r, 0], -snapshot.fitness[r]))


def elite_gallery(snapshot: ArchiveSnapshot, descriptors: Sequence[str],
                  path: str | os.PathLike, *, count: int = 12, physics: Physics | None = None,
                  overwrite: bool = False) -> Path:
    """PNG of up to `count` elites from across a MAP-Elites archive (`pick_elites`; its
    robots in the extra field "grid"), each rendered in its initial pose and titled with its
    fitness and its `descriptors` (their names, in the snapshot's order).

    Raises:
      ValueError: the archive is empty or `path` is not ``.png``.
      OutputExistsError: `path` exists and not `overwrite`.
      mjregen.render.GLBackendError: no OpenGL backend can render.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from mjregen.physics.compile import compile_robot
    from mjregen.render import RobotRenderer, View

    path = Path(path)
    if path.suffix != ".png":
        raise ValueError(f"a gallery is a .png file; got {str(path)!r}")
    rows = pick_elites(snapshot, count)
    if not rows:
        raise ValueError("the archive holds no robot with voxels to draw")
    columns = min(4, len(rows))
    lines = -(-len(rows) // columns)
    figure = Figure(figsize=(3.2 * columns, 2.9 * lines))
    FigureCanvasAgg(figure)
    for k, row in enumerate(rows):
        robot = Robot(snapshot.extra["grid"][row])
        ax = figure.add_subplot(lines, columns, k + 1)
        ax.set(xticks=[], yticks=[])
        described = ", ".join(f"{name} {value:.3g}" for name, value
                              in zip(descriptors, snapshot.descriptors[row]))
        ax.set_title(f"fitness {snapshot.fitness[row]:.2f}\n{described}", fontsize=8)
        with RobotRenderer(compile_robot(robot, physics=physics),
                           view=View(width=320, height=240)) as renderer:
            ax.imshow(renderer.render())
    figure.tight_layout()
    with atomic_open(path, overwrite=overwrite) as handle:
        figure.savefig(handle, format="png", dpi=100)
    return path
