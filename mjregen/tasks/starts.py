"""How much of a robot's walk belongs to its exact start: the walk from shifted starts.

Every walk starts with each voxel moved by a seeded random offset (`Scene.start_shift`,
`mjregen.physics.start_state`), and an evolution scores a robot by the mean of
`DEFAULT_STARTS` such starts unless told otherwise. A body that is its own mirror image keeps
that symmetry from the exact start (shift 0: nothing in the physics breaks it) and may walk
a way that any shift ends; any gait near a parting of ways (a stick–slip event, a stride that
flips) may likewise depend on its start. `shifted_starts` walks the robot from the exact
start and from `starts` shifted ones (start indices 0, 1, ... of seed `start_seed`, every
voxel moved by normal random amounts of `shift` voxel lengths), so that a user can judge the
robot by the distances it keeps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mjregen.errors import MjregenError
from mjregen.grid import Robot

# the physics (and MuJoCo) load on first use: the command line reads this module's defaults
# while building its parser, before it chooses MuJoCo's GL backend
if TYPE_CHECKING:
    from mjregen.physics import Physics
    from mjregen.physics.simulation import Result
    from mjregen.search.backends import Backend

KEPT = 0.9  # a robot whose shifted starts keep less of its distance than this on average
#             walks, from the exact start, partly by that start
STILL = 1e-3  # voxel lengths: a walk from the exact start shorter than this is no walk to keep
DEFAULT_STARTS = 1  # starts per robot of an evolution's score (docs/transfer.md measures it)
CHECK_STARTS = 20  # shifted starts of a robot's check, e.g. `mjregen walk --shifted-starts 20`


@dataclass(frozen=True)
class StartJob:
    """One walk: a robot grid (int8), its physics (whose scene's ``start_shift`` is the
    start's: 0 = exact), measured time (s; None = the scene's), the start's seed and index,
    and whether to record the centre-of-mass trajectory."""

    grid: np.ndarray
    physics: Physics
    duration: float | None
    seed: int
    index: int
    record: bool = False


def walk_from(job: StartJob) -> Result:
    """`simulate` the job's robot from its start (the backends' function)."""
    from mjregen.physics.simulation import simulate

    return simulate(Robot(job.grid), physics=job.physics, duration=job.duration,
                    record=job.record, start_seed=job.seed, start=job.index)


@dataclass(frozen=True)
class ShiftedStarts:
    """The walk from the exact start and from the shifted ones.

    Attributes:
      default: the exact start's `Result` (start shift 0).
      shift: voxel lengths, standard deviation of every voxel's shift.
      seed: the shifted starts' seed.
      indices: ``(starts,)`` the shifted starts' indices.
      distances: ``(starts,)`` voxel lengths from each shifted start; NaN where that walk
        became unstable.
      reasons: why each unstable walk is unstable ("" for the stable ones).
      mirror_axes: the horizontal axes across which the body is its own mirror image
        (`Robot.mirror_axes`).
    """

    default: Result
    shift: float
    seed: int
    indices: tuple[int, ...]
    distances: np.ndarray
    reasons: tuple[str, ...]
    mirror_axes: tuple[str, ...]

    @property
    def stable(self) -> np.ndarray:
        """``(starts,)`` bool: the shifted walks that stayed stable."""
        return np.isfinite(self.distances)

    def _statistic(self, reduce) -> float:
        kept = self.distances[self.stable]
        return float(reduce(kept)) if kept.size else math.nan

    @property
    def mean(self) -> float:
        """Voxel lengths, the mean distance of the stable shifted walks (NaN if none)."""
        return self._statistic(np.mean)

    @property
    def low(self) -> float:
        """Voxel lengths, the shortest stable shifted walk (NaN if none)."""
        return self._statistic(np.min)

    @property
    def high(self) -> float:
        """Voxel lengths, the longest stable shifted walk (NaN if none)."""
        return self._statistic(np.max)

    @property
    def kept(self) -> float:
        """`mean` / the exact start's distance; NaN when that walk is unstable or
        shorter than STILL (the robot does not walk)."""
        default = self.default.distance
        if not (math.isfinite(default) and default >= STILL):
            return math.nan
        return self.mean / default

    @property
    def depends_on_start(self) -> bool:
        """The shifted walks keep less than KEPT of the exact start's distance on
        average, or some of them became unstable."""
        return bool(self.kept < KEPT) or not bool(np.all(self.stable))


def _walks(jobs: list[StartJob], backend: Backend | None) -> list:
    """Each job's walk (`walk_from`), in this process or on `backend`; MjregenError naming
    the first start whose walk failed there."""
    if backend is None:
        return [walk_from(job) for job in jobs]
    outcomes = backend.map(walk_from, jobs)
    for job, outcome in zip(jobs, outcomes):
        if not outcome.ok:
            which = (f"shifted start {job.index} (seed {job.seed})"
                     if job.physics.scene.start_shift else "exact start")
            raise MjregenError(f"the walk from the {which} failed: {outcome.error}")
    return [outcome.value for outcome in outcomes]


def shifted_starts(robot: Robot, *, physics: Physics | None = None,
                   duration: float | None = None, starts: int = CHECK_STARTS,
                   shift: float | None = None, start_seed: int = 0,
                   backend: Backend | None = None, record_default: bool = False
                   ) -> ShiftedStarts:
    """Walk `robot` from the exact start and from `starts` shifted ones.

    Args:
      robot: a non-empty `Robot`.
      physics: None = the paper's.
      duration: s of actuation that the distance counts; None = the scene's measured time.
      starts: number of shifted starts (>= 1): indices 0 .. `starts` - 1.
      shift: voxel lengths, > 0: standard deviation of each voxel's shift; None = the
        scene's ``start_shift`` (its default when that is 0).
      start_seed: the shifted starts' seed (>= 0).
      backend: a `mjregen.search.backends.Backend` to run the walks on (None: in this
        process, one after another); every walk is the same whichever runs it.
      record_default: record the exact start's centre-of-mass trajectory
        (`simulate`'s ``record``).
    Raises:
      MjregenError: an empty robot, `starts` < 1, `shift` not a number > 0 within the
        scene's range, or a walk that failed on `backend` (its reason).
      PhysicsParameterError: bad `duration` (from `simulate`).
      CompileError: `start_seed` not a whole number >= 0.
    """
    if robot.is_empty:
        raise MjregenError("an empty robot has no walk to start")
    if isinstance(starts, bool) or not isinstance(starts, int) or starts < 1:
        raise MjregenError(f"starts must be a whole number >= 1, got {starts!r}")
    from mjregen.physics import Physics
    from mjregen.physics.params import DEFAULT_START_SHIFT

    physics = Physics() if physics is None else physics
    if shift is None:
        shift = physics.scene.start_shift or DEFAULT_START_SHIFT
    if isinstance(shift, bool) or not isinstance(shift, (int, float)) \
            or not (math.isfinite(shift) and shift > 0.0):
        raise MjregenError(f"shift must be a finite number of voxel lengths > 0, got {shift!r}")
    try:
        shifted = physics.replace(start_shift=float(shift))
    except ValueError as error:
        raise MjregenError(f"shift: {error}") from None
    exact = physics.replace(start_shift=0.0)
    indices = tuple(range(starts))
    grid = np.asarray(robot.grid)
    jobs = [StartJob(grid, exact, duration, 0, 0, record=record_default)]
    jobs += [StartJob(grid, shifted, duration, start_seed, index) for index in indices]
    results = _walks(jobs, backend)
    return ShiftedStarts(
        default=results[0], shift=float(shift), seed=start_seed, indices=indices,
        distances=np.array([r.distance for r in results[1:]], dtype=float),
        reasons=tuple(r.reason for r in results[1:]), mirror_axes=robot.mirror_axes())
