"""The paper's experiments in one place: what is run, at which scale, into which folders.

Evolution conditions (`CONDITIONS`): 2D and 3D robots, each grown by a feed-forward
("ff") and an LSTM ("lstm") NCA, with the paper's GA (`mjregen.search.ga.PRESETS` "2d"/"3d"),
its fitness (`mjregen.tasks.locomotion.LocomotionTask`) and its run counts (10 runs in 2D, 24 in
3D). A 2D robot is the paper's: the grown pattern laid flat on the floor as one layer of voxels,
walked in 3D (body "sheet"). The regrowth experiment: three diverse evolved 3D walkers
(`mjregen.experiments.walkers`), the paper's cut (`mjregen.tasks.regrowth.paper_cut`, grid
x-indices 0-3 of 9 removed), a regrowth NCA evolved with the paper's regeneration GA
(`PRESETS["regen"]`), then the locomotion recovery of the original, damaged and regrown
robot (`mjregen.experiments.recovery`); its jobs are
`mjregen.experiments.regrowth.regen_jobs`. Reading run folders: `read_run`, `list_runs`,
`best_run`, `list_regen_runs`.

A `Scale` says how much of that is run: "paper" is the paper's, "quick" a named reduced
scale that fits about an hour on two cores, "smoke" seconds of work for tests. Every number
can be overridden (`evolution_jobs`). Run folders (each a `mjregen.search.runs` folder)::

    <root>/<condition>/seed_<n>             evolutions, e.g. runs/results/3d_ff/seed_0
    <root>/walkers/walker_<i>.{npz,npy}     the three picked 3D walkers, walkers.json
    <root>/regen_<walker>_<net>/seed_<n>    regrowth runs, with recovery.json/.md

An evolution here writes exactly the folder that the printed `mjregen evolve` command
writes (same config.json, through `mjregen.experiments.locomotion.evolve_locomotion`), so
either can resume the other.
"""

from __future__ import annotations

import csv
import json
import math
import shlex
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mjregen.errors import MjregenError
from mjregen.growth.nca import NCAConfig
from mjregen.physics import Physics
from mjregen.search.ga import PRESETS, GAConfig
from mjregen.tasks.bodies import body_physics

DEFAULT_ROOT = Path("runs") / "results"
NETS = ("ff", "lstm")
# Rough CPU-s per evaluation with the default physics, from real evolutions at the paper's
# populations: 3D 0.56 (docs/performance.md), 2D 0.02 (sheets, whose settle ends at rest:
# 0.0165 over 4 generations of 300); for planning only.
CPU_PER_EVALUATION = {2: 0.02, 3: 0.56}


@dataclass(frozen=True)
class Condition:
    """One evolution condition of the paper.

    Attributes:
      name: folder name, "<dim>d_<kind>" (e.g. "3d_ff").
      dim: 2 or 3.
      kind: "ff" or "lstm".
      preset: the paper's GA preset (a key of `mjregen.search.ga.PRESETS`).
      paper_runs: independent runs in the paper (2D 10, 3D 24).
      body: how a grown grid becomes the robot (`mjregen.tasks.bodies.BODIES`): 2D
        "sheet", 3D "grid".
    """

    name: str
    dim: int
    kind: str
    preset: str
    paper_runs: int
    body: str = "grid"

    @property
    def nca(self) -> NCAConfig:
        return NCAConfig(dim=self.dim, kind=self.kind)

    @property
    def paper_ga(self) -> GAConfig:
        return PRESETS[self.preset]


CONDITIONS: dict[str, Condition] = {
    f"{dim}d_{kind}": Condition(f"{dim}d_{kind}", dim, kind, f"{dim}d", 10 if dim == 2 else 24,
                                "sheet" if dim == 2 else "grid")
    for dim in (2, 3) for kind in NETS
}


@dataclass(frozen=True)
class Scale:
    """How much of the experiments is run.

    Attributes:
      name: "paper", "quick" or "smoke".
      description: one line for documents.
      population, generations, runs: per dimension (2, 3).
      regen_population, regen_generations: the regrowth GA; truncation and elites keep the
        regen preset's proportions (20 % each).
      regen_runs: regrowth runs per walker and network.
      regen_nets: regrowth NCA networks per walker; None = the walker's own (the paper
        trained both and found the walker's own network best for all three robots).
      settle, measured: s per dimension; None = the paper's (3D 0.05 + 0.5, 2D 1.0 + 0.25).
    """

    name: str
    description: str
    population: dict[int, int]
    generations: dict[int, int]
    runs: dict[int, int]
    regen_population: int
    regen_generations: int
    regen_runs: int = 1
    regen_nets: tuple[str, ...] | None = None
    settle: dict[int, float] | None = None
    measured: dict[int, float] | None = None

    def physics(self, dim: int) -> Physics:
        """Default physics, with this scale's settle time for `dim` if it has one."""
        physics = Physics()
        return physics if self.settle is None else physics.replace(settle_time=self.settle[dim])

    def duration(self, dim: int) -> float | None:
        """s of walking measured; None = the paper's."""
        return None if self.measured is None else self.measured[dim]


SCALES: dict[str, Scale] = {
    "paper": Scale(
        "paper", "the paper's: 2D pop 300 x 500 gens x 10 runs, 3D pop 100 x 300 gens x 24 runs, "
        "regrowth pop 1000 x 1000 gens with both networks",
        population={2: 300, 3: 100}, generations={2: 500, 3: 300}, runs={2: 10, 3: 24},
        regen_population=1000, regen_generations=1000, regen_nets=NETS),
    "quick": Scale(
        "quick", "the shipped results, ~75 min on 2 cores (two conditions at a time, one core "
        "each): 2D pop 20 x 12 gens x 3 runs, 3D pop 12 x 9 gens x 4 runs, regrowth pop 300 x "
        "120 gens with the walker's own network",
        population={2: 20, 3: 12}, generations={2: 12, 3: 9}, runs={2: 3, 3: 4},
        regen_population=300, regen_generations=120),
    "smoke": Scale(
        "smoke", "seconds of work for tests: pop 4 x 2 gens x 2 runs, 0.01 s settle + 0.02 s walks",
        population={2: 4, 3: 4}, generations={2: 2, 3: 2}, runs={2: 2, 3: 2},
        regen_population=8, regen_generations=2,
        settle={2: 0.01, 3: 0.01}, measured={2: 0.02, 3: 0.02}),
}


def scaled_ga(preset: GAConfig, population: int, generations: int) -> GAConfig:
    """`preset` at another population (`GAConfig.scaled`) and length."""
    return preset.scaled(population).with_overrides(generations=generations)


def scale_of(config: dict) -> str:
    """Name of the `SCALES` entry a run's config.json matches ("custom" if none): same
    population, generations and settings of the evaluation (runs per condition not checked;
    the start shift neither, so runs from before it keep their scale)."""
    task = config.get("task", {})
    if task.get("task") != "locomotion":
        return "custom"
    dim = int(task["nca"]["dim"])
    for name, scale in SCALES.items():
        if (config["ga"]["population"] == scale.population[dim]
                and config["ga"]["generations"] == scale.generations[dim]
                and "physics" in task
                and Physics.from_dict(task["physics"]).replace(start_shift=0.0)
                == scale.physics(dim).replace(start_shift=0.0)
                and task.get("duration") == scale.duration(dim)):
            return name
    return "custom"


@dataclass(frozen=True)
class EvolutionJob:
    """One evolution run: a condition, a seed and its settings."""

    condition: Condition
    seed: int
    out: Path
    ga: GAConfig
    physics: Physics
    duration: float | None

    def argv(self, *, workers: int = 1) -> list[str]:
        """Arguments of the equivalent `mjregen evolve` command."""
        ga = self.ga
        args = ["evolve", "--dim", str(self.condition.dim), "--net", self.condition.kind,
                *(["--body", self.condition.body] if self.condition.body != "grid" else []),
                "--preset", self.condition.preset, "--pop", str(ga.population),
                "--gens", str(ga.generations), "--truncation", str(ga.truncation),
                "--elites", str(ga.elites), "--sigma", f"{ga.sigma:g}", "--seed", str(self.seed)]
        if self.physics.scene.settle_time is not None:
            args += ["--settle", f"{self.physics.scene.settle_time:g}"]
        if self.duration is not None:
            args += ["--duration", f"{self.duration:g}"]
        backend = ["--backend", "serial"] if workers == 1 else ["--workers", str(workers)]
        return args + backend + ["--out", str(self.out)]

    def command(self, *, workers: int = 1) -> str:
        return "mjregen " + shlex.join(self.argv(workers=workers))

    def evaluations(self) -> int:
        return self.ga.population * self.ga.generations


def run_folder(root: str | Path, condition: str, seed: int) -> Path:
    """``<root>/<condition>/seed_<seed>``."""
    return Path(root) / condition / f"seed_{seed}"


def evolution_jobs(scale: Scale, *, root: str | Path = DEFAULT_ROOT,
                   conditions: list[str] | None = None, population: int | None = None,
                   generations: int | None = None, runs: int | None = None,
                   first_seed: int = 0) -> list[EvolutionJob]:
    """The evolution runs of `scale` (overrides: None = the scale's), condition by condition.

    Raises:
      MjregenError: an unknown condition name, or GA numbers the GA rejects.
    """
    names = list(CONDITIONS) if conditions is None else list(conditions)
    unknown = [n for n in names if n not in CONDITIONS]
    if unknown:
        raise MjregenError(f"unknown condition(s) {', '.join(unknown)}; choose from "
                           f"{', '.join(CONDITIONS)}")
    jobs = []
    for name in names:
        condition = CONDITIONS[name]
        dim = condition.dim
        try:
            ga = scaled_ga(condition.paper_ga, population or scale.population[dim],
                           generations or scale.generations[dim])
        except ValueError as error:
            raise MjregenError(f"{name}: {error}") from None
        for seed in range(first_seed, first_seed + (runs or scale.runs[dim])):
            jobs.append(EvolutionJob(condition, seed, run_folder(root, name, seed), ga,
                                     scale.physics(dim), scale.duration(dim)))
    return jobs


def run_evolution_job(job: EvolutionJob, *, workers: int = 1, progress: bool = True):
    """Run (or resume, or leave alone when finished) one evolution; returns its
    `mjregen.search.runs.RunSummary`.

    A folder with a config.json is resumed; its settings must equal the job's.

    Raises:
      mjregen.search.runs.RunFolderError: the folder holds a run with other settings.
    """
    from mjregen.experiments.locomotion import evolve_locomotion
    from mjregen.search.backends import make_backend

    backend = make_backend("serial") if workers == 1 else make_backend("process", workers=workers)
    with backend:
        return evolve_locomotion(out=job.out, nca=job.condition.nca, ga=job.ga, seed=job.seed,
                                 backend=backend, physics=job.physics, duration=job.duration,
                                 body=job.condition.body,
                                 resume=(job.out / "config.json").is_file(), progress=progress)


@dataclass(frozen=True)
class RunInfo:
    """What is on disk of one run folder.

    Attributes:
      path: the run folder.
      condition: the folder's parent's name (e.g. "3d_ff").
      seed: the GA seed.
      config: config.json.
      generations_done, generations_planned: metrics.csv rows, and the GA's generations.
      best: per-generation best fitness ``(generations_done,)``.
      best_fitness: highest best fitness (-inf if no generation is done).
      best_generation: first generation that reached it (-1 if none).
      elapsed: s of wall time its finished generations took (metrics.csv's last ``elapsed``;
        0 if none).
    """

    path: Path
    condition: str
    seed: int
    config: dict
    generations_done: int
    generations_planned: int
    best: np.ndarray = field(repr=False)
    best_fitness: float
    best_generation: int
    elapsed: float

    @property
    def complete(self) -> bool:
        return self.generations_done >= self.generations_planned

    @property
    def robot_physics(self) -> Physics:
        """Today's default physics, for the settle and measured times of this run's robots
        (a sheet's: the 2D times; `mjregen.tasks.bodies.body_physics`)."""
        return body_physics(Physics(), self.config.get("task", {}).get("body", "grid"))

    def best_files(self, generation: int | None = None) -> tuple[Path, Path]:
        """(NCA ``.npz``, robot ``.npy``) of a generation's best (default: `best_generation`)."""
        g = self.best_generation if generation is None else generation
        stem = self.path / "best" / f"gen_{g:04d}"
        return stem.with_suffix(".npz"), stem.with_suffix(".npy")


def read_run(path: str | Path) -> RunInfo:
    """`RunInfo` of a run folder.

    Raises:
      FileNotFoundError: no config.json in `path`.
    """
    path = Path(path)
    config = json.loads((path / "config.json").read_text())
    rows = []
    if (path / "metrics.csv").is_file():
        with (path / "metrics.csv").open() as handle:
            rows = list(csv.DictReader(handle))
    best = np.array([float(r["best"]) for r in rows])
    top = int(np.argmax(best)) if len(best) else -1
    return RunInfo(path=path, condition=path.parent.name, seed=int(config["seed"]), config=config,
                   generations_done=len(rows), generations_planned=int(config["ga"]["generations"]),
                   best=best, best_fitness=float(best[top]) if len(best) else -math.inf,
                   best_generation=top, elapsed=float(rows[-1]["elapsed"]) if rows else 0.0)


def list_runs(root: str | Path = DEFAULT_ROOT) -> dict[str, list[RunInfo]]:
    """Evolution runs under `root` with at least one finished generation, by condition
    (`CONDITIONS` order, conditions without runs left out), sorted by seed."""
    found: dict[str, list[RunInfo]] = {}
    for name in CONDITIONS:
        runs = []
        for folder in sorted(Path(root, name).glob("seed_*")):
            if (folder / "config.json").is_file():
                info = read_run(folder)
                if info.generations_done:
                    runs.append(info)
        if runs:
            found[name] = sorted(runs, key=lambda r: r.seed)
    return found


def best_run(runs: list[RunInfo]) -> RunInfo:
    """The run whose best fitness is highest (ties: lowest seed)."""
    return max(runs, key=lambda r: (r.best_fitness, -r.seed))


def robot_name(root: str | Path, run: RunInfo) -> str:
    """The name of `run`'s best robot in measurements kept beside the runs
    (``transfer.json``): its path relative to `root`, e.g. ``3d_ff/seed_0/best/gen_0285.npy``."""
    return run.best_files()[1].relative_to(Path(root)).as_posix()


def _robot_entry(root: str | Path, run: RunInfo) -> tuple[str, tuple[Path, Physics]]:
    """A run's best robot as (`robot_name`, (path, `RunInfo.robot_physics`))."""
    return robot_name(root, run), (run.best_files()[1], run.robot_physics)


def best_robots(root: str | Path = DEFAULT_ROOT) -> dict[str, tuple[Path, Physics]]:
    """Each condition's best robot under `root`: the best generation's robot of its
    `best_run`, as {path relative to `root`: (path, the physics it walks in,
    `RunInfo.robot_physics`)} (the names `benchmarks/transfer.py --best-of` gives its
    measurements and the results report looks them up by)."""
    return dict(_robot_entry(root, best_run(runs)) for runs in list_runs(root).values())


def finished_runs_robots(root: str | Path = DEFAULT_ROOT) -> dict[str, tuple[Path, Physics]]:
    """The best robot of every finished run under `root`, named as in `best_robots`
    (`benchmarks/transfer.py --each-run`: how many runs of a condition end on a robot that
    transfers)."""
    return dict(_robot_entry(root, run) for runs in list_runs(root).values()
                for run in runs if run.complete)


def list_regen_runs(root: str | Path = DEFAULT_ROOT) -> list[tuple[str, str, Path]]:
    """(walker, net, folder) of every regrowth run under `root` with a recovery.json."""
    found = []
    for folder in sorted(Path(root).glob("regen_*/seed_*")):
        if (folder / "recovery.json").is_file():
            walker, _, net = folder.parent.name.removeprefix("regen_").rpartition("_")
            found.append((walker, net, folder))
    return found
