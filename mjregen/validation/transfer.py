"""Does a robot's walk transfer: from other starts, turned, at a finer time step, and in
the paper's engine?

A robot transfers (`TRANSFER_RULE`) when fresh starts, its turned copies and a walk at
`FINER_STEP` of the time step keep, on average, at least `KEEP` of its distance (the mean
over its starts of seed 0), and the paper's engine walks it at least `ENGINE` as far. A walk
that holds only from one exact start, one orientation or one time step is an artefact of the
simulation, not a gait.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.physics.simulation import simulate, simulate_starts
from mjregen.validation.engine import PaperEngine

KEEP = 0.9  # share of the distance that fresh starts, turned copies and a finer step keep
ENGINE = 0.8  # share of the distance the paper's engine walks
FINER_STEP = 0.5  # the finer step's fraction of the physics' own time step
TRANSFER_RULE = (f"fresh starts, rotations and a time step {FINER_STEP:g} of the default keep "
                 f">= {KEEP:.0%} of the distance on average, and the paper's engine walks "
                 f">= {ENGINE:.0%} of it")


@dataclass
class Transfer:
    """One robot's walks, voxel lengths.

    Attributes:
      name, voxels: the robot.
      mirror_axes: the axes its grid is mirror-symmetric across (`Robot.mirror_axes`).
      starts: from its starts 0.. of seed 0 (their mean is its distance).
      fresh: from as many starts of seed 1.
      rotated: turned about z by 90, 180 and 270 degrees (2D: mirrored in x), start 0.
      exact: from the exact start (start shift 0).
      finer_step: from the same starts as `starts` with the time step `FINER_STEP` of the
        physics' own (a walk that the integration makes, not the physics, changes with the
        step; the same starts, so that the spread between starts is not taken for it).
      engine: in the paper's engine; None for 2D or without an engine.
    """

    name: str
    voxels: int
    mirror_axes: list[str]
    starts: list[float]
    fresh: list[float]
    rotated: list[float]
    exact: float
    finer_step: list[float]
    engine: float | None

    @property
    def distance(self) -> float:
        """The mean over the starts of seed 0."""
        return float(np.mean(self.starts))

    @property
    def fresh_kept(self) -> float:
        return float(np.mean(self.fresh)) / self.distance

    @property
    def rotated_kept(self) -> float:
        return float(np.mean(self.rotated)) / self.distance

    @property
    def finer_step_kept(self) -> float:
        return float(np.mean(self.finer_step)) / self.distance

    @property
    def engine_ratio(self) -> float | None:
        return None if self.engine is None else self.engine / self.distance

    @property
    def transfers(self) -> bool:
        """`TRANSFER_RULE` (False without an engine's distance)."""
        engine = self.engine_ratio
        return (self.fresh_kept >= KEEP and self.rotated_kept >= KEEP
                and self.finer_step_kept >= KEEP and engine is not None and engine >= ENGINE)


def rotations(robot: Robot) -> list[Robot]:
    """The robot turned about z: by 90, 180 and 270 degrees in 3D; mirrored in x in 2D (a
    half turn about z of a robot in the x-z plane)."""
    grid = np.asarray(robot.grid)
    if robot.dim == 2:
        return [Robot(np.ascontiguousarray(grid[::-1, :]))]
    return [Robot(np.ascontiguousarray(np.rot90(grid, k, axes=(0, 1)))) for k in (1, 2, 3)]


def measure_transfer(robot: Robot, *, name: str = "robot", starts: int = 10,
                     engine: PaperEngine | None = None,
                     physics: Physics | None = None) -> Transfer:
    """Walk `robot` every way `Transfer` lists, with `physics` (None = the default; a sheet
    of a 2D run: `mjregen.tasks.bodies.body_physics`), the engine for the same settle
    and measured times."""
    physics = physics or Physics()

    def distances(seed: int, walk: Physics = physics) -> list[float]:
        return [r.distance for r in simulate_starts(robot, physics=walk, start_seed=seed,
                                                    starts=range(starts))]

    exact = simulate(robot, physics=physics.replace(start_shift=0.0))
    finer = physics.replace(timestep_safety=FINER_STEP * physics.scene.timestep_safety)
    times = physics.scene.timing(robot.dim)
    return Transfer(name=name, voxels=robot.n_voxels, mirror_axes=list(robot.mirror_axes()),
                    starts=distances(0), fresh=distances(1),
                    rotated=[simulate(r, physics=physics).distance for r in rotations(robot)],
                    exact=exact.distance, finer_step=distances(0, finer),
                    engine=None if engine is None else engine.distance(robot, times=times))


def transfer_record(row: Transfer, starts: int, physics: Physics | None = None) -> dict:
    """`row` as a shipped walker's manifest block "transfer" (what tests/test_assets.py reads
    back): the physics (None = the default) it was measured with, every walk, the rule, the
    verdict and the date."""
    return {"physics": (physics or Physics()).to_dict(), "starts": starts, "distance": row.distance,
            "distances": row.starts, "fresh": float(np.mean(row.fresh)),
            "fresh_distances": row.fresh, "rotated": row.rotated, "exact_start": row.exact,
            "finer_step": float(np.mean(row.finer_step)),
            "finer_step_distances": row.finer_step, "engine": row.engine, "rule": TRANSFER_RULE,
            "transfers": row.transfers, "measured": datetime.now(UTC).date().isoformat()}


def best_transferring(rows: list[Transfer]) -> Transfer | None:
    """The row of the farthest walker (mean over its starts) among those that transfer;
    None when none does."""
    return max((row for row in rows if row.transfers), key=lambda row: row.distance,
               default=None)


def read_measurements(path: str | Path) -> dict[str, dict]:
    """Transfer measurements kept in a JSON file (`benchmarks/transfer.py --json`: a list of
    entries with a "name") by name; empty if the file is not there.

    Raises:
      ValueError: the file holds something else.
    """
    path = Path(path)
    if not path.is_file():
        return {}
    entries = json.loads(path.read_text())
    if not isinstance(entries, list) or not all(isinstance(e, dict) and "name" in e
                                                for e in entries):
        raise ValueError(f"{path} is not a list of transfer measurements "
                         "(benchmarks/transfer.py --json)")
    return {entry["name"]: entry for entry in entries}
