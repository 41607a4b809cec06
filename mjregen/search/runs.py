"""Evolution runs on disk: one output folder per run, resumable after a kill.

The folder holds
  config.json     everything that determines the run (task, GA settings, seed)
  metrics.csv     one row per generation (see `METRICS`; walking tasks add the best
                  individual's shortest walk and the spread of its walks over its starts)
  best/gen_NNNN.npz, best/gen_NNNN.npy   each generation's best genome (NCA checkpoint)
                  and its robot
  fitness.png     best and mean fitness per generation, redrawn every generation
  checkpoint.npz  the GA state after the last finished generation, written atomically,
                  with the hash of config.json (a resume refuses an edited config)
  errors.log      the evaluations that failed: one line each and the first traceback of
                  each generation (only when some failed)
A killed run continues from `checkpoint.npz` with ``resume=True`` and produces exactly the
results of an uninterrupted run: evaluation is deterministic and the GA's random state is
restored. A finished run kept without its checkpoint (a record: config.json, metrics.csv
and best/) is left alone on resume: its summary comes from best/. A folder holding a run is
never overwritten without ``resume`` or ``force``, and ``force`` only ever deletes a folder
that holds an mjregen run. A generation in which every evaluation failed stops the run
(`RunFailedError`): its results would be meaningless.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable, Protocol

import numpy as np

from mjregen import __version__
from mjregen.errors import CheckpointError
from mjregen.grid import Robot
from mjregen.growth.checkpoint import load_nca, save_nca
from mjregen.growth.nca import NCA, NCAConfig
from mjregen.plotting import line_axes, save_png
from mjregen.search.backends import Backend
from mjregen.search.ga import GAConfig, GeneticAlgorithm
from mjregen.search.run_folder import (
    EVALUATION_COLUMNS,
    RUN_FORMAT,
    RunFolderError,
    check_restartable,
    config_hash,
    evaluation_columns,
    load_checkpoint,
    prepare_folder,
    read_metrics,
    save_checkpoint,
)
from mjregen.search.run_lock import RunLock
from mjregen.search.run_loop import run_steps
from mjregen.tasks.evaluation import PopulationEvaluation

METRICS = ("generation", "best", "mean", "median", "std", *EVALUATION_COLUMNS,
           "best_distance_min", "best_distance_std")
# the generation's best individual's shortest walk and the spread of its walks over its starts
# (voxel lengths; empty for tasks without them)
SPREAD = {"best_distance_min": "distance_min", "best_distance_std": "distance_std"}


class Task(Protocol):
    """What an evolution evaluates: genomes of an NCA -> fitness (higher is better)."""

    nca: NCAConfig

    def evaluate(self, genomes: np.ndarray, backend: Backend) -> PopulationEvaluation: ...

    def to_config(self) -> dict:
        """The task as JSON: config.json's "task" entry, compared on resume."""


@dataclass(frozen=True)
class RunSummary:
    """Outcome of `run_evolution`: the best individual ever evaluated and where it is."""

    out: Path
    generations: int
    best_fitness: float
    best_generation: int
    best_genome: np.ndarray


GENOME_ARRAYS = ("population", "parents")  # what a GA state holds its genomes in


def _checkpoint_save(path: Path, ga: GeneticAlgorithm, best: dict, config_sha256: str) -> None:
    """The GA state and the best so far (`save_checkpoint`)."""
    state = ga.state_dict()
    genomes = {name: state.pop(name) for name in GENOME_ARRAYS if name in state}
    state.update(best_fitness=best["best_fitness"], best_generation=best["best_generation"])
    save_checkpoint(path, state=state, arrays={"best_genome": best["best_genome"], **genomes},
                    config_sha256=config_sha256)


def _checkpoint_load(path: Path) -> tuple[GeneticAlgorithm, dict]:
    """The GA and the best so far of a checkpoint `_checkpoint_save` wrote.

    Raises:
      CheckpointError: unreadable, or not the checkpoint of a GA that fits its run.
      RunFolderError: the run's config.json changed since.
    """
    state, arrays = load_checkpoint(path)
    genomes = {name: arrays[name] for name in GENOME_ARRAYS if name in arrays}
    try:
        if not genomes or "best_genome" not in arrays:
            raise KeyError("population" if not genomes else "best_genome")
        best = {"best_fitness": state.pop("best_fitness"),
                "best_generation": state.pop("best_generation"),
                "best_genome": arrays["best_genome"]}
    except KeyError as error:
        raise CheckpointError(f"cannot read run checkpoint {path}: {error}") from None
    try:
        return GeneticAlgorithm.from_state_dict({**state, **genomes}), best
    except ValueError as error:
        raise CheckpointError(f"run checkpoint {path} does not fit its run: {error}") from None


def plot_fitness(rows: list[dict], path: Path, title: str) -> None:
    """Best and mean fitness per generation as a PNG."""
    generations = [int(r["generation"]) for r in rows]
    figure, ax = line_axes(xlabel="generation", ylabel="fitness", title=title)
    ax.plot(generations, [float(r["best"]) for r in rows], label="best")
    ax.plot(generations, [float(r["mean"]) for r in rows], label="mean")
    save_png(figure, path)


def _save_best(stem: Path, config: NCAConfig, genome: np.ndarray, result: PopulationEvaluation,
               top: int, *, generation: int, seed: int) -> None:
    """A generation's best NCA (``stem.npz``, with its fitness and details) and robot
    (``stem.npy``)."""
    metadata = {"generation": generation, "fitness": float(result.fitness[top]), "seed": seed,
                **{name: float(values[top]) for name, values in result.details.items()}}
    save_nca(stem.with_suffix(".npz"), NCA(config, genome), metadata=metadata, overwrite=True)
    Robot(result.grids[top]).save(stem.with_suffix(".npy"), overwrite=True)


def _finished_record(out: Path, generations: int) -> RunSummary | None:
    """The summary of a run in `out` whose metrics.csv lists all `generations` (None when it
    lists fewer), read from best/ without its checkpoint: the best genome is the first
    generation's best NCA with the highest fitness. metrics.csv rounds to 6 digits, so every
    generation listed with the highest fitness is a candidate, read in full from its NCA file;
    a record keeps only some of their files (the missing ones are skipped).

    Raises:
      RunFolderError: none of the candidates' NCA files exists, or one cannot be read.
    """
    rows = read_metrics(out / "metrics.csv", "generation", generations)
    if not rows or len(rows) < generations:
        return None
    listed = np.array([float(r["best"]) for r in rows])
    candidates = np.flatnonzero(listed == listed.max())
    best: tuple[float, int, np.ndarray] | None = None
    for generation in candidates:
        path = out / "best" / f"gen_{generation:04d}.npz"
        if not path.is_file():
            continue
        try:
            nca, metadata = load_nca(path)
        except CheckpointError as error:
            raise RunFolderError(f"{out} is finished but its best NCA cannot be read: "
                                 f"{error}") from None
        if best is None or metadata["fitness"] > best[0]:
            best = (float(metadata["fitness"]), int(generation), nca.genome)
    if best is None:
        names = ", ".join(f"gen_{g:04d}.npz" for g in candidates)
        raise RunFolderError(f"{out} is finished but its best NCA cannot be read: none of "
                             f"{names} is in {out / 'best'}")
    return RunSummary(out=out, generations=generations, best_fitness=best[0],
                      best_generation=best[1], best_genome=np.asarray(best[2], dtype=np.float32))


def _metrics_row(result: PopulationEvaluation, *, generation: int, top: int, wall: float,
                 elapsed: float) -> dict:
    """A generation's metrics.csv row (`METRICS`); `top`: its best individual."""
    fitness = result.fitness
    spread = {column: (f"{result.details[name][top]:.6g}" if name in result.details else "")
              for column, name in SPREAD.items()}
    return {
        "generation": generation, "best": f"{fitness.max():.6g}", "mean": f"{fitness.mean():.6g}",
        "median": f"{np.median(fitness):.6g}", "std": f"{fitness.std():.6g}",
        **evaluation_columns(result, wall=wall, elapsed=elapsed), **spread,
    }


def run_evolution(
    task: Task,
    ga_config: GAConfig,
    *,
    seed: int,
    out: str | Path,
    backend: Backend,
    resume: bool = False,
    force: bool = False,
    progress: bool = True,
    on_generation: Callable[[dict], None] | None = None,
) -> RunSummary:
    """Evolve `task` with the GA, writing the run folder `out` (see the module docstring).

    Args:
      task: what to evaluate (e.g. `mjregen.tasks.locomotion.LocomotionTask`).
      ga_config: population, generations, truncation, elites, sigma.
      seed: seeds the GA (the only random thing in a run).
      out: the run folder.
      backend: where simulations run; results do not depend on it.
      resume: continue the run in `out` (its settings must equal these).
      force: delete the run in `out` first (only a run folder is ever deleted).
      progress: show a tqdm bar with the current best.
      on_generation: called with each generation's metrics row.
    Raises:
      RunFolderError: `out` holds another run, there is nothing to resume, its config was
        edited, or `force` is asked to delete a folder that is not a run folder.
      RunFailedError: every evaluation of a generation failed.
      ValueError: `seed` is not a whole number >= 0 (nothing is written).
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a whole number >= 0, got {seed!r}")
    out = Path(out)
    config = {
        "format": RUN_FORMAT, "task": task.to_config(), "ga": ga_config.to_dict(), "seed": seed,
        "mjregen_version": __version__, "created": datetime.now(timezone.utc).isoformat(),
    }
    with RunLock(out):
        resuming = prepare_folder(out, config, resume=resume, force=force,
                                  task_class=type(task))
        started_with = config_hash(out / "config.json")
        if resume and not resuming:
            finished = _finished_record(out, ga_config.generations)
            if finished is not None:
                return finished
            check_restartable(out, "checkpoint.npz", "generation")
        if resuming:
            ga, best = _checkpoint_load(out / "checkpoint.npz")
        else:
            ga = GeneticAlgorithm(ga_config, task.nca.genome_size, seed=seed)
            best = {"best_fitness": -np.inf, "best_generation": -1, "best_genome": None}
        steps = GenerationSteps(ga, best, task=task, out=out, seed=seed,
                                started_with=started_with)
        run_steps(steps, task, out=out, backend=backend, progress=progress,
                  description=f"evolving {out.name}", unit="gen", on_step=on_generation)
        return steps.summary()


class GenerationSteps:
    """The GA's side of a run folder (`mjregen.search.run_loop.SearchSteps`): each
    generation's best in best/, the best ever evaluated, fitness.png and the checkpoint."""

    counter = "generation"
    columns = METRICS

    def __init__(self, ga: GeneticAlgorithm, best: dict, *, task: Task, out: Path, seed: int,
                 started_with: str) -> None:
        self.ga, self.best, self._task, self._out = ga, best, task, out
        self._seed, self._started_with = seed, started_with
        self._top, self._generation_best = 0, -np.inf  # the last generation's (`tell`)

    @property
    def done(self) -> int:
        return self.ga.generation

    @property
    def total(self) -> int:
        return self.ga.config.generations

    def restore(self) -> None:
        last = self._out / "best" / f"gen_{self.done - 1:04d}.npz"
        if self.done and not last.is_file():
            raise RunFolderError(f"{self._out}: checkpoint.npz is at generation {self.done} but "
                                 f"{last} is missing: restore it from a copy, or start the run "
                                 "again with force")
        (self._out / "best").mkdir(exist_ok=True)

    def ask(self) -> np.ndarray:
        return self.ga.ask()

    def tell(self, genomes: np.ndarray, result: PopulationEvaluation) -> None:
        generation = self.ga.generation
        self._top = top = int(self.ga.tell(result.fitness)[0])
        if result.fitness[top] > self.best["best_fitness"]:
            self.best = {"best_fitness": float(result.fitness[top]),
                         "best_generation": generation, "best_genome": genomes[top]}
        _save_best(self._out / "best" / f"gen_{generation:04d}", self._task.nca, genomes[top],
                   result, top, generation=generation, seed=self._seed)
        self._generation_best = float(result.fitness.max())

    def metrics_row(self, result: PopulationEvaluation, *, step: int, wall: float,
                    elapsed: float) -> dict:
        return _metrics_row(result, generation=step, top=self._top, wall=wall,
                            elapsed=elapsed)

    def draw(self, rows: list[dict]) -> None:
        plot_fitness(rows, self._out / "fitness.png", title=self._out.name)

    def save_checkpoint(self) -> None:
        _checkpoint_save(self._out / "checkpoint.npz", self.ga, self.best, self._started_with)

    def postfix(self) -> dict[str, str]:
        return {"best": f"{self._generation_best:.3f}",
                "overall": f"{self.best['best_fitness']:.3f}"}

    def summary(self) -> RunSummary:
        """The run's outcome so far."""
        best = self.best
        return RunSummary(out=self._out, generations=self.done,
                          best_fitness=best["best_fitness"],
                          best_generation=best["best_generation"],
                          best_genome=np.asarray(best["best_genome"], dtype=np.float32))
