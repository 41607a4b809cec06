"""Pictures of a MAP-Elites archive: the fitness of each cell's elite as a heatmap, and the
QD score and coverage per iteration."""

from __future__ import annotations

import os
from typing import Sequence

import numpy as np

from mjregen.plotting import save_png


def archive_heatmap(fitness: np.ndarray, names: Sequence[str],
                    ranges: Sequence[tuple[float, float]], path: str | os.PathLike,
                    *, title: str | None = None) -> None:
    """PNG of the best fitness per cell over the first two descriptors (over the first one
    and nothing else for one descriptor); further descriptors are maximised over.

    Args:
      fitness: float ``cells`` (one axis per descriptor), NaN where a cell is empty.
      names, ranges: each descriptor's name and (low, high).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fitness = np.asarray(fitness, dtype=np.float64)
    if fitness.ndim == 1:
        fitness = fitness[:, None]
        y_name, y_range = "", (0.0, 1.0)
    else:
        y_name, y_range = names[1], ranges[1]
    if fitness.ndim > 2:
        filled = ~np.isnan(fitness)
        folded = np.where(filled, fitness, -np.inf).max(axis=tuple(range(2, fitness.ndim)))
        fitness = np.where(np.isinf(folded), np.nan, folded)
    figure = Figure(figsize=(6.4, 4.8), dpi=100)
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    image = ax.imshow(np.ma.masked_invalid(fitness.T), origin="lower", aspect="auto",
                      interpolation="nearest", cmap="viridis",
                      extent=(*ranges[0], *y_range))
    figure.colorbar(image, ax=ax, label="fitness of the cell's elite")
    ax.set_xlabel(names[0])
    ax.set_ylabel(y_name)
    if not y_name:
        ax.set_yticks([])
    folded_note = f" (best over {', '.join(names[2:])})" if len(names) > 2 else ""
    ax.set_title((title or "archive") + folded_note, fontsize=10)
    save_png(figure, path)


def qd_curves(rows: Sequence[dict], path: str | os.PathLike, *, title: str | None = None) -> None:
    """PNG of QD score and coverage per iteration from metrics.csv rows."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    iterations = [int(r["iteration"]) for r in rows]
    figure = Figure(figsize=(9, 3.6), dpi=100)
    FigureCanvasAgg(figure)
    for k, (column, label) in enumerate((("qd_score", "QD score"), ("coverage", "coverage"))):
        ax = figure.add_subplot(1, 2, k + 1)
        ax.plot(iterations, [float(r[column]) for r in rows])
        ax.set(xlabel="iteration", ylabel=label)
        ax.grid(alpha=0.3)
        if title:
            ax.set_title(title, fontsize=10)
    save_png(figure, path)
