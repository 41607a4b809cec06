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
      similarity: {cut: cells of the regrown grid equal to the grown one}, the paper's cut
        first.
      recovery: the original, damaged and regrown robots' walks after the paper's cut.
    """

    cells: int
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
                         duration: float | None = None, cuts: list[str] | None = None
                         ) -> SelfRegrowthReport:
    """Grow `nca`'s robot, cut it (the paper's cut and `cuts`; default 8 `random_cuts`),
    regrow each with the same NCA, and walk the original, damaged and regrown robots of
    the paper's cut."""
    config = nca.config
    cuts = random_cuts(8, dim=config.dim, grid_size=config.grid_size) if cuts is None else cuts
    growth = nca.grow()
    regrown = {cut: regrow_after_cut(config, nca.genome[None], growth, cut)
               for cut in [PAPER_CUT, *cuts]}
    similarity = {cut: int(own_similarity(grids, growth.grids)[0]) for cut, grids in regrown.items()}
    robots = _paper_cut_robots(config, growth, regrown[PAPER_CUT])
    return SelfRegrowthReport(cells=int(growth.grids[0].size), similarity=similarity,
                              recovery=measure_recovery(robots, physics=physics, duration=duration))


def self_regrowth_robots(nca: NCA, growth: Growth | None = None) -> dict[str, Robot]:
    """`nca`'s grown robot ("original"), the paper's cut of it ("damaged") and what the same
    NCA regrows from that cut ("regrown"); `growth`: `nca.grow()` where the caller has it."""
    growth = nca.grow() if growth is None else growth
    return _paper_cut_robots(nca.config, growth,
                             regrow_after_cut(nca.config, nca.genome[None], growth, PAPER_CUT))


def _paper_cut_robots(config: NCAConfig, growth: Growth, regrown: np.ndarray
                      ) -> dict[str, Robot]:
    """The original, damaged and regrown robots of the paper's cut, given the regrown grids
    ``(1, *grid)``."""
    return {"original": growth.robot(),
            "damaged": damaged_robot(damaged_states(config, growth, PAPER_CUT)),
            "regrown": Robot(regrown[0])}


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
    `finished_runs` not yet in ``root/grow_regrow_engine.json`` (keys
    `engine_key`), add them there and return all its distances."""

    def robots():
        for run in finished_runs(root):
            made = functools.cache(lambda run=run: self_regrowth_robots(
                load_nca(run.best_files()[0])[0]))
            for role in ROLES:
                yield engine_key(root, run, role), lambda made=made, role=role: made()[role]
    return walk_new(Path(root, ENGINE_FILE), robots(), engine, progress=progress)


def engine_key(root: str | Path, run: RunInfo, role: str) -> str:
    """The key of a run's `role` robot in grow_regrow_engine.json: the run folder's path
    relative to `root`, then the role."""
    return f"{run.path.relative_to(root).as_posix()}/{role}"
