"""Line plots written as PNG files, without pyplot's global state (safe in any thread)."""

from __future__ import annotations

import os

from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from mjregen.fileio import atomic_open


def line_axes(*, xlabel: str, ylabel: str, title: str | None = None) -> tuple[Figure, Axes]:
    """A 6×4 inch figure with one set of labelled axes."""
    figure = Figure(figsize=(6, 4), dpi=100)
    FigureCanvasAgg(figure)
    ax = figure.add_subplot()
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.grid(alpha=0.3)
    return figure, ax


def save_png(figure: Figure, path: str | os.PathLike) -> None:
    """Add the legend, lay out and write `figure` to `path` atomically."""
    for ax in figure.axes:
        if ax.get_legend_handles_labels()[0]:
            ax.legend()
    figure.tight_layout()
    with atomic_open(path) as handle:
        figure.savefig(handle, format="png")
