"""Locomotion evolutions as one library call: `evolve_locomotion` writes a run folder (the
one `mjregen evolve` writes), `stored_locomotion_run` reads back what a folder was started
with."""

from __future__ import annotations

import json
from pathlib import Path

from mjregen.errors import MjregenError
from mjregen.growth.nca import NCAConfig
from mjregen.physics import Physics
from mjregen.search.backends import Backend
from mjregen.search.ga import GAConfig
from mjregen.search.runs import RunSummary, run_evolution
from mjregen.tasks.locomotion import LocomotionTask


def evolve_locomotion(*, out: str | Path, nca: NCAConfig, ga: GAConfig, seed: int,
                      backend: Backend, physics: Physics | None = None,
                      duration: float | None = None, resume: bool = False,
                      force: bool = False, progress: bool = True) -> RunSummary:
    """Evolve NCAs whose robots walk far, into the run folder `out`.

    Args:
      out: the run folder (config.json, metrics.csv, best/, checkpoint.npz, fitness.png).
      nca: the network that grows the robots.
      ga: population, generations, truncation, elites, sigma.
      seed: the GA's seed.
      backend: where the robots are simulated (results do not depend on it).
      physics: None = the default physics.
      duration: s of walking measured; None = the scene's.
      resume: continue the run in `out` (these settings must be its own).
      force: replace a run already in `out`.
      progress: a progress bar.
    Raises:
      mjregen.search.runs.RunFolderError: `out` holds another run or nothing to resume.
    """
    task = LocomotionTask(nca=nca, physics=physics or Physics(), duration=duration)
    return run_evolution(task, ga, seed=seed, out=out, backend=backend,
                         task_config=task.to_config(), resume=resume, force=force,
                         progress=progress)


def stored_locomotion_run(out: str | Path) -> tuple[LocomotionTask, GAConfig, int]:
    """(task, GA settings, seed) a locomotion run folder was started with.

    Raises:
      MjregenError: no config.json in `out`, or one that is not a locomotion run's.
    """
    path = Path(out) / "config.json"
    if not path.is_file():
        raise MjregenError(f"nothing to resume: {path} does not exist")
    try:
        stored = json.loads(path.read_text())
        return (LocomotionTask.from_config(stored["task"]), GAConfig(**stored["ga"]),
                int(stored["seed"]))
    except (json.JSONDecodeError, UnicodeDecodeError, KeyError, TypeError, ValueError) as error:
        raise MjregenError(f"{path} is not a readable run configuration of a locomotion run: "
                           f"{type(error).__name__}: {error}") from None
