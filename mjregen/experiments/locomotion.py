"""Walking searches as one library call: `evolve_locomotion` (the GA), `evolve_grow_regrow`
(the GA on one NCA that grows and regrows) and `map_elites_locomotion` (MAP-Elites) write
the run folder `mjregen evolve` writes; `stored_locomotion_run` and `stored_map_elites_run`
read back what a folder was started with."""

from __future__ import annotations

import json
from pathlib import Path

from mjregen.errors import MjregenError
from mjregen.growth.nca import NCAConfig
from mjregen.physics import Physics
from mjregen.search.backends import Backend
from mjregen.search.ga import GAConfig
from mjregen.search.map_elites import MapElitesConfig
from mjregen.search.qd_runs import QDRunSummary, run_map_elites
from mjregen.search.runs import RunSummary, run_evolution
from mjregen.tasks import registry
from mjregen.tasks.grow_regrow import PAPER_CUT, GrowRegrowTask
from mjregen.tasks.locomotion import DEFAULT_STARTS, LocomotionTask


def evolve_locomotion(*, out: str | Path, nca: NCAConfig, ga: GAConfig, seed: int,
                      backend: Backend, physics: Physics | None = None,
                      duration: float | None = None, starts: int = DEFAULT_STARTS,
                      start_seed: int | None = None, body: str = "grid",
                      resume: bool = False, force: bool = False, progress: bool = True
                      ) -> RunSummary:
    """Evolve NCAs whose robots walk far, into the run folder `out`.

    Args:
      out: the run folder (config.json, metrics.csv, best/, checkpoint.npz, fitness.png).
      nca: the network that grows the robots.
      ga: population, generations, truncation, elites, sigma.
      seed: the GA's seed, and the seed of every robot's starts.
      backend: where the robots are simulated (results do not depend on it).
      physics: None = the default physics.
      duration: s of walking measured; None = the scene's.
      starts: starts each robot walks from; its fitness is their mean (`LocomotionTask`).
      start_seed: seed of the starts; None = `seed` (a run older than starts resumes with
        its own, 0).
      body: how a grown grid becomes the robot ("grid" or "sheet", `LocomotionTask`).
      resume: continue the run in `out` (these settings must be its own).
      force: replace a run already in `out`.
      progress: a progress bar.
    Raises:
      mjregen.search.runs.RunFolderError: `out` holds another run or nothing to resume.
    """
    task = LocomotionTask(nca=nca, physics=physics or Physics(), duration=duration,
                          starts=starts, start_seed=seed if start_seed is None else start_seed,
                          body=body)
    return run_evolution(task, ga, seed=seed, out=out, backend=backend,
                         resume=resume, force=force, progress=progress)


def evolve_grow_regrow(*, out: str | Path, nca: NCAConfig, ga: GAConfig, seed: int,
                       backend: Backend, physics: Physics | None = None,
                       duration: float | None = None, starts: int = DEFAULT_STARTS,
                       start_seed: int | None = None,
                       cut: str = PAPER_CUT, cell_cost: float = 0.1,
                       regrown_weight: float = 0.0, resume: bool = False,
                       force: bool = False, progress: bool = True) -> RunSummary:
    """Evolve one NCA whose robot walks far and that regrows it after `cut`
    (`mjregen.tasks.grow_regrow`), into the run folder `out`. Arguments as for
    `evolve_locomotion`; `cut` ("paper" or a half-space condition), `cell_cost` (voxel
    lengths per wrongly regrown cell) and `regrown_weight` (the regrown robot's share of the
    locomotion fitness) as for `GrowRegrowTask`."""
    task = GrowRegrowTask(nca=nca, physics=physics or Physics(), duration=duration,
                          starts=starts, start_seed=seed if start_seed is None else start_seed,
                          cut=cut, cell_cost=cell_cost, regrown_weight=regrown_weight)
    return run_evolution(task, ga, seed=seed, out=out, backend=backend,
                         resume=resume, force=force, progress=progress)


def task_from_config(config: dict) -> LocomotionTask | GrowRegrowTask:
    """The walking task a run's config.json "task" entry describes.

    Raises:
      ValueError: another task. KeyError: an entry is missing.
    """
    if config.get("task") not in ("locomotion", "grow-regrow"):
        raise ValueError(f"not a walking task: {config.get('task')!r}")
    return registry.task_from_config(config)


def map_elites_locomotion(*, out: str | Path, nca: NCAConfig, config: MapElitesConfig,
                          seed: int, backend: Backend, physics: Physics | None = None,
                          duration: float | None = None, starts: int = DEFAULT_STARTS,
                          start_seed: int | None = None,
                          resume: bool = False, force: bool = False, progress: bool = True
                          ) -> QDRunSummary:
    """Search NCAs whose robots walk far across behaviour descriptors with MAP-Elites, into
    the run folder `out` (`mjregen.search.qd_runs`). Arguments as for `evolve_locomotion`,
    with `config` the MAP-Elites settings."""
    task = LocomotionTask(nca=nca, physics=physics or Physics(), duration=duration,
                          starts=starts, start_seed=seed if start_seed is None else start_seed)
    return run_map_elites(task, config, seed=seed, out=out, backend=backend,
                          resume=resume, force=force, progress=progress)


def _stored_config(out: str | Path) -> tuple[Path, dict]:
    path = Path(out) / "config.json"
    if not path.is_file():
        raise MjregenError(f"nothing to resume: {path} does not exist")
    try:
        stored = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise MjregenError(f"{path} is not a readable run configuration: {error}") from None
    if not isinstance(stored, dict):
        raise MjregenError(f"{path} is not a run configuration (not a JSON object)")
    return path, stored


def stored_locomotion_run(out: str | Path) -> tuple[LocomotionTask | GrowRegrowTask,
                                                     GAConfig, int]:
    """(task, GA settings, seed) a walking GA run folder (locomotion or grow-regrow) was
    started with.

    Raises:
      MjregenError: no config.json in `out`, or one that is not a locomotion GA run's.
    """
    path, stored = _stored_config(out)
    try:
        return (task_from_config(stored["task"]), GAConfig(**stored["ga"]),
                int(stored["seed"]))
    except (KeyError, TypeError, ValueError) as error:
        raise MjregenError(f"{path} is not a readable run configuration of a locomotion run: "
                           f"{type(error).__name__}: {error}") from None


def stored_map_elites_run(out: str | Path) -> tuple[LocomotionTask, MapElitesConfig, int]:
    """(task, MAP-Elites settings, seed) a locomotion MAP-Elites run folder was started with.

    Raises:
      MjregenError: no config.json in `out`, or one that is not a locomotion MAP-Elites run's.
    """
    path, stored = _stored_config(out)
    try:
        return (LocomotionTask.from_config(stored["task"]),
                MapElitesConfig.from_dict(stored["map_elites"]), int(stored["seed"]))
    except (KeyError, TypeError, ValueError) as error:
        raise MjregenError(f"{path} is not a readable configuration of a locomotion MAP-Elites "
                           f"run: {type(error).__name__}: {error}") from None
