"""MAP-Elites runs on disk: one output folder per run, resumable after a kill, like the GA's
(`mjregen.search.runs`; shared rules in `mjregen.search.run_folder`).

The folder holds
  config.json     everything that determines the run (task, "map_elites" settings, seed)
  metrics.csv     one row per iteration (see `QD_METRICS`)
  archive.npz     the archive after the last finished iteration (`read_archive`): each
                  elite's genome, fitness, descriptors, cell and robot grid, with the
                  descriptors' names, ranges and cells and the NCA's configuration
  best.npz, best.npy   the best elite so far as an NCA checkpoint, and its robot
  heatmap.png     fitness of each cell's elite; qd.png: QD score and coverage per iteration
                  (both redrawn every `run_loop.PLOT_EVERY` s and after the last iteration)
  checkpoint.npz  the search after the last finished iteration (its ribs scheduler, pickled),
                  written atomically, with the hash of config.json
  errors.log      the evaluations that failed (only when some failed)
A killed run continues from `checkpoint.npz` with ``resume=True`` and produces exactly the
results of an uninterrupted run. A finished run kept without its checkpoint (a record,
`scripts/snapshot_runs.py`) resumes to its summary at once; an unfinished one listing more
than one iteration without it is an error (its files are left as they are). Unstable and
failed robots enter the archive with their penalty fitness (any working robot of their cell
replaces them).
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable, Protocol

import numpy as np

from mjregen import __version__
from mjregen.errors import CheckpointError
from mjregen.fileio import atomic_open
from mjregen.grid import Robot
from mjregen.growth.checkpoint import save_nca
from mjregen.growth.nca import NCA, NCAConfig
from mjregen.search.archive_plots import archive_heatmap, qd_curves
from mjregen.search.backends import Backend
from mjregen.search.map_elites import (
    ArchiveSnapshot,
    MapElites,
    MapElitesConfig,
    import_ribs,
)
from mjregen.search.run_folder import (
    EVALUATION_COLUMNS,
    RUN_FORMAT,
    RunFolderError,
    config_hash,
    evaluation_columns,
    load_checkpoint,
    prepare_folder,
    read_metrics,
    save_checkpoint,
)
from mjregen.search.run_lock import RunLock
from mjregen.search.run_loop import run_steps
from mjregen.search.runs import Task
from mjregen.tasks.descriptors import describe, descriptor_ranges
from mjregen.tasks.evaluation import PopulationEvaluation

QD_METRICS = ("iteration", "qd_score", "coverage", "elites", "best", "batch_best",
              "batch_mean", *EVALUATION_COLUMNS)
ARCHIVE_FORMAT = "mjregen-archive-1"


class QDTask(Task, Protocol):
    """What a MAP-Elites run evaluates: an evolution's task (genomes of an NCA -> fitness
    and grown robots) that also names its lowest fitness."""

    lowest_fitness: float  # below every fitness the task gives (the QD score's offset)


@dataclass(frozen=True)
class QDRunSummary:
    """Outcome of `run_map_elites`: the archive's size and best."""

    out: Path
    iterations: int
    best_fitness: float
    qd_score: float
    coverage: float
    elites: int


def run_map_elites(task: QDTask, config: MapElitesConfig, *, seed: int, out: str | Path,
                   backend: Backend, resume: bool = False,
                   force: bool = False, progress: bool = True,
                   on_iteration: Callable[[dict], None] | None = None) -> QDRunSummary:
    """Search `task` with MAP-Elites, writing the run folder `out` (module docstring).

    Args:
      task: what to evaluate (e.g. `mjregen.tasks.locomotion.LocomotionTask`).
      config: the search's settings, descriptors and cells included.
      seed: seeds every random generator of the search.
      out: the run folder.
      backend: where simulations run; results do not depend on it.
      resume, force: as for `mjregen.search.runs.run_evolution`.
      progress: a tqdm bar with the QD score and the best fitness.
      on_iteration: called with each iteration's metrics row.
    Raises:
      RunFolderError: `out` holds another run, there is nothing to resume, its config was
        edited, it lists more than one iteration but has no checkpoint and is unfinished,
        or `force` is asked to delete a folder that is not a run folder.
      RunFailedError: every evaluation of an iteration failed.
      CheckpointError: the checkpoint cannot be read.
      mjregen.search.map_elites.MissingRibsError: ribs is not installed (nothing is written).
      ValueError: `seed` is not a whole number >= 0 (nothing is written).
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a whole number >= 0, got {seed!r}")
    import_ribs()  # before anything is written
    out = Path(out)
    run_config = {
        "format": RUN_FORMAT, "task": task.to_config(), "map_elites": config.to_dict(),
        "seed": int(seed), "mjregen_version": __version__,
        "created": datetime.now(timezone.utc).isoformat(),
    }
    shape = (task.nca.grid_size,) * task.nca.dim
    ranges = descriptor_ranges(config.descriptors, shape)
    with RunLock(out):
        resumed = prepare_folder(out, run_config, resume=resume, force=force,
                                 task_class=type(task))
        started_with = config_hash(out / "config.json")
        finished = None if resumed or not resume else _finished_record(out, config.iterations)
        if finished is not None:
            return finished
        if resumed:
            search = _checkpoint_load(out / "checkpoint.npz")
        else:
            search = MapElites(config, task.nca.genome_size, ranges=ranges, seed=int(seed),
                               qd_score_offset=task.lowest_fitness,
                               extra_fields={"grid": (shape, np.int8)})
        steps = IterationSteps(search, task=task, out=out, seed=int(seed), ranges=ranges,
                               started_with=started_with)
        run_steps(steps, task, out=out, backend=backend, progress=progress,
                  description=f"MAP-Elites {out.name}", unit="it", on_step=on_iteration)
        return steps.summary()


class IterationSteps:
    """MAP-Elites' side of a run folder (`mjregen.search.run_loop.SearchSteps`): the archive,
    the best elite, the heatmap and QD curves, and the checkpoint."""

    counter = "iteration"
    columns = QD_METRICS

    def __init__(self, search: MapElites, *, task: QDTask, out: Path, seed: int,
                 ranges: list[tuple[float, float]], started_with: str) -> None:
        self.search, self._task, self._out, self._seed = search, task, out, seed
        self._ranges, self._started_with = ranges, started_with
        self._snapshot, self._stats = search.snapshot(), search.stats()  # the last step's

    @property
    def done(self) -> int:
        return self.search.iteration

    @property
    def total(self) -> int:
        return self.search.config.iterations

    def restore(self) -> None:
        """A missing archive.npz is written again from the checkpoint's state."""
        if self.done and not (self._out / "archive.npz").is_file():
            save_archive(self._out / "archive.npz", self.search.snapshot(), self.search.config,
                         self._ranges, self._task.nca)

    def ask(self) -> np.ndarray:
        return self.search.ask()

    def tell(self, genomes: np.ndarray, result: PopulationEvaluation) -> None:
        search, out = self.search, self._out
        iteration, best_before = search.iteration, search.stats()["best"]
        search.tell(result.fitness, describe(result.grids, search.config.descriptors),
                    grid=result.grids)
        self._snapshot = snapshot = search.snapshot()
        save_archive(out / "archive.npz", snapshot, search.config, self._ranges, self._task.nca)
        self._stats = stats = search.stats()
        if not stats["best"] <= best_before:  # improved (or the first iteration)
            _save_best(out, self._task.nca, snapshot, seed=self._seed, iteration=iteration)

    def metrics_row(self, result: PopulationEvaluation, *, step: int, wall: float,
                    elapsed: float) -> dict:
        return _metrics_row(self._stats, result, iteration=step, wall=wall, elapsed=elapsed)

    def draw(self, rows: list[dict]) -> None:
        out = self._out
        archive_heatmap(self._snapshot.fitness_grid(), self.search.config.descriptors,
                        self._ranges, out / "heatmap.png", title=out.name)
        qd_curves(rows, out / "qd.png", title=out.name)

    def save_checkpoint(self) -> None:
        _checkpoint_save(self._out / "checkpoint.npz", self.search, self._started_with)

    def postfix(self) -> dict[str, str]:
        return {"qd": f"{self._stats['qd_score']:.1f}", "best": f"{self._stats['best']:.3f}"}

    def summary(self) -> QDRunSummary:
        """The run's outcome so far."""
        stats = self.search.stats()
        return QDRunSummary(out=self._out, iterations=self.done, best_fitness=stats["best"],
                            qd_score=stats["qd_score"], coverage=stats["coverage"],
                            elites=stats["elites"])


def _finished_record(out: Path, iterations: int) -> QDRunSummary | None:
    """The summary of a finished run in `out` kept without its checkpoint: QD score,
    coverage and elites of metrics.csv's last row, the best fitness from best.npz. None when
    metrics.csv lists at most one of more iterations: a run killed in its first iteration
    (metrics.csv is written before the checkpoint), which starts again.

    Raises:
      RunFolderError: metrics.csv lists more than one iteration but fewer than
        `iterations` (nothing to continue from), or best.npz is missing or unreadable.
    """
    from mjregen.growth.checkpoint import load_nca

    rows = read_metrics(out / "metrics.csv", "iteration", iterations)
    if len(rows) <= 1 < iterations:
        return None
    if len(rows) < iterations:
        raise RunFolderError(f"{out} lists {len(rows)} of {iterations} iterations but has no "
                             "checkpoint.npz to continue from; its files are left as they are")
    try:
        best = float(load_nca(out / "best.npz")[1]["fitness"])
    except (FileNotFoundError, CheckpointError) as error:
        raise RunFolderError(f"{out} is finished but its best elite cannot be read: "
                             f"{error}") from None
    last = rows[-1]
    return QDRunSummary(out=out, iterations=iterations, best_fitness=best,
                        qd_score=float(last["qd_score"]), coverage=float(last["coverage"]),
                        elites=int(last["elites"]))


def _metrics_row(stats: dict, result: PopulationEvaluation, *, iteration: int, wall: float,
                 elapsed: float) -> dict:
    """An iteration's metrics.csv row (`QD_METRICS`)."""
    fitness = result.fitness
    return {
        "iteration": iteration, "qd_score": f"{stats['qd_score']:.8g}",
        "coverage": f"{stats['coverage']:.6g}", "elites": stats["elites"],
        "best": f"{stats['best']:.6g}", "batch_best": f"{fitness.max():.6g}",
        "batch_mean": f"{fitness.mean():.6g}",
        **evaluation_columns(result, wall=wall, elapsed=elapsed),
    }


def _save_best(out: Path, nca: NCAConfig, snapshot: ArchiveSnapshot, *, seed: int,
               iteration: int) -> None:
    """The archive's best elite as ``best.npz`` (NCA checkpoint) and ``best.npy`` (robot)."""
    top = int(np.argmax(snapshot.fitness))
    metadata = {"iteration": iteration, "fitness": float(snapshot.fitness[top]), "seed": seed,
                "cell": int(snapshot.index[top]),
                "descriptors": [float(v) for v in snapshot.descriptors[top]]}
    save_nca(out / "best.npz", NCA(nca, snapshot.genomes[top]), metadata=metadata,
             overwrite=True)
    Robot(snapshot.extra["grid"][top]).save(out / "best.npy", overwrite=True)


def save_archive(path: Path, snapshot: ArchiveSnapshot, config: MapElitesConfig,
                 ranges: list[tuple[float, float]], nca: NCAConfig) -> None:
    """Write the archive's elites to `path` atomically (read with `read_archive`)."""
    meta = {"descriptors": list(config.descriptors), "cells": list(config.cells),
            "ranges": [list(r) for r in ranges], "nca": nca.to_dict()}
    with atomic_open(path) as handle:
        np.savez(handle, format=np.array(ARCHIVE_FORMAT), meta=np.array(json.dumps(meta)),
                 index=snapshot.index, genomes=snapshot.genomes, fitness=snapshot.fitness,
                 descriptors=snapshot.descriptors,
                 **{f"extra_{k}": v for k, v in snapshot.extra.items()})


@dataclass(frozen=True)
class StoredArchive:
    """A run's archive.npz: its elites and what its cells mean."""

    snapshot: ArchiveSnapshot
    descriptors: tuple[str, ...]
    ranges: tuple[tuple[float, float], ...]
    nca: NCAConfig

    def nca_of(self, elite: int) -> NCA:
        """The NCA of elite row `elite`."""
        return NCA(self.nca, self.snapshot.genomes[elite])


def read_archive(path: str | Path) -> StoredArchive:
    """A MAP-Elites run's archive.npz.

    Raises:
      CheckpointError: missing, corrupt, or not an archive file.
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            if str(data["format"]) != ARCHIVE_FORMAT:
                raise CheckpointError(f"{path} is not a MAP-Elites archive")
            meta = json.loads(str(data["meta"]))
            snapshot = ArchiveSnapshot(
                index=data["index"], genomes=data["genomes"], fitness=data["fitness"],
                descriptors=data["descriptors"], cells=tuple(meta["cells"]),
                extra={k[len("extra_"):]: data[k] for k in data.files if k.startswith("extra_")})
            nca = NCAConfig.from_dict(meta["nca"])
    except (KeyError, ValueError, TypeError, OSError, EOFError, zipfile.BadZipFile) as error:
        raise CheckpointError(f"cannot read MAP-Elites archive {path}: {error}") from None
    return StoredArchive(snapshot=snapshot, descriptors=tuple(meta["descriptors"]),
                         ranges=tuple(tuple(r) for r in meta["ranges"]), nca=nca)


def _checkpoint_save(path: Path, search: MapElites, config_sha256: str) -> None:
    """The search's state (`save_checkpoint`)."""
    ribs = import_ribs()
    save_checkpoint(path, state={"iteration": search.iteration, "ribs_version": ribs.__version__},
                    arrays={"search": np.frombuffer(search.state_bytes(), dtype=np.uint8)},
                    config_sha256=config_sha256)


def _checkpoint_load(path: Path) -> MapElites:
    """The search of a checkpoint `_checkpoint_save` wrote.

    Raises:
      CheckpointError: unreadable, not a MAP-Elites checkpoint, another ribs version, or
        inconsistent.
      RunFolderError: the run's config.json changed since.
    """
    ribs = import_ribs()
    state, arrays = load_checkpoint(path)
    if "search" not in arrays:
        raise CheckpointError(f"cannot read run checkpoint {path}: it holds no search state")
    data = arrays["search"].tobytes()
    if state.get("ribs_version") != ribs.__version__:
        raise CheckpointError(
            f"{path} was written with ribs {state.get('ribs_version')}, this is ribs "
            f"{ribs.__version__}: an exact resume needs the same version (pip install "
            f"ribs=={state.get('ribs_version')})")
    try:
        search = MapElites.from_state_bytes(data)
    except CheckpointError as error:
        raise CheckpointError(f"cannot read run checkpoint {path}: {error}") from None
    if search.iteration != state.get("iteration"):
        raise CheckpointError(f"{path} is inconsistent: its search is at iteration "
                              f"{search.iteration}, its record says {state.get('iteration')}")
    return search
