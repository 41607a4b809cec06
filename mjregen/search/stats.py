"""Statistics over several evolution runs: mean best fitness (MAP-Elites runs: also QD
score and coverage) with bootstrapped 95 % CIs (the paper's Fig. 3b/4b style), read from
the runs' metrics.csv files. Below `MIN_CI_RUNS` runs the band is the runs' range instead:
a percentile bootstrap of so few values covers far less than its level (two runs: their
range, whatever the level)."""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mjregen.errors import MjregenError
from mjregen.plotting import save_png

MIN_CI_RUNS = 5  # runs below which a band is the runs' range, not a bootstrap CI


@dataclass(frozen=True)
class CurveStats:
    """Per generation over runs: ``generations (G,)``, ``mean, low, high (G,)``, n runs,
    what low and high are (`band`: "95 % CI", or "range" below MIN_CI_RUNS runs), and each
    run's own length (longer runs are cut to G)."""

    generations: np.ndarray
    mean: np.ndarray
    low: np.ndarray
    high: np.ndarray
    n_runs: int
    run_lengths: tuple[int, ...] = ()
    band: str = "95 % CI"

    @property
    def truncated(self) -> bool:
        """Some runs had more generations than the curves show."""
        return any(n > len(self.generations) for n in self.run_lengths)


def run_kind(run: str | Path) -> str:
    """What a run folder evolved for: its config.json's task ("locomotion", "regrowth")."""
    path = Path(run) / "config.json"
    try:
        return str(json.loads(path.read_text())["task"]["task"])
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise MjregenError(f"{path}: cannot tell what the run evolved for ({error})") from None


def is_map_elites_run(run: str | Path) -> bool:
    """The run folder holds a MAP-Elites run (its config.json has "map_elites" settings)."""
    path = Path(run) / "config.json"
    try:
        return "map_elites" in json.loads(path.read_text())
    except (OSError, ValueError, TypeError) as error:
        raise MjregenError(f"{path}: cannot read the run's configuration ({error})") from None


def read_curve(run: str | Path, column: str = "best") -> np.ndarray:
    """One column of a run's metrics.csv as float ``(generations,)``."""
    path = Path(run) / "metrics.csv"
    if not path.is_file():
        raise FileNotFoundError(f"no metrics.csv in {run}")
    with path.open() as handle:
        rows = list(csv.DictReader(handle))
    if not rows or column not in rows[0]:
        raise MjregenError(f"{path} has no rows or no column {column!r}")
    return np.array([float(r[column]) for r in rows])


def bootstrap_curves(curves: np.ndarray, *, resamples: int = 10_000, confidence: float = 0.95,
                     seed: int = 0) -> CurveStats:
    """Mean over runs and its percentile-bootstrap CI, per generation; with fewer than
    MIN_CI_RUNS runs, their range (`CurveStats.band` says which).

    Args:
      curves: ``(runs, generations)``.
    """
    curves = np.asarray(curves, dtype=np.float64)
    if curves.ndim != 2 or curves.shape[0] < 1:
        raise ValueError(f"curves must be (runs, generations), got shape {curves.shape}")
    if curves.shape[0] < MIN_CI_RUNS:
        return CurveStats(np.arange(curves.shape[1]), curves.mean(axis=0), curves.min(axis=0),
                          curves.max(axis=0), curves.shape[0], band="range")
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, curves.shape[0], size=(resamples, curves.shape[0]))
    means = curves[picks].mean(axis=1)  # (resamples, generations)
    tail = (1.0 - confidence) / 2.0 * 100.0
    low, high = np.percentile(means, [tail, 100.0 - tail], axis=0)
    return CurveStats(np.arange(curves.shape[1]), curves.mean(axis=0), low, high, curves.shape[0],
                      band=f"{confidence:.0%} CI".replace("%", " %"))


def group_stats(runs: list[str | Path], column: str = "best", **kwargs: object) -> CurveStats:
    """`bootstrap_curves` of several runs of one kind, cut to the shortest run's length
    (`CurveStats.truncated` says whether that cut anything).

    Raises:
      MjregenError: the runs evolved for different tasks (their fitnesses do not compare).
    """
    kinds = {str(run): run_kind(run) for run in runs}
    if len(set(kinds.values())) > 1:
        raise MjregenError("the runs evolved for different tasks, whose fitnesses do not "
                           f"compare: {', '.join(f'{r} ({k})' for r, k in kinds.items())}")
    curves = [read_curve(run, column) for run in runs]
    length = min(len(c) for c in curves)
    stats = bootstrap_curves(np.stack([c[:length] for c in curves]), **kwargs)
    return replace(stats, run_lengths=tuple(len(c) for c in curves))


def plot_panels(panels: dict[str, dict[str, CurveStats]], path: str | Path, *,
                xlabel: str = "generation") -> None:
    """One panel per metrics column ({column: {group label: stats}}), each with the groups'
    mean curves and shaded bands (CIs, or ranges of few runs), side by side in one PNG."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(6 * len(panels), 4), dpi=100)
    FigureCanvasAgg(figure)
    for k, (column, groups) in enumerate(panels.items()):
        ax = figure.add_subplot(1, len(panels), k + 1)
        ax.set(xlabel=xlabel, ylabel=column)
        ax.grid(alpha=0.3)
        for label, stats in groups.items():
            line, = ax.plot(stats.generations, stats.mean,
                            label=f"{label} (n={stats.n_runs}; shaded: {stats.band})")
            ax.fill_between(stats.generations, stats.low, stats.high, color=line.get_color(),
                            alpha=0.25)
    save_png(figure, path)
