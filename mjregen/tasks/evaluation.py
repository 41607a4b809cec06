"""Evaluation results, and one robot's locomotion evaluation as a worker job (no torch here).

`evaluate_robot` is the function the evaluation backends run: it takes a small picklable
job and returns a small picklable `RobotEvaluation` (no trajectories). A generation's
results, whatever the task, are a `PopulationEvaluation`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mjregen.grid import Material, Robot
from mjregen.physics import Physics
from mjregen.physics.simulation import simulate
from mjregen.tasks.fitness import locomotion_fitness


@dataclass(frozen=True)
class RobotJob:
    """A robot grid (int8 array, any valid shape) with its physics and measured time (s)."""

    grid: np.ndarray
    physics: Physics
    duration: float | None = None


@dataclass(frozen=True)
class RobotEvaluation:
    """The parts of a `mjregen.physics.simulation.Result` an evolution needs, and its
    locomotion fitness."""

    fitness: float
    distance: float
    n_voxels: int
    stable: bool
    reason: str
    steps: int
    cpu_time: float


HARD_STEP_COST = 1.7  # steps of a robot with a hard voxel / without (measured on 3D blocks)


def expected_cost(grid: np.ndarray) -> float:
    """Relative CPU cost of simulating `grid` (int8 robot grid): its voxel count, times
    HARD_STEP_COST when a hard voxel is present (its stiff bonds shorten the step). For
    ordering work, not a measurement."""
    voxels = float(np.count_nonzero(grid))
    return voxels * HARD_STEP_COST if np.any(grid == Material.HARD) else voxels


def evaluate_robot(job: RobotJob) -> RobotEvaluation:
    """Simulate `job.grid`; never raises for an unstable run (see `simulate`)."""
    result = simulate(Robot(job.grid), physics=job.physics, duration=job.duration)
    return RobotEvaluation(
        fitness=locomotion_fitness(result), distance=result.distance, n_voxels=result.n_voxels,
        stable=result.stable, reason=result.reason, steps=result.steps, cpu_time=result.cpu_time,
    )


@dataclass
class PopulationEvaluation:
    """Per-individual results of one generation (arrays of length P), for any task.

    Attributes:
      fitness: float64; higher is better (penalties for unstable or failed runs included).
      grids: int8 ``(P, *grid)``, the robots that were evaluated.
      details: named per-individual measures stored with each generation's best (e.g.
        "distance" in voxel lengths, "voxels"), each ``(P,)``.
      stable: bool; False for unstable or failed simulations (all True without physics).
      failed: bool; True when the evaluation raised or its worker died, twice.
      errors: one line per failed distinct robot.
      tracebacks: the tracebacks of `errors`, in the same order.
      n_distinct: distinct robots in the population.
      sim_cpu_time: s of simulation CPU time summed over workers.
    """

    fitness: np.ndarray
    grids: np.ndarray
    details: dict[str, np.ndarray] = field(default_factory=dict)
    stable: np.ndarray | None = None
    failed: np.ndarray | None = None
    errors: list[str] = field(default_factory=list)
    tracebacks: list[str] = field(default_factory=list)
    n_distinct: int = 0
    sim_cpu_time: float = 0.0

    def __post_init__(self) -> None:
        n = len(self.fitness)
        if self.stable is None:
            self.stable = np.ones(n, dtype=bool)
        if self.failed is None:
            self.failed = np.zeros(n, dtype=bool)
        if not self.n_distinct:
            self.n_distinct = len({grid.tobytes() for grid in self.grids})
