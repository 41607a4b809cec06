"""Robots of finished runs walked in the paper's engine, kept in a JSON file beside the runs.

The file maps a key (which run's which robot) to the engine's distance in voxel lengths
(null where the engine runs no such robot, e.g. a 2D grid). A robot already in the file is
not walked again, a grid met twice is walked once, and the file is rewritten whole after
every walk, so an interrupted measurement keeps what it measured.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable
from pathlib import Path

from mjregen.fileio import atomic_open
from mjregen.grid import Robot
from mjregen.validation.engine import PaperEngine


def read_kept(path: str | Path) -> dict[str, float | None]:
    """The distances kept in `path` ({} if there is no such file).

    Raises:
      ValueError: the file is not a JSON object of distances (the message names it).
    """
    path = Path(path)
    if not path.is_file():
        return {}
    try:
        kept = json.loads(path.read_text())
    except json.JSONDecodeError as error:
        raise ValueError(f"{path} is not JSON: {error}") from error
    if not isinstance(kept, dict) or not all(
            value is None or isinstance(value, (int, float)) for value in kept.values()):
        raise ValueError(f"{path} should map robots to distances")
    return kept


def walk_new(path: str | Path, robots: Iterable[tuple[str, Callable[[], Robot]]],
             engine: PaperEngine, *, progress: Callable[[str], None] = print
             ) -> dict[str, float | None]:
    """Walk in `engine` each robot of `robots` ((key, a function that makes the robot))
    whose key `path` does not hold yet, add it to `path` and return all its distances."""
    kept = read_kept(path)
    by_grid: dict[bytes, float | None] = {}
    for key, make in robots:
        if key in kept:
            continue
        robot = make()
        grid = robot.grid.tobytes()
        if grid not in by_grid:
            by_grid[grid] = 0.0 if robot.is_empty else engine.distance(robot)
        kept[key] = by_grid[grid]
        progress(f"{key}: {kept[key]}")
        with atomic_open(path, "w") as handle:
            json.dump(kept, handle, indent=1, sort_keys=True)
    return kept
