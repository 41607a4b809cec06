"""One NCA that grows a walking robot and regrows it after damage.

The paper evolves two networks, one that grows and one that regrows, and names that as its
limitation. Here one genome does both: its NCA grows a robot from the seed (the locomotion
task), the grown CA state is damaged as in the paper (its cells on one side of a plane
erased, state, alpha and LSTM memory), and the same NCA runs its growth steps again from
the damaged state (it keeps its own memory: it is the same network). The damage is a
half-space of the grid ("paper": grid x-indices 0-3 of 9, or any condition such as "y > 4"),
or "half": each robot's own lower half across its longest extent (`half_cut`), which no
robot can avoid by growing away from a fixed plane. The fitness judges the
regrowth by its form, its function or both:

    fitness = (1 - w) × locomotion(grown) + w × locomotion(regrown)
              - cell_cost × (cells - similarity)

similarity being the cells (of 729 in 3D) of the regrown grid equal to the grown one, so
each cell the regrowth gets wrong costs `cell_cost` voxel lengths of walking, and w the
`regrown_weight`: with w > 0 the regrown robot walks too (from the same starts; a regrown
robot equal to the grown one is not simulated again), and a robot whose regrowth falls over
or fails scores as unstable.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import torch

from mjregen.grid import AXIS_NAMES, InvalidGridError, half_space_mask
from mjregen.growth.nca import CAState, Growth, NCAConfig, grow
from mjregen.physics import Physics
from mjregen.tasks.evaluation import PopulationEvaluation
from mjregen.tasks.locomotion import DEFAULT_STARTS, LocomotionTask
from mjregen.tasks.regrowth import cut_half_space, erase_cells

if TYPE_CHECKING:  # the search layer hands a task its backend
    from mjregen.search.backends import Backend

PAPER_CUT = "paper"  # the paper's damage: grid x-indices below the centre
HALF_CUT = "half"  # each robot's own lower half across its longest extent


def grown_states(growth: Growth) -> CAState:
    """The CA states a population's growth leaves, as the paper's code keeps them for
    regrowth: the cleaned grids, every cell's grown alpha and the memory."""
    final = growth.final
    memory = None if final.memory is None else tuple(m.clone() for m in final.memory)
    return CAState(torch.from_numpy(growth.grids.astype(np.int64)), final.alpha.clone(), memory)


def cut_condition(cut: str, grid_size: int) -> str:
    """The half-space condition of a fixed cut: "paper" is ``x < centre`` (0-3 of 9)."""
    return f"x < {grid_size // 2}" if cut == PAPER_CUT else cut


def half_cut(grid: np.ndarray) -> str:
    """The half-space condition of `grid`'s "half" cut: the cells below the middle of the
    robot's extent along its longest axis (the first of the longest), ``"<axis> < m"`` with
    m = (lowest + highest + 1) // 2 of its voxels' indices there. A robot spanning x 1-7 of a
    9-grid (as the paper's do) gets the paper's cut, ``"x < 4"``; a column one voxel wide
    loses its lower cells. An empty grid gets ``"x < 0"`` (nothing)."""
    cells = np.argwhere(grid != 0)
    if len(cells) == 0:
        return "x < 0"
    low, high = cells.min(axis=0), cells.max(axis=0)
    axis = int(np.argmax(high - low))
    return f"{AXIS_NAMES[grid.ndim][axis]} < {(low[axis] + high[axis] + 1) // 2}"


def damaged_states(config: NCAConfig, growth: Growth, cut: str = PAPER_CUT) -> CAState:
    """The grown states of a population cut by `cut`: a half-space condition such as
    ``"z > 4"``, "paper", or "half" (each robot its own `half_cut`)."""
    if cut == HALF_CUT:
        masks = np.stack([half_space_mask(config.grid_shape, half_cut(grid))
                          for grid in growth.grids])
        return erase_cells(grown_states(growth), masks)
    return cut_half_space(grown_states(growth), cut_condition(cut, config.grid_size))


def regrow_after_cut(config: NCAConfig, genomes: np.ndarray, growth: Growth,
                     cut: str = PAPER_CUT) -> np.ndarray:
    """int8 ``(P, *grid)``: each genome's robot regrown by its own NCA after `cut` of its
    grown state (`damaged_states`)."""
    return grow(config, genomes, start=damaged_states(config, growth, cut)).grids


def own_similarity(regrown: np.ndarray, grown: np.ndarray) -> np.ndarray:
    """Cells of each regrown grid equal to its own grown grid, ``(P,)``."""
    return (regrown == grown).reshape(len(grown), -1).sum(axis=1)


@dataclass(frozen=True)
class GrowRegrowTask:
    """Grow robots that walk far and regrow after `cut` (see the module docstring).

    Attributes:
      nca: the network that grows and regrows.
      physics, duration, starts, start_seed: the walk, as in `LocomotionTask`.
      cut: the damage during evolution: "paper", "half" (each robot's own lower half,
        `half_cut`) or a half-space condition ("y > 4").
      cell_cost: voxel lengths of walking one wrongly regrown cell costs.
      regrown_weight: the share of the regrown robot's locomotion fitness in the fitness, in
        [0, 1]; 0 (the default) does not walk it.
    """

    nca: NCAConfig
    physics: Physics = field(default_factory=Physics)
    duration: float | None = None
    starts: int = DEFAULT_STARTS
    start_seed: int = 0
    cut: str = PAPER_CUT
    cell_cost: float = 0.1
    regrown_weight: float = 0.0
    _locomotion: LocomotionTask = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.cell_cost) and self.cell_cost >= 0.0):
            raise ValueError(f"cell_cost must be finite and >= 0, got {self.cell_cost!r}")
        if not 0.0 <= self.regrown_weight <= 1.0:
            raise ValueError(f"regrown_weight must be in [0, 1], got {self.regrown_weight!r}")
        if self.cut != HALF_CUT:
            try:
                half_space_mask(self.nca.grid_shape, cut_condition(self.cut, self.nca.grid_size))
            except InvalidGridError as error:
                raise InvalidGridError(f"cut must be {PAPER_CUT!r}, {HALF_CUT!r} or a half-space "
                                       f"of the grid: {error}") from None
        object.__setattr__(self, "_locomotion", LocomotionTask(
            nca=self.nca, physics=self.physics, duration=self.duration, starts=self.starts,
            start_seed=self.start_seed))

    def to_config(self) -> dict:
        """The task as JSON (a run folder's config.json "task" entry)."""
        return {**self._locomotion.to_config(), "task": "grow-regrow", "cut": self.cut,
                "cell_cost": self.cell_cost, "regrown_weight": self.regrown_weight}

    @classmethod
    def from_config(cls, config: dict) -> GrowRegrowTask:
        """The task `to_config` described (one without "regrown_weight", from before it
        existed, has 0).

        Raises:
          ValueError: not a grow-regrow task's configuration. KeyError: an entry is missing.
        """
        if config.get("task") != "grow-regrow":
            raise ValueError(f"not a grow-regrow task: {config.get('task')!r}")
        walk = LocomotionTask.from_config({**config, "task": "locomotion"})
        return cls(nca=walk.nca, physics=walk.physics, duration=walk.duration,
                   starts=walk.starts, start_seed=walk.start_seed, cut=config["cut"],
                   cell_cost=float(config["cell_cost"]),
                   regrown_weight=float(config.get("regrown_weight", 0.0)))

    @property
    def lowest_fitness(self) -> float:
        """Below every fitness: an unstable walk whose regrowth got every cell wrong."""
        return self._locomotion.lowest_fitness - self.cell_cost * np.prod(self.nca.grid_shape)

    def evaluate(self, genomes: np.ndarray, backend: Backend) -> PopulationEvaluation:
        """Score a population of genomes ``(P, G)``: walk, cut, regrow (and walk the regrown
        robots if `regrown_weight` > 0)."""
        growth = grow(self.nca, genomes)
        regrown = regrow_after_cut(self.nca, genomes, growth, self.cut)
        score = own_similarity(regrown, growth.grids)
        population, cells = len(genomes), int(np.prod(self.nca.grid_shape))
        walking = growth.grids if not self.regrown_weight else np.concatenate(
            [growth.grids, regrown])
        walked = self._locomotion.evaluate_grids(walking, backend)
        grown, again = slice(0, population), slice(population, None)
        weight = self.regrown_weight
        locomotion = walked.fitness[grown]
        details = {name: values[grown] for name, values in walked.details.items()}
        stable, failed = walked.stable[grown], walked.failed[grown]
        if weight:
            locomotion = (1 - weight) * locomotion + weight * walked.fitness[again]
            details.update({f"regrown_{name}": walked.details[name][again]
                            for name in ("distance", "voxels")})
            details["regrown_locomotion"] = walked.fitness[again]
            stable, failed = stable & walked.stable[again], failed | walked.failed[again]
            locomotion = np.where(stable, locomotion, self._locomotion.lowest_fitness)
        return PopulationEvaluation(
            fitness=locomotion - self.cell_cost * (cells - score), grids=growth.grids,
            details={**details, "locomotion": walked.fitness[grown], "similarity": score},
            stable=stable, failed=failed, errors=walked.errors, tracebacks=walked.tracebacks,
            sim_cpu_time=walked.sim_cpu_time)
