"""The locomotion fitness pipeline of an evolution.

genomes ``(P, G)`` → batched NCA growth → the paper's cleaning → the robots (`BODIES`: the
grown grids themselves, or 2D patterns laid flat as sheets) → identical robots merged
(each distinct grid is simulated once per generation) → robots already simulated in an
earlier generation (elites, recurring shapes) taken from a cache → simulation of the rest on a
backend, each robot from `starts` starts (every voxel moved by an offset seeded by
`start_seed`, the start's index and the robot: `mjregen.physics.start_state`) → fitness, the
mean over the starts. Simulation is deterministic, so the cache changes no result, only the
time; a resumed run starts with an empty cache and gets the same numbers.
Unstable simulations keep their penalty fitness; individuals whose evaluation failed twice
(an exception or a dead worker) get the same penalty and are flagged `failed`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from mjregen.growth.nca import NCAConfig, grow
from mjregen.physics import Physics, PhysicsParameterError
from mjregen.physics.start_state import MAX_STARTS, check_start
from mjregen.tasks.bodies import BODIES, as_robots, body_physics
from mjregen.tasks.cache import LRUCache
from mjregen.tasks.evaluation import (
    PopulationEvaluation,
    RobotJob,
    evaluate_robot,
    expected_cost,
)
from mjregen.tasks.fitness import EMPTY_FITNESS, UNSTABLE_FITNESS
from mjregen.tasks.starts import DEFAULT_STARTS

if TYPE_CHECKING:  # the search layer hands a task its backend
    from mjregen.search.backends import Backend


@dataclass(frozen=True)
class LocomotionTask:
    """Grow robots with an NCA and score how far they walk.

    Attributes:
      nca: the NCA configuration the genomes belong to.
      physics: materials and scene of the simulation.
      duration: s of actuation measured; None = the scene's (the paper's 0.5 s / 0.25 s).
      starts: starts each robot walks from (>= 1); its fitness is their mean.
      start_seed: seed of the starts (>= 0; an evolution's is its run's seed).
      cache_size: robots whose results are kept across generations (least recently used
        dropped first); a robot seen again is not simulated again.
      body: how a grown grid becomes the robot (`BODIES`); "sheet" only for a 2D NCA.
    """

    nca: NCAConfig
    physics: Physics = field(default_factory=Physics)
    duration: float | None = None
    starts: int = DEFAULT_STARTS
    start_seed: int = 0
    cache_size: int = 20_000
    body: str = "grid"
    _cache: LRUCache = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_cache", LRUCache(self.cache_size))
        if isinstance(self.starts, bool) or not isinstance(self.starts, (int, np.integer)) \
                or self.starts < 1:
            raise ValueError(f"starts must be a whole number >= 1, got {self.starts!r}")
        if self.starts > MAX_STARTS:
            raise ValueError(f"starts must be at most {MAX_STARTS:,} (one model's keyframes), "
                             f"got {self.starts:,}")
        if self.starts > 1 and self.physics.scene.start_shift == 0.0:
            raise PhysicsParameterError(
                f"{self.starts} starts need a start shift > 0: with start_shift 0 every start "
                "is the exact start, the same walk each time")
        check_start("start_seed", self.start_seed)
        if self.body not in BODIES:
            raise ValueError(f"unknown body {self.body!r}; choose one of {', '.join(BODIES)}")
        if self.body == "sheet" and self.nca.dim != 2:
            raise ValueError(f"a sheet body lays a 2D pattern flat; this NCA is "
                             f"{self.nca.dim}D")

    def to_config(self) -> dict:
        """The task as JSON (a run folder's config.json "task" entry)."""
        return {"task": "locomotion", "nca": self.nca.to_dict(),
                "physics": self.physics.to_dict(), "duration": self.duration,
                "starts": int(self.starts), "start_seed": int(self.start_seed),
                "body": self.body}

    @classmethod
    def from_config(cls, config: dict) -> LocomotionTask:
        """The task `to_config` described (physics descriptions of any format migrate; a
        description without starts is one from before them: one start, seed 0; one without
        a body walks the grown grid; sheets described before the settle rest, physics format
        5 and older, settled for the full time).

        Raises:
          ValueError: `config` is not a locomotion task's.
          KeyError: an entry is missing.
        """
        if config.get("task") != "locomotion":
            raise ValueError(f"not a locomotion task: {config.get('task')!r}")
        body = config.get("body", "grid")
        physics = Physics.from_dict(config["physics"])
        if body == "sheet" and config["physics"].get("format", 1) < 6:
            physics = physics.replace(settle_rest=0.0)
        return cls(nca=NCAConfig.from_dict(config["nca"]), physics=physics,
                   duration=config["duration"], starts=config.get("starts", 1),
                   start_seed=config.get("start_seed", 0), body=body)

    @property
    def genome_size(self) -> int:
        return self.nca.genome_size

    @property
    def lowest_fitness(self) -> float:
        """Below every fitness this task gives: the unstable penalty."""
        return UNSTABLE_FITNESS[self.nca.dim]

    @property
    def robot_physics(self) -> Physics:
        """The physics the robots walk in (`body_physics`)."""
        return body_physics(self.physics, self.body)

    def robots(self, grids: np.ndarray) -> np.ndarray:
        """The robots of grown grids ``(P, *grid)`` (`as_robots`)."""
        return as_robots(grids, self.body)

    def evaluate(self, genomes: np.ndarray, backend: Backend) -> PopulationEvaluation:
        """Score a population of genomes ``(P, G)``."""
        return self.evaluate_grids(grow(self.nca, genomes).grids, backend)

    def evaluate_grids(self, grids: np.ndarray, backend: Backend) -> PopulationEvaluation:
        """Score the robots of grown grids, int8 ``(P, *grid)``; the evaluation's grids are
        the robots (`robots`)."""
        grids = self.robots(grids)
        population, dim = len(grids), self.nca.dim
        physics = self.robot_physics
        distinct: dict[bytes, int] = {}
        owner = np.array([distinct.setdefault(g.tobytes(), len(distinct)) for g in grids])
        firsts = np.unique(owner, return_index=True)[1]
        n_voxels = np.count_nonzero(grids.reshape(population, -1), axis=1)
        keys = list(distinct)
        present = [d for d, i in enumerate(firsts) if n_voxels[i] > 0]
        cached = {d: self._cache.get(keys[d]) for d in present if keys[d] in self._cache}
        # the costliest robots first, so that no worker is left with a large one at the end
        # of the generation while the others wait (results do not depend on the order)
        to_simulate = sorted((d for d in present if d not in cached),
                             key=lambda d: -expected_cost(grids[firsts[d]]))
        outcomes = backend.map(
            evaluate_robot,
            [RobotJob(grids[firsts[d]], physics, self.duration, self.starts,
                      self.start_seed, rule=dim) for d in to_simulate],
        )
        for d, outcome in zip(to_simulate, outcomes):
            if outcome.ok:  # failures are not results: they are retried next time
                self._cache.put(keys[d], outcome.value)
        n = len(distinct)
        fitness = np.full(n, EMPTY_FITNESS[dim], dtype=np.float64)
        distance, lowest, spread = np.zeros(n), np.zeros(n), np.zeros(n)
        stable = np.ones(n, dtype=bool)
        failed = np.zeros(n, dtype=bool)
        errors, tracebacks, cpu = [], [], 0.0
        results = dict(cached)
        for d, outcome in zip(to_simulate, outcomes):
            if outcome.ok:
                results[d] = outcome.value
                cpu += outcome.value.cpu_time
            else:
                fitness[d], stable[d], failed[d] = UNSTABLE_FITNESS[dim], False, True
                distance[d] = lowest[d] = spread[d] = np.nan
                errors.append(f"robot {d} (individual {firsts[d]}): {outcome.error}")
                tracebacks.append(outcome.trace)
        for d, result in results.items():
            fitness[d], stable[d] = result.fitness, result.stable
            distance[d], lowest[d], spread[d] = (result.distance, result.distance_min,
                                                 result.distance_std)
        return PopulationEvaluation(
            fitness=fitness[owner], grids=grids,
            details={"distance": distance[owner], "distance_min": lowest[owner],
                     "distance_std": spread[owner], "voxels": n_voxels},
            stable=stable[owner], failed=failed[owner], errors=errors, tracebacks=tracebacks,
            n_distinct=n,
            sim_cpu_time=cpu,
        )
