"""One robot's locomotion evaluation as a job for a worker (no torch imported here).

`evaluate_robot` is the function the evaluation backends run: it takes a small picklable
job and returns a small picklable `RobotEvaluation` (no trajectories).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.simulate import simulate


@dataclass(frozen=True)
class RobotJob:
    """A robot grid (int8 array, any valid shape) with its physics and measured time (s)."""

    grid: np.ndarray
    physics: Physics
    duration: float | None = None


@dataclass(frozen=True)
class RobotEvaluation:
    """The parts of a `mjregen.simulate.Result` an evolution needs."""

    fitness: float
    distance: float
    n_voxels: int
    stable: bool
    reason: str
    steps: int
    cpu_time: float


def evaluate_robot(job: RobotJob) -> RobotEvaluation:
    """Simulate `job.grid`; never raises for an unstable run (see `simulate`)."""
    result = simulate(Robot(job.grid), physics=job.physics, duration=job.duration)
    return RobotEvaluation(
        fitness=result.fitness, distance=result.distance, n_voxels=result.n_voxels,
        stable=result.stable, reason=result.reason, steps=result.steps, cpu_time=result.cpu_time,
    )
