"""The one loop of every search's run folder, whatever its optimiser: ask, evaluate, tell,
then the step's files in a fixed order (its own files, a metrics.csv row, the pictures, the
checkpoint), so that a run killed at any moment resumes to the uninterrupted run's results.

An optimiser takes part through a `SearchSteps` (the GA's in `mjregen.search.runs`,
MAP-Elites' in `mjregen.search.qd_runs`): it asks for genomes, takes their evaluation and
writes what it keeps of a step; the loop does the rest.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable, Protocol

import numpy as np
from tqdm import tqdm

from mjregen import interrupt
from mjregen.search.backends import Backend
from mjregen.search.run_folder import (
    RunFailedError,
    check_agreement,
    log_failures,
    read_metrics,
    write_metrics,
)
from mjregen.tasks.evaluation import PopulationEvaluation

PLOT_EVERY = 10.0  # s of wall time between redraws of a run's pictures (and after the last step)


class EvaluatedTask(Protocol):
    """What the loop evaluates: genomes ``(P, G)`` -> a population's results."""

    def evaluate(self, genomes: np.ndarray, backend: Backend) -> PopulationEvaluation: ...


class SearchSteps(Protocol):
    """An optimiser's side of a run folder.

    Attributes:
      counter: what a step is called, and the first column of metrics.csv ("generation",
        "iteration").
      columns: metrics.csv's columns.
      done: steps finished (the checkpoint's).
      total: steps the run takes.
    """

    counter: str
    columns: tuple[str, ...]
    done: int
    total: int

    def restore(self) -> None:
        """Check, or write again, the files of the finished steps (metrics.csv agrees with
        the checkpoint).

        Raises:
          RunFolderError: a file the run needs is missing (nothing is changed).
        """

    def ask(self) -> np.ndarray:
        """The next step's genomes ``(P, G)``."""

    def tell(self, genomes: np.ndarray, result: PopulationEvaluation) -> None:
        """Take the step's evaluation and write the step's own files (best robots, archive);
        `done` grows by one."""

    def metrics_row(self, result: PopulationEvaluation, *, step: int, wall: float,
                    elapsed: float) -> dict:
        """The step's metrics.csv row (`columns`); `wall`, `elapsed`: s of this step and of
        the run so far."""

    def draw(self, rows: list[dict]) -> None:
        """Redraw the run's pictures from its metrics rows."""

    def save_checkpoint(self) -> None:
        """Write the optimiser's state atomically (after the step's other files)."""

    def postfix(self) -> dict[str, str]:
        """What the progress bar shows after a step."""


def run_steps(steps: SearchSteps, task: EvaluatedTask, *, out: Path, backend: Backend,
              progress: bool, description: str, unit: str,
              on_step: Callable[[dict], None] | None = None) -> None:
    """Run `steps`' remaining steps into `out`; metrics.csv must list every finished step
    (`check_agreement`). `description`, `unit`: the progress bar's.

    Raises:
      RunFolderError: metrics.csv disagrees with the checkpoint (nothing is changed).
      RunFailedError: every evaluation of a step failed (the checkpoint keeps the last good
        step).
    """
    counter = steps.counter
    rows = read_metrics(out / "metrics.csv", counter, steps.done)
    check_agreement(out, rows, steps.done, counter)
    steps.restore()
    elapsed = float(rows[-1]["elapsed"]) if rows else 0.0
    last_drawn = -np.inf
    bar = tqdm(total=steps.total, initial=steps.done, disable=not progress, desc=description,
               unit=unit)
    while steps.done < steps.total:
        interrupt.check()
        start = time.perf_counter()
        step = steps.done
        genomes = steps.ask()
        result = task.evaluate(genomes, backend)
        if result.errors:
            log_failures(out / "errors.log", step, result, progress=progress, label=counter)
        if np.all(result.failed):
            raise RunFailedError(
                f"every evaluation of {counter} {step} failed, e.g. {result.errors[0]} "
                f"(tracebacks in {out / 'errors.log'}); the run stops, its checkpoint holds "
                f"the last good {counter}")
        steps.tell(genomes, result)
        wall = time.perf_counter() - start
        elapsed += wall
        rows.append(steps.metrics_row(result, step=step, wall=wall, elapsed=elapsed))
        write_metrics(out / "metrics.csv", steps.columns, rows)
        if time.perf_counter() - last_drawn > PLOT_EVERY or steps.done == steps.total:
            steps.draw(rows)
            last_drawn = time.perf_counter()
        steps.save_checkpoint()
        bar.set_postfix(steps.postfix())
        bar.update(1)
        if on_step is not None:
            on_step(rows[-1])
    bar.close()
