"""A regrowth run as one library call (what `mjregen regen` runs): damage a robot's CA
state, evolve a second NCA that regrows it (fitness: cells equal to the original, as in the
paper), then walk the original, damaged and regrown robots (the paper's Table 1). And the
paper's regrowth experiment as jobs: each picked walker, network and seed one run folder
``<root>/regen_<walker>_<net>/seed_<n>``."""

from __future__ import annotations

import shlex
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from mjregen.errors import MjregenError
from mjregen.experiments.paper import (
    CONDITIONS,
    DEFAULT_ROOT,
    Scale,
    read_run,
    scaled_ga,
)
from mjregen.experiments.recovery import RecoveryReport, measure_recovery, write_report
from mjregen.grid import Robot
from mjregen.growth.checkpoint import load_nca, save_nca
from mjregen.growth.nca import NCA, CAState, Growth, NCAConfig
from mjregen.physics import Physics
from mjregen.resources import PAPER_ROBOTS, asset
from mjregen.search.backends import SerialBackend
from mjregen.search.ga import PRESETS, GAConfig
from mjregen.search.run_lock import RunLock
from mjregen.search.runs import RunSummary, run_evolution
from mjregen.tasks.regrowth import (
    RegrowthTask,
    cut_half_space,
    damaged_robot,
    paper_cut,
    similarity,
    state_of_growth,
    state_of_robot,
    state_of_saved,
)

ROLES = ("original", "damaged", "regrown")
SEED_DAMAGE = "seed"  # every cell erased but the seed: the NCA grows the robot from the seed


@dataclass(frozen=True)
class RegrowthSource:
    """The robot a regrowth starts from.

    Attributes:
      robot: the original robot (on the NCA grid).
      state: its CA state, which the damage is cut from (`mjregen.tasks.regrowth`).
      label: where it came from (a file's path), for config.json and reports.
      start: how `state` was made: "grown" (an NCA's growth, alphas and all), "saved" (the
        CA state the paper's code saved) or "alpha 1" (a grid alone: alpha 1 on its voxels).
    """

    robot: Robot
    state: CAState
    label: str
    start: str


def regrowth_source(*, robot: str | Path | None = None, checkpoint: str | Path | None = None,
                    paper: str | None = None) -> RegrowthSource:
    """The original robot of a regrowth, from exactly one of: a robot grid file (``.npy``;
    its CA state: alpha 1 on every voxel), an NCA checkpoint that grows it (its CA state as
    grown, alphas and all, as the paper's code regrows from), or the name of one of the
    paper's robots (the biped from the CA state the paper's code saved; the tripod and the
    multiped, whose states were not published, with alpha 1).

    Raises:
      MjregenError: not exactly one source, an unknown paper robot, a robot not on the NCA
        grid, or a file that cannot be read.
    """
    given = [s for s in (robot, checkpoint, paper) if s is not None]
    if len(given) != 1:
        raise MjregenError("give exactly one of robot, checkpoint or paper")
    if checkpoint is not None:
        nca, _ = load_nca(checkpoint)
        growth = nca.grow()
        return RegrowthSource(growth.robot(), state_of_growth(growth), str(checkpoint), "grown")
    if paper is not None and paper not in PAPER_ROBOTS:
        raise MjregenError(f"unknown paper robot {paper!r}; choose from {', '.join(PAPER_ROBOTS)}")
    path = Path(robot) if robot is not None else asset("robots", "paper", f"{paper}.npy")
    original = Robot.load(path)
    config = NCAConfig(dim=original.dim, kind="ff")
    if original.shape != config.grid_shape:
        raise MjregenError(f"{path}: regrowth needs the NCA grid {config.grid_shape}, "
                           f"got {original.shape}")
    # a shipped robot by its place in the repository, the same on every machine
    label = str(path) if paper is None else f"assets/robots/paper/{paper}.npy"
    saved = path.with_name(f"{path.stem}_ca_state.npy") if paper is not None else None
    if saved is not None and saved.is_file():
        try:
            state = state_of_saved(np.load(saved), config)
        except ValueError as error:
            raise MjregenError(f"{saved}: {error}") from None
        if not np.array_equal(state.state[0].numpy(), original.grid):
            raise MjregenError(f"{saved}: its states are not the robot in {path}")
        return RegrowthSource(original, state, label, "saved")
    return RegrowthSource(original, state_of_robot(original, config), label, "alpha 1")


@dataclass(frozen=True)
class RegrowthRun:
    """What `run_regrowth` did.

    Attributes:
      summary: the GA run (its folder, best genome, best similarity).
      robots: {"original", "damaged" (cleaned), "regrown"}.
      regrowth: the best regrowth NCA's growth from the damaged state (its steps' grids).
      report: the three robots' walks (`mjregen.experiments.recovery`).
    """

    summary: RunSummary
    robots: dict[str, Robot]
    regrowth: Growth
    report: RecoveryReport


REGROWTH_FILE = "regrowth.npz"  # a run's best regrowth NCA, with what it regrows


def run_regrowth(*, source: RegrowthSource, out: str | Path, damage: str | None = None,
                 net: str = "ff", ga: GAConfig | None = None, seed: int = 0,
                 physics: Physics | None = None, duration: float | None = None,
                 name: str | None = None, resume: bool = False, force: bool = False,
                 progress: bool = True) -> RegrowthRun:
    """Damage `source`'s CA state, evolve an NCA that regrows it, walk the three robots.

    Writes into the run folder `out`: the GA's files (config.json, metrics.csv, best/,
    checkpoint.npz, fitness.png), original/damaged/regrown.npy, recovery.md/.json and
    ``regrowth.npz``: the best regrowth NCA with the robot and damaged state it regrows
    (`replay_regrowth` runs it again).

    Args:
      source: the original robot and its CA state (`regrowth_source`).
      damage: cells removed, a half-space such as "x < 4"; None = the paper's cut (x below
        the grid centre); `SEED_DAMAGE` ("seed") = every cell but the paper's seed, so that
        the evolved NCA grows the robot from the seed: where it grows it exactly, its
        regrowth.npz is an NCA whose grown CA state a later regrowth can start from
        (``regrowth_source(checkpoint=...)``, start "grown").
      net: the regrowth NCA's network, "ff" or "lstm".
      ga: the GA; None = the paper's regrowth preset.
      seed: the GA's seed.
      physics, duration: the walks' physics (None = the default) and s measured (None =
        the scene's).
      name: the robot's name in recovery.md (default: the source file's stem).
      resume, force, progress: as for `mjregen.search.runs.run_evolution`.
    Raises:
      mjregen.errors.InvalidGridError: an unreadable damage condition.
      MjregenError: an empty robot, or damage that removes no voxel or every voxel.
      mjregen.search.runs.RunFolderError: `out` holds another run or nothing to resume.
    """
    out, ga = Path(out), ga or PRESETS["regen"]
    name = name or Path(source.label).stem
    if source.robot.is_empty:
        raise MjregenError(f"{source.label}: an empty robot has nothing to damage or regrow")
    config = NCAConfig(dim=source.robot.dim, kind=net)
    damaged = damaged_state(source.state, damage, config)
    left = damaged_robot(damaged)
    nothing_left = not damaged.state.any()  # cells the NCA grows from, before cleaning
    if nothing_left or left.n_voxels == source.robot.n_voxels:
        what = "removes every voxel (nothing is left to regrow from)" if nothing_left else \
            "removes no voxel of the robot (there is nothing to regrow)"
        raise MjregenError(f"the damage {damage or 'paper cut'!r} {what}; choose another "
                           "--damage")
    task = RegrowthTask(nca=config, original=np.asarray(source.robot.grid),
                        damaged=CAState(damaged.state, damaged.alpha, None),
                        provenance={"source": source.label, "start": source.start,
                                    "damage": damage or "paper cut"})
    with RunLock(out):  # the GA run and the files written after it
        return _regrow_and_walk(task, ga, out=out, seed=seed, name=name,
                                damaged=damaged, source=source, physics=physics,
                                duration=duration, resume=resume, force=force,
                                progress=progress)


def damaged_state(state: CAState, damage: str | None, config: NCAConfig) -> CAState:
    """`state` after `damage` (as for `run_regrowth`; "seed": the paper's seed state of
    `config`'s grid, memory left to the regrowth NCA)."""
    if damage is None:
        return paper_cut(state)
    if damage == SEED_DAMAGE:
        seed = CAState.seed(config, 1)
        return CAState(seed.state, seed.alpha, None)
    return cut_half_space(state, damage)


def _regrow_and_walk(task: RegrowthTask, ga: GAConfig, *, out: Path,
                     seed: int, name: str, damaged: CAState, source: RegrowthSource,
                     physics: Physics | None, duration: float | None, resume: bool,
                     force: bool, progress: bool) -> RegrowthRun:
    """`run_regrowth`'s GA run and the files and walks after it (the folder held)."""
    config = task.nca
    summary = run_evolution(task, ga, seed=seed, out=out, backend=SerialBackend(),
                            resume=resume, force=force, progress=progress)
    regrowth = task.regrow(summary.best_genome)
    robots = {"original": source.robot,
              "damaged": damaged_robot(damaged),
              "regrown": regrowth.robot()}
    for role, robot in robots.items():
        robot.save(out / f"{role}.npy", overwrite=True)
    save_nca(out / REGROWTH_FILE, NCA(config, summary.best_genome), overwrite=True, metadata={
        "robot": name, "similarity": int(summary.best_fitness),
        "generation": summary.best_generation, "seed": seed, "ga": ga.to_dict(),
        **{key: value for key, value in task.to_config().items()
           if key not in ("task", "nca")}})
    report = measure_recovery(robots, physics=physics, duration=duration)
    write_report(report, out, name=name)
    return RegrowthRun(summary, robots, regrowth, report)


@dataclass(frozen=True)
class RegrowthReplay:
    """A regrowth NCA's experiment run again from its file (`replay_regrowth`).

    Attributes:
      robots: {"original", "damaged" (cleaned), "regrown"}.
      similarity: cells of the regrown grid equal to the original's.
      report: the three robots' walks.
      metadata: the file's record (robot, source, start, damage, similarity, GA, ...).
    """

    robots: dict[str, Robot]
    similarity: int
    report: RecoveryReport
    metadata: dict


def replay_regrowth(path: str | Path, *, physics: Physics | None = None,
                    duration: float | None = None) -> RegrowthReplay:
    """Regrow the robot a regrowth NCA file (``regrowth.npz`` of `run_regrowth`) records
    from the damaged state it records, and walk the original, damaged and regrown robots.

    Raises:
      FileNotFoundError, mjregen.errors.CheckpointError: no readable NCA at `path`.
      MjregenError: the NCA records no original robot and damaged state (not a regrowth
        NCA's file).
    """
    nca, metadata = load_nca(path)
    missing = [k for k in ("original", "damaged_state", "damaged_alpha") if k not in metadata]
    if missing:
        raise MjregenError(f"{path} records no {', '.join(missing)}: not a regrowth NCA "
                           f"written by run_regrowth")
    original = np.asarray(metadata["original"], dtype=np.int8)
    state = torch.tensor(metadata["damaged_state"], dtype=torch.int64)[None]
    alpha = torch.tensor(metadata["damaged_alpha"], dtype=torch.float32)[None]
    damaged = CAState(state, alpha, None)
    task = RegrowthTask(nca=nca.config, original=original, damaged=damaged)
    regrowth = task.regrow(nca.genome)
    robots = {"original": Robot(original), "damaged": damaged_robot(damaged),
              "regrown": regrowth.robot()}
    return RegrowthReplay(robots, int(similarity(regrowth.grids, original)[0]),
                          measure_recovery(robots, physics=physics, duration=duration), metadata)


@dataclass(frozen=True)
class RegenJob:
    """One regrowth run: a walker, a regrowth network, a seed and the regen GA."""

    walker: str
    checkpoint: Path
    net: str
    seed: int
    out: Path
    ga: GAConfig
    settle: float | None
    duration: float | None

    def argv(self) -> list[str]:
        """Arguments of the equivalent `mjregen regen` command (it writes the same folder)."""
        ga = self.ga
        args = ["regen", "--checkpoint", str(self.checkpoint), "--net", self.net,
                "--pop", str(ga.population), "--gens", str(ga.generations),
                "--truncation", str(ga.truncation), "--elites", str(ga.elites),
                "--sigma", f"{ga.sigma:g}", "--seed", str(self.seed)]
        if self.settle is not None:
            args += ["--settle", f"{self.settle:g}"]
        if self.duration is not None:
            args += ["--duration", f"{self.duration:g}"]
        return args + ["--no-video", "--out", str(self.out)]

    def command(self) -> str:
        return "mjregen " + shlex.join(self.argv())

    @property
    def complete(self) -> bool:
        """Finished and its recovery measured."""
        if not (self.out / "recovery.json").is_file():
            return False
        return read_run(self.out).complete


def regen_folder(root: str | Path, walker: str, net: str, seed: int) -> Path:
    """``<root>/regen_<walker>_<net>/seed_<seed>``."""
    return Path(root) / f"regen_{walker}_{net}" / f"seed_{seed}"


def regen_jobs(scale: Scale, walkers: list[dict], *, root: str | Path = DEFAULT_ROOT,
               population: int | None = None, generations: int | None = None,
               nets: tuple[str, ...] | None = None) -> list[RegenJob]:
    """The regrowth runs of `scale` for `walkers` (from
    `mjregen.experiments.walkers.load_or_pick_walkers`)."""
    ga = scaled_ga(PRESETS["regen"], population or scale.regen_population,
                   generations or scale.regen_generations)
    jobs = []
    for walker in walkers:
        for net in nets or scale.regen_nets or (CONDITIONS[walker["condition"]].kind,):
            for seed in range(scale.regen_runs):
                jobs.append(RegenJob(walker["name"], Path(walker["npz"]), net, seed,
                                     regen_folder(root, walker["name"], net, seed), ga,
                                     None if scale.settle is None else scale.settle[3],
                                     scale.duration(3)))
    return jobs


def run_regen_job(job: RegenJob, *, progress: bool = True):
    """Run (or resume) one regrowth (`mjregen.experiments.regrowth.run_regrowth`, the same
    folder as the job's printed `mjregen regen` command, pictures and videos aside): returns
    its `RegrowthRun`, or None for a finished job, which is left alone.

    Raises:
      mjregen.search.runs.RunFolderError: the folder holds a run with other settings.
    """
    if job.complete:
        return None
    physics = Physics() if job.settle is None else Physics().replace(settle_time=job.settle)
    return run_regrowth(source=regrowth_source(checkpoint=job.checkpoint), out=job.out,
                        net=job.net, ga=job.ga, seed=job.seed, physics=physics,
                        duration=job.duration, resume=(job.out / "config.json").is_file(),
                        progress=progress)
