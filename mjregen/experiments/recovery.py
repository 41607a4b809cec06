"""Locomotion recovery after damage: the paper's Table 1 for one robot.

Original, damaged and regrown robots walk with the same physics for the same time (the
paper's table: 0.5 s after the settle); distances of the damaged and regrown robots are
given as percentages of the original's.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from mjregen.fileio import atomic_open
from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.physics.simulation import simulate
from mjregen.tasks.fitness import locomotion_fitness
from mjregen.tasks.regrowth import robot_similarity, similarity

ROLES = ("original", "damaged", "regrown")
MEANINGFUL_DISTANCE = 0.01  # voxel lengths: a walk shorter than this is no reference


@dataclass(frozen=True)
class RecoveryReport:
    """Similarity and locomotion of the original, damaged and regrown robot.

    Attributes:
      grid_cells: cells in the grid (729 in 3D, 49 in 2D).
      similarity: cells of the regrown (and the damaged) grid equal to the original's.
      robot_similarity: the same restricted to cells either robot occupies (fraction).
      voxels, distance, fitness, stable: per role ("original", "damaged", "regrown");
        distance in voxel lengths.
      duration: s of walking measured.
    """

    grid_cells: int
    similarity: dict[str, int]
    robot_similarity: dict[str, float]
    voxels: dict[str, int]
    distance: dict[str, float]
    fitness: dict[str, float]
    stable: dict[str, bool]
    duration: float

    def percent_of_original(self, role: str) -> float:
        """`role`'s distance as a percentage of the original's (NaN when the original did
        not walk: below MEANINGFUL_DISTANCE, or unstable)."""
        original = self.distance["original"]
        if not original >= MEANINGFUL_DISTANCE:  # NaN too
            return float("nan")
        return 100.0 * self.distance[role] / original

    def to_dict(self) -> dict:
        """JSON-ready values (NaN, e.g. the distance of an unstable run, becomes None)."""
        values = asdict(self)
        values["percent_of_original"] = {r: self.percent_of_original(r) for r in ROLES[1:]}
        for key in ("distance", "percent_of_original"):
            values[key] = {r: None if np.isnan(v) else v for r, v in values[key].items()}
        return values

    def _percent(self, role: str) -> str:
        """"62 %" or "n/a" (a percentage of a distance that is not one)."""
        percent = self.percent_of_original(role)
        return "n/a" if np.isnan(percent) else f"{percent:.0f} %"

    def to_markdown(self, name: str = "robot") -> str:
        """A Markdown table in the layout of the paper's Table 1."""
        def flag(role: str) -> str:
            return "" if self.stable[role] else " (unstable)"

        return "\n".join([
            (f"| {name} | similarity (of {self.grid_cells}) | robot cells matching | voxels | "
            f"distance original | damaged (% of original) | regrown (% of original) |"),
            "|---|---|---|---|---|---|---|",
            (f"| {name} | {self.similarity['regrown']} (damaged {self.similarity['damaged']}) | "
            f"{100 * self.robot_similarity['regrown']:.1f} % | "
            f"{self.voxels['original']} / {self.voxels['damaged']} / {self.voxels['regrown']} | "
            f"{self.distance['original']:.2f}{flag('original')} | "
            f"{self.distance['damaged']:.2f} ({self._percent('damaged')}){flag('damaged')} | "
            f"{self.distance['regrown']:.2f} ({self._percent('regrown')}){flag('regrown')} |"),
            "",
            f"Distances in voxel lengths over {self.duration:g} s of walking.",
        ])


def measure_recovery(robots: dict[str, Robot], *, physics: Physics | None = None,
                     duration: float | None = None, start_seed: int = 0) -> RecoveryReport:
    """Simulate the three robots (keys `ROLES`) and compare them with the original.

    Args:
      robots: {"original": ..., "damaged": ..., "regrown": ...}, all of one grid shape.
      physics: None = the default physics.
      duration: s of walking; None = the scene's measured time (the paper's 0.5 s in 3D).
      start_seed: the seed of the start (start 0) each robot walks from
        (`mjregen.physics.simulate`); an evolved robot's own fitness walked from its run's.
    """
    missing = [role for role in ROLES if role not in robots]
    if missing:
        raise ValueError(f"measure_recovery needs robots for {', '.join(missing)}")
    physics = Physics() if physics is None else physics
    results = {role: simulate(robots[role], physics=physics, duration=duration,
                              start_seed=start_seed) for role in ROLES}
    original = robots["original"].grid
    grids = np.stack([robots[role].grid for role in ROLES])
    equal = similarity(grids, original)
    overlap = robot_similarity(grids, original)
    dim = robots["original"].dim
    return RecoveryReport(
        grid_cells=int(original.size),
        similarity={role: int(equal[i]) for i, role in enumerate(ROLES)},
        robot_similarity={role: float(overlap[i]) for i, role in enumerate(ROLES)},
        voxels={role: robots[role].n_voxels for role in ROLES},
        distance={role: float(results[role].distance) for role in ROLES},
        fitness={role: float(locomotion_fitness(results[role])) for role in ROLES},
        stable={role: results[role].stable for role in ROLES},
        duration=float(physics.scene.timing(dim)[1] if duration is None else duration),
    )


def write_report(report: RecoveryReport, folder: str | Path, *, name: str = "robot") -> list[Path]:
    """Write ``recovery.md`` and ``recovery.json`` into `folder` (atomically)."""
    folder = Path(folder)
    with atomic_open(folder / "recovery.md", "w") as handle:
        handle.write(report.to_markdown(name) + "\n")
    with atomic_open(folder / "recovery.json", "w") as handle:
        json.dump(report.to_dict(), handle, indent=2)
    return [folder / "recovery.md", folder / "recovery.json"]
