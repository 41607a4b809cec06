"""What one NCA that grows and regrows (`mjregen.tasks.grow_regrow`) achieves: its walk,
its regrowth after the paper's cut and after random half-space cuts, and the locomotion
recovery of its original, damaged and regrown robot (the paper's Table 1 for it)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjregen.experiments.recovery import RecoveryReport, measure_recovery
from mjregen.grid import Robot
from mjregen.growth.nca import NCA
from mjregen.physics import Physics
from mjregen.tasks.grow_regrow import (
    PAPER_CUT,
    damaged_states,
    own_similarity,
    regrow_after_cut,
)
from mjregen.tasks.regrowth import damaged_robot


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
    genomes = nca.genome[None]
    growth = nca.grow()
    similarity = {}
    regrown_paper = None
    for cut in [PAPER_CUT, *cuts]:
        regrown = regrow_after_cut(config, genomes, growth, cut)
        similarity[cut] = int(own_similarity(regrown, growth.grids)[0])
        if cut == PAPER_CUT:
            regrown_paper = regrown[0]
    robots = {"original": growth.robot(),
              "damaged": damaged_robot(damaged_states(config, growth, PAPER_CUT)),
              "regrown": Robot(regrown_paper)}
    return SelfRegrowthReport(cells=int(growth.grids[0].size), similarity=similarity,
                              recovery=measure_recovery(robots, physics=physics,
                                                        duration=duration))
