"""Evolution runs on disk: one output folder per run, resumable after a kill.

The folder holds
  config.json     everything that determines the run (task, GA settings, seed)
  metrics.csv     one row per generation (see `METRICS`)
  best/gen_NNNN.npz, best/gen_NNNN.npy   each generation's best genome (NCA checkpoint)
                  and its robot
  fitness.png     best and mean fitness per generation, redrawn every generation
  checkpoint.npz  the GA state after the last finished generation, written atomically,
                  with the hash of config.json (a resume refuses an edited config)
  errors.log      the evaluations that failed: one line each and the first traceback of
                  each generation (only when some failed)
A killed run continues from `checkpoint.npz` with ``resume=True`` and produces exactly the
results of an uninterrupted run: evaluation is deterministic and the GA's random state is
restored. A folder holding a run is never overwritten without ``resume`` or ``force``, and
``force`` only ever deletes a folder that holds an mjregen run. A generation in which every
evaluation failed stops the run (`RunFailedError`): its results would be meaningless.
"""

from __future__ import annotations

import csv
import hashlib
import json
import shutil
import sys
import time
import zipfile
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable, Protocol

import numpy as np
from tqdm import tqdm

from mjregen import __version__, interrupt
from mjregen.errors import CheckpointError, MjregenError
from mjregen.fileio import atomic_open
from mjregen.grid import Robot
from mjregen.growth.checkpoint import save_nca
from mjregen.growth.nca import NCA, NCAConfig
from mjregen.plotting import line_axes, save_png
from mjregen.search.backends import Backend
from mjregen.search.ga import GAConfig, GeneticAlgorithm
from mjregen.tasks.evaluation import PopulationEvaluation

RUN_FORMAT = "mjregen-run-1"
PLOT_EVERY = 10.0  # s of wall time between redraws of fitness.png (and after the last generation)
METRICS = ("generation", "best", "mean", "median", "std", "unstable", "failed", "distinct",
           "evaluations", "evals_per_s", "wall_time", "elapsed")


class Task(Protocol):
    """What an evolution evaluates: genomes of an NCA -> fitness (higher is better)."""

    nca: NCAConfig

    def evaluate(self, genomes: np.ndarray, backend: Backend) -> PopulationEvaluation: ...


class RunFolderError(MjregenError, ValueError):
    """The output folder holds another run, or cannot be resumed or replaced."""


class RunFailedError(MjregenError, RuntimeError):
    """Every evaluation of a generation failed (the first error is in the message)."""


def _config_hash(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _read_config(path: Path) -> dict:
    """A run's config.json, or RunFolderError naming it."""
    try:
        config = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise RunFolderError(f"{path} is not a readable run configuration: {error}") from None
    if not isinstance(config, dict):
        raise RunFolderError(f"{path} is not a run configuration (not a JSON object)")
    return config


def _is_run_folder(path: Path) -> bool:
    """`path` holds an mjregen run: a config.json of this run format."""
    try:
        return json.loads((path / "config.json").read_text()).get("format") == RUN_FORMAT
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, AttributeError):
        return False


def _check_deletable(out: Path) -> None:
    """Raise RunFolderError unless `force` may delete `out`: an mjregen run folder that is
    not the working directory, the home folder or one of their parents."""
    resolved = out.resolve()
    protected = {Path.cwd().resolve(), Path.home().resolve()}
    if any(resolved == p or resolved in p.parents for p in protected):
        raise RunFolderError(f"force never deletes {out} (the working directory, the home "
                             "folder or a parent of one): choose another --out")
    if not _is_run_folder(out):
        raise RunFolderError(f"{out} is not empty and does not hold an mjregen run (no "
                             f"config.json of format {RUN_FORMAT}): force only replaces run "
                             "folders; choose another --out")


@dataclass(frozen=True)
class RunSummary:
    """Outcome of `run_evolution`: the best individual ever evaluated and where it is."""

    out: Path
    generations: int
    best_fitness: float
    best_generation: int
    best_genome: np.ndarray


GENOME_ARRAYS = ("population", "parents")  # what a GA state holds its genomes in


def _checkpoint_save(path: Path, ga: GeneticAlgorithm, best: dict) -> None:
    state = ga.state_dict()
    genomes = {name: state.pop(name) for name in GENOME_ARRAYS if name in state}
    state.update(best_fitness=best["best_fitness"], best_generation=best["best_generation"],
                 config_sha256=_config_hash(path.with_name("config.json")))
    with atomic_open(path) as handle:
        np.savez(handle, format=np.array(RUN_FORMAT), best_genome=best["best_genome"],
                 state=np.array(json.dumps(state)), **genomes)


def _checkpoint_load(path: Path) -> tuple[GeneticAlgorithm, dict]:
    try:
        with np.load(path, allow_pickle=False) as archive:
            if str(archive["format"]) != RUN_FORMAT:
                raise CheckpointError(f"{path} is not an mjregen run checkpoint")
            state = json.loads(str(archive["state"]))
            genomes = {name: archive[name] for name in GENOME_ARRAYS if name in archive}
            best_genome = archive["best_genome"]
            if not genomes:
                raise KeyError("population")
    except (KeyError, ValueError, OSError, EOFError, zipfile.BadZipFile) as error:
        raise CheckpointError(f"cannot read run checkpoint {path}: {error}") from None
    config_hash = state.pop("config_sha256", None)  # absent in older checkpoints
    config_path = path.with_name("config.json")
    if config_hash is not None and config_hash != _config_hash(config_path):
        raise RunFolderError(f"{config_path} changed since the run wrote {path.name} (its hash "
                             "differs): restore the file, or start a new run")
    best = {"best_fitness": state.pop("best_fitness"), "best_generation": state.pop("best_generation"),
            "best_genome": best_genome}
    try:
        return GeneticAlgorithm.from_state_dict({**state, **genomes}), best
    except ValueError as error:
        raise CheckpointError(f"run checkpoint {path} does not fit its run: {error}") from None


def _prepare_folder(out: Path, config: dict, *, resume: bool, force: bool) -> bool:
    """Create or check the run folder; returns True when an earlier run is resumed."""
    config_path = out / "config.json"
    if resume and force:
        raise RunFolderError("choose either resume or force, not both")
    if resume:
        if not config_path.is_file():
            raise RunFolderError(f"nothing to resume: {config_path} does not exist")
        stored = _read_config(config_path)
        differences = sorted(k for k in set(stored) | set(config)
                             if k not in ("created", "mjregen_version") and stored.get(k) != config.get(k))
        if differences:
            raise RunFolderError(
                f"{out} holds a run with different settings ({', '.join(differences)}); "
                "resume it with its own settings or use another folder")
        return (out / "checkpoint.npz").is_file()
    if out.exists() and any(out.iterdir()):
        if not force:
            raise RunFolderError(f"{out} is not empty; pass resume to continue the run in it "
                                 "or force to delete it and start again")
        _check_deletable(out)
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)
    with atomic_open(config_path, "w") as handle:
        json.dump(config, handle, indent=2)
    return False


def _log_failures(path: Path, generation: int, result: PopulationEvaluation, *,
                  progress: bool) -> None:
    """Append a generation's failed evaluations (one line each, the first traceback) to
    `path`, and say so on screen."""
    with path.open("a") as handle:
        handle.write(f"generation {generation}: {len(result.errors)} failed\n")
        handle.writelines(f"  {line}\n" for line in result.errors)
        if result.tracebacks and result.tracebacks[0]:
            handle.write(result.tracebacks[0] + "\n")
    message = (f"generation {generation}: {len(result.errors)} evaluation(s) failed, e.g. "
               f"{result.errors[0]} (see {path})")
    if progress:
        tqdm.write(message)
    else:
        print(message, file=sys.stderr)


def _read_metrics(path: Path, generations: int) -> list[dict]:
    """Rows of generations < `generations` (a killed run may have written one more)."""
    if not path.is_file():
        return []
    with path.open() as handle:
        return [row for row in csv.DictReader(handle) if int(row["generation"]) < generations]


def _write_metrics(path: Path, rows: list[dict]) -> None:
    with atomic_open(path, "w") as handle:
        writer = csv.DictWriter(handle, fieldnames=METRICS)
        writer.writeheader()
        writer.writerows(rows)


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


def _metrics_row(result: PopulationEvaluation, *, generation: int, wall: float,
                 elapsed: float) -> dict:
    """A generation's metrics.csv row (`METRICS`)."""
    fitness = result.fitness
    return {
        "generation": generation, "best": f"{fitness.max():.6g}", "mean": f"{fitness.mean():.6g}",
        "median": f"{np.median(fitness):.6g}", "std": f"{fitness.std():.6g}",
        "unstable": int(np.count_nonzero(~result.stable & ~result.failed)),
        "failed": int(np.count_nonzero(result.failed)), "distinct": result.n_distinct,
        "evaluations": len(fitness), "evals_per_s": f"{len(fitness) / wall:.4g}",
        "wall_time": f"{wall:.4g}", "elapsed": f"{elapsed:.6g}",
    }


def run_evolution(
    task: Task,
    ga_config: GAConfig,
    *,
    seed: int,
    out: str | Path,
    backend: Backend,
    task_config: dict,
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
      task_config: JSON description of `task`, stored in config.json and compared on resume.
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
        "format": RUN_FORMAT, "task": task_config, "ga": ga_config.to_dict(), "seed": seed,
        "mjregen_version": __version__, "created": datetime.now(timezone.utc).isoformat(),
    }
    resuming = _prepare_folder(out, config, resume=resume, force=force)
    if resuming:
        ga, best = _checkpoint_load(out / "checkpoint.npz")
    else:
        ga = GeneticAlgorithm(ga_config, task.nca.genome_size, seed=seed)
        best = {"best_fitness": -np.inf, "best_generation": -1, "best_genome": None}
    rows = _read_metrics(out / "metrics.csv", ga.generation)
    elapsed = float(rows[-1]["elapsed"]) if rows else 0.0
    (out / "best").mkdir(exist_ok=True)
    last_plot = -np.inf
    bar = tqdm(total=ga_config.generations, initial=ga.generation, disable=not progress,
               desc=f"evolving {out.name}", unit="gen")
    while ga.generation < ga_config.generations:
        interrupt.check()
        start = time.perf_counter()
        generation = ga.generation
        population = ga.ask()
        result = task.evaluate(population, backend)
        if result.errors:
            _log_failures(out / "errors.log", generation, result, progress=progress)
        if np.all(result.failed):
            raise RunFailedError(
                f"every evaluation of generation {generation} failed, e.g. {result.errors[0]} "
                f"(tracebacks in {out / 'errors.log'}); the run stops, its checkpoint holds "
                "the last good generation")
        top = int(ga.tell(result.fitness)[0])
        if result.fitness[top] > best["best_fitness"]:
            best = {"best_fitness": float(result.fitness[top]), "best_generation": generation,
                    "best_genome": population[top]}
        _save_best(out / "best" / f"gen_{generation:04d}", task.nca, population[top], result,
                   top, generation=generation, seed=seed)
        wall = time.perf_counter() - start
        elapsed += wall
        rows.append(_metrics_row(result, generation=generation, wall=wall, elapsed=elapsed))
        _write_metrics(out / "metrics.csv", rows)
        fitness = result.fitness
        if time.perf_counter() - last_plot > PLOT_EVERY or ga.generation == ga_config.generations:
            plot_fitness(rows, out / "fitness.png", title=out.name)
            last_plot = time.perf_counter()
        _checkpoint_save(out / "checkpoint.npz", ga, best)
        bar.set_postfix(best=f"{fitness.max():.3f}", overall=f"{best['best_fitness']:.3f}")
        bar.update(1)
        if on_generation is not None:
            on_generation(rows[-1])
    bar.close()
    return RunSummary(out=out, generations=ga.generation, best_fitness=best["best_fitness"],
                      best_generation=best["best_generation"],
                      best_genome=np.asarray(best["best_genome"], dtype=np.float32))
