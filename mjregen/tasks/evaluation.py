"""Evaluation results, and one robot's locomotion evaluation as a worker job (no torch here).

`evaluate_robot` is the function the evaluation backends run: it takes a small picklable
job and returns a small picklable `RobotEvaluation` (no trajectories). A robot is scored from
`RobotJob.starts` starts (`mjregen.physics.start_state`: every voxel moved by a seeded offset),
compiled once: its fitness is the mean of theirs, and one unstable start makes the robot
unstable. A generation's results, whatever the task, are a `PopulationEvaluation`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mjregen.grid import Material, Robot
from mjregen.physics import Physics
from mjregen.physics.simulation import simulate_starts
from mjregen.tasks.fitness import starts_fitness


@dataclass(frozen=True)
class RobotJob:
    """A robot grid (int8 array, any valid shape) with its physics, measured time (s; None =
    the scene's), number of starts (>= 1; starts 0, 1, ...), the starts' seed and the
    fitness rule (2 or 3, `mjregen.tasks.fitness.locomotion_fitness`; None = the grid's
    dimension)."""

    grid: np.ndarray
    physics: Physics
    duration: float | None = None
    starts: int = 1
    start_seed: int = 0
    rule: int | None = None


@dataclass(frozen=True)
class RobotEvaluation:
    """What an evolution needs of a robot's walks from its starts.

    Attributes:
      fitness: the mean locomotion fitness over the starts; the unstable penalty when any
        start was unstable.
      distance: voxel lengths, the mean distance over the starts (NaN when unstable).
      distance_min: voxel lengths, the shortest of them (NaN when unstable).
      distances: voxel lengths, each start's distance (NaN where unstable).
      n_voxels: voxels of the robot.
      stable: every start stayed stable.
      reason: why the first unstable start is unstable ("" when stable).
      steps, cpu_time: summed over the starts (CPU s, compile included).
    """

    fitness: float
    distance: float
    n_voxels: int
    stable: bool
    reason: str
    steps: int
    cpu_time: float
    distance_min: float = float("nan")
    distances: tuple[float, ...] = ()

    @property
    def distance_std(self) -> float:
        """Voxel lengths, the standard deviation of `distances` (0 for one start)."""
        return float(np.std(self.distances)) if self.distances else float("nan")


HARD_STEP_COST = 1.7  # steps of a robot with a hard voxel / without (measured on 3D blocks)


def expected_cost(grid: np.ndarray) -> float:
    """Relative CPU cost of simulating `grid` (int8 robot grid): its voxel count, times
    HARD_STEP_COST when a hard voxel is present (its stiff bonds shorten the step). For
    ordering work, not a measurement."""
    voxels = float(np.count_nonzero(grid))
    return voxels * HARD_STEP_COST if np.any(grid == Material.HARD) else voxels


def evaluate_robot(job: RobotJob) -> RobotEvaluation:
    """Walk `job.grid` from its starts 0 .. ``job.starts`` - 1; never raises for an unstable
    run (see `simulate`)."""
    results = simulate_starts(Robot(job.grid), physics=job.physics, duration=job.duration,
                              starts=range(job.starts), start_seed=job.start_seed)
    unstable = [r for r in results if not r.stable]
    distances = tuple(r.distance for r in results)
    first = results[0]
    return RobotEvaluation(
        fitness=starts_fitness(results, rule=job.rule),
        distance=float(np.mean(distances)), distance_min=float(np.min(distances)),
        distances=distances, n_voxels=first.n_voxels, stable=not unstable,
        reason=unstable[0].reason if unstable else "",
        steps=sum(r.steps for r in results), cpu_time=sum(r.cpu_time for r in results),
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
