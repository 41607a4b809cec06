"""What one NCA that grows and regrows (`mjregen.tasks.grow_regrow`) achieves: its walk,
its regrowth after the paper's cut and after random half-space cuts, and the locomotion
recovery of its original, damaged and regrown robot (the paper's Table 1 for it), here and
in the paper's engine. A growth-only NCA is judged the same way (regrowing with the NCA
that grew the robot), as the baseline of the same evaluations."""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mjregen.experiments.engine_walks import walk_new
from mjregen.experiments.paper import RunInfo, read_run
from mjregen.experiments.recovery import ROLES, RecoveryReport, measure_recovery
from mjregen.grid import Robot
from mjregen.growth.checkpoint import load_nca
from mjregen.growth.config import NCAConfig
from mjregen.growth.nca import NCA, Growth
from mjregen.physics import Physics
from mjregen.tasks.grow_regrow import (
    PAPER_CUT,
    damaged_states,
    own_similarity,
    regrow_after_cut,
)
from mjregen.tasks.regrowth import damaged_robot
from mjregen.validation.engine import PaperEngine

ENGINE_FILE = "grow_regrow_engine.json"  # in a results root: `measure_in_engine`


@dataclass(frozen=True)
class SelfRegrowthReport:
    """Attributes:
      cells: grid cells (729 in 3D).
      damage: the cut the robots were walked after ("paper", "half" or a half-space).
      similarity: {cut: cells of the regrown grid equal to the grown one}, `damage` first.
      recovery: the original, damaged and regrown robots' walks after `damage`.
    """

    cells: int
    damage: str
    similarity: dict[str, int]
    recovery: RecoveryReport


def random_cuts(count: int, *, dim: int, grid_size: int, seed: int = 0) -> list[str]:
    """`count` distinct half-space cuts drawn at random: an axis, a side and a plane
    through the robot's grid interior (index 2 .. grid_size - 3)."""
    rng = np.random.default_rng(seed)
    axes = ("x", "y", "z") if dim == 3 else ("x", "z")
    possible = [f"{a} {op} {k}" for a in axes for op in ("<", ">")
                for k in range(2, grid_size - 2)]
    picks = rng.choice(len(possible), size=min(count, len(possible)), replace=False)
    return [possible[i] for i in sorted(picks)]


def self_regrowth_report(nca: NCA, *, physics: Physics | None = None,
                         duration: float | None = None, cuts: list[str] | None = None,
                         damage: str = PAPER_CUT, start_seed: int = 0) -> SelfRegrowthReport:
    """Grow `nca`'s robot, cut it (`damage`: "paper", "half" or a half-space, and `cuts`;
    default 8 `random_cuts`), regrow each with the same NCA, and walk the original, damaged
    and regrown robots of `damage` from start 0 of `start_seed` (an evolved NCA's: its run's,
    the start its fitness walked)."""
    config = nca.config
    cuts = random_cuts(8, dim=config.dim, grid_size=config.grid_size) if cuts is None else cuts
    growth = nca.grow()
    regrown = {cut: regrow_after_cut(config, nca.genome[None], growth, cut)
               for cut in dict.fromkeys([damage, *cuts])}
    similarity = {cut: int(own_similarity(grids, growth.grids)[0])
                  for cut, grids in regrown.items()}
    robots = _cut_robots(config, growth, regrown[damage], damage)
    return SelfRegrowthReport(cells=int(growth.grids[0].size), damage=damage,
                              similarity=similarity,
                              recovery=measure_recovery(robots, physics=physics, duration=duration,
                                                        start_seed=start_seed))


def self_regrowth_robots(nca: NCA, growth: Growth | None = None, damage: str = PAPER_CUT
                         ) -> dict[str, Robot]:
    """`nca`'s grown robot ("original"), `damage` ("paper", "half" or a half-space) done to it
    ("damaged") and what the same NCA regrows from that ("regrown"); `growth`: `nca.grow()`
    where the caller has it."""
    growth = nca.grow() if growth is None else growth
    return _cut_robots(nca.config, growth,
                       regrow_after_cut(nca.config, nca.genome[None], growth, damage), damage)


def _cut_robots(config: NCAConfig, growth: Growth, regrown: np.ndarray, damage: str
                ) -> dict[str, Robot]:
    """The original, damaged and regrown robots of `damage`, given the regrown grids
    ``(1, *grid)``."""
    return {"original": growth.robot(),
            "damaged": damaged_robot(damaged_states(config, growth, damage)),
            "regrown": Robot(regrown[0])}


def run_damage(run: RunInfo) -> str | None:
    """The damage a grow-regrow run was evolved to regrow from (its task's cut); None for a
    growth-only run."""
    task = run.config["task"]
    return task.get("cut", PAPER_CUT) if task.get("task") == "grow-regrow" else None


def damages(runs: list[RunInfo]) -> dict[Path, list[str]]:
    """The damages each run is judged after: a grow-regrow run its own; a growth-only run
    the paper's cut and every grow-regrow run's, to be compared with each."""
    evolved = list(dict.fromkeys(d for d in map(run_damage, runs) if d is not None))
    everyone = list(dict.fromkeys([PAPER_CUT, *evolved]))
    return {run.path: [run_damage(run)] if run_damage(run) else everyone for run in runs}


def finished_runs(root: str | Path) -> list[RunInfo]:
    """The finished runs under `root` whose best NCA a self-regrowth report judges: the
    grow-regrow runs (``grow_regrow_*``) and the 3D growth-only runs beside them."""
    found = []
    for folder in sorted([*Path(root).glob("grow_regrow_*/seed_*"),
                          *Path(root).glob("3d_*/seed_*")]):
        if (folder / "config.json").is_file():
            run = read_run(folder)
            if run.complete and run.best_files()[0].is_file():
                found.append(run)
    return found


def measure_in_engine(root: str | Path, engine: PaperEngine, *,
                      progress: Callable[[str], None] = print) -> dict[str, float | None]:
    """Walk in `engine` the `self_regrowth_robots` of the best NCA of each of
    `finished_runs` after each of its `damages` not yet in ``root/grow_regrow_engine.json``
    (keys `engine_key`), add them there and return all its distances."""

    def robots():
        runs = finished_runs(root)
        judged = damages(runs)
        for run in runs:
            for damage in judged[run.path]:
                made = functools.cache(lambda run=run, damage=damage: self_regrowth_robots(
                    load_nca(run.best_files()[0])[0], damage=damage))
                for role in ROLES:
                    yield (engine_key(root, run, role, damage),
                           lambda made=made, role=role: made()[role])
    return walk_new(Path(root, ENGINE_FILE), robots(), engine, progress=progress)


def engine_key(root: str | Path, run: RunInfo, role: str, damage: str = PAPER_CUT) -> str:
    """The key of a run's `role` robot after `damage` in grow_regrow_engine.json: the run
    folder's path relative to `root`, the damage unless it is the paper's cut, then the
    role."""
    cut = "" if damage == PAPER_CUT else f"{damage}/"
    return f"{run.path.relative_to(root).as_posix()}/{cut}{role}"
