"""The paper's Table 1 from several regrowth runs per row, and their robots in its engine.

Runs live under ``<root>/table1/<robot>_<name>/seed_<s>`` (`mjregen regen --paper ROBOT
--out ...`); every finished one (a recovery.json) that regrows the paper's cut counts, and
rows group them by robot, regrowth network and start (how the CA state regrown from was
made: "saved", "alpha 1" or "grown"). Runs that grow a robot from its seed (``--damage
seed``, the source of a "grown" start) are not rows: `seed_growth_runs` lists them, and
`grows_exactly` says whether one's grown state is a start of its robot. The paper's engine walks each run's
original, damaged and regrown robot once (`measure_in_engine`); the distances are kept in
``<root>/table1_engine.json`` by the robot files' paths relative to `root`.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mjregen.experiments.engine_walks import read_kept, walk_new
from mjregen.experiments.paper import read_run
from mjregen.experiments.recovery import ROLES
from mjregen.experiments.regrowth import SEED_DAMAGE
from mjregen.grid import Robot
from mjregen.validation.engine import PaperEngine

FOLDER = "table1"
ENGINE_FILE = "table1_engine.json"
PAPER_CUT = "paper cut"  # the damage label of a run that regrows the paper's cut


@dataclass(frozen=True)
class Spread:
    """Mean, smallest and largest of `n` values (NaN for none)."""

    mean: float
    low: float
    high: float
    n: int

    @classmethod
    def of(cls, values: list[float]) -> Spread:
        if not values:
            return cls(math.nan, math.nan, math.nan, 0)
        return cls(float(np.mean(values)), float(min(values)), float(max(values)), len(values))


@dataclass(frozen=True)
class Table1Run:
    """One regrowth run.

    Attributes:
      folder: its run folder.
      robot: the robot's name (the folder's parent's name up to its first "_").
      net: the regrowth network, "ff" or "lstm".
      start: how the CA state regrown from was made ("saved", "alpha 1", "grown").
      damage: what was erased (`PAPER_CUT`; `SEED_DAMAGE`: all but the paper's seed).
      seed: the GA's seed.
      population, generations, planned: the GA's population, the generations it ran and
        the generations it was started for.
      elapsed: s of wall time its generations took (metrics.csv's last ``elapsed``; one
        process on one core for the runs of records/paper).
      recovery: its recovery.json (similarity, distances in voxel lengths, percentages);
        None while it is under way.
    """

    folder: Path
    robot: str
    net: str
    start: str
    damage: str
    seed: int
    population: int
    generations: int
    planned: int
    elapsed: float
    recovery: dict | None


def all_run_folders(root: str | Path) -> list[Path]:
    """Every run folder under ``root/table1``, the runs that grow a robot from its seed (the
    source of a "grown" start) included."""
    return [folder for folder in sorted(Path(root, FOLDER).glob("*/seed_*"))
            if (folder / "config.json").is_file()]


def list_table1_runs(root: str | Path) -> list[Table1Run]:
    """Every finished run under ``root/table1`` that regrows the paper's cut, in folder order."""
    return [run for run in _paper_cut_runs(root) if run.recovery is not None]


def runs_under_way(root: str | Path) -> list[Table1Run]:
    """The runs under ``root/table1`` that regrow the paper's cut and have not finished (no
    recovery.json yet; their `recovery` is None), in folder order."""
    return [run for run in _paper_cut_runs(root) if run.recovery is None]


def seed_growth_runs(root: str | Path) -> list[Table1Run]:
    """The runs under ``root/table1`` that grow a robot from the paper's seed (``--damage
    seed``, the source of a "grown" start), finished or not, in folder order. A finished one
    grows its robot exactly when `grows_exactly`."""
    return _runs_with_damage(root, SEED_DAMAGE)


def grows_exactly(run: Table1Run) -> bool:
    """Does the finished run's best NCA grow (regrow) every cell of the grid as the
    original has it? (Only then is its grown CA state a start of the same robot.)"""
    return run.recovery is not None and (
        run.recovery["similarity"]["regrown"] == run.recovery["grid_cells"])


def _paper_cut_runs(root: str | Path) -> list[Table1Run]:
    return _runs_with_damage(root, PAPER_CUT)


def _runs_with_damage(root: str | Path, damage: str) -> list[Table1Run]:
    runs = [read_table1_run(folder) for folder in all_run_folders(root)]
    return [run for run in runs if run.damage == damage]


def read_table1_run(folder: str | Path) -> Table1Run:
    """The regrowth run in `folder` (its robot named by the folder's parent)."""
    folder = Path(folder)
    progress = read_run(folder)
    config = progress.config
    task = config["task"]
    recovery = folder / "recovery.json"
    return Table1Run(folder=folder, robot=folder.parent.name.split("_")[0],
                     net=task["nca"]["kind"], start=task.get("start", "?"),
                     damage=task.get("damage", "?"), seed=int(config["seed"]),
                     population=int(config["ga"]["population"]),
                     generations=progress.generations_done,
                     planned=progress.generations_planned, elapsed=progress.elapsed,
                     recovery=json.loads(recovery.read_text()) if recovery.is_file() else None)


@dataclass(frozen=True)
class Table1Row:
    """The runs of one robot, regrowth network and start: their recovery as spreads."""

    robot: str
    net: str
    start: str
    runs: tuple[Table1Run, ...]

    @property
    def grid_cells(self) -> int:
        """Cells of the robot's grid (729 for the paper's 9 x 9 x 9)."""
        return int(self.runs[0].recovery["grid_cells"])

    @property
    def hours(self) -> float:
        """Wall time of the row's runs, summed (h)."""
        return sum(run.elapsed for run in self.runs) / 3600

    def similarity(self) -> Spread:
        """Cells of the regrown grid equal to the original's."""
        return Spread.of([r.recovery["similarity"]["regrown"] for r in self.runs])

    def distance(self, role: str) -> Spread:
        """mjregen's distance of the `role` robot (voxel lengths)."""
        return Spread.of([r.recovery["distance"][role] for r in self.runs])

    def percent(self, role: str) -> Spread:
        """mjregen's distance of the `role` robot in % of its run's original's."""
        return Spread.of([r.recovery["percent_of_original"][role] for r in self.runs
                          if r.recovery["percent_of_original"][role] is not None])

    def engine_distance(self, root: str | Path, measured: dict, role: str) -> Spread:
        """The paper engine's distance of the `role` robot over the runs it walked."""
        return Spread.of([d for d in (measured.get(engine_key(root, r.folder, role))
                                      for r in self.runs) if d is not None])

    def engine_percent(self, root: str | Path, measured: dict, role: str) -> Spread:
        """The engine's distance of the `role` robot in % of its run's original's, over the
        runs whose both robots it walked (an original at rest gives no percentage)."""
        values = []
        for run in self.runs:
            mine, original = (measured.get(engine_key(root, run.folder, r))
                              for r in (role, "original"))
            if mine is not None and original:
                values.append(100.0 * mine / original)
        return Spread.of(values)


def table1_rows(runs: list[Table1Run]) -> list[Table1Row]:
    """The runs grouped by (robot, network, start), sorted by those."""
    groups: dict[tuple[str, str, str], list[Table1Run]] = {}
    for run in runs:
        groups.setdefault((run.robot, run.net, run.start), []).append(run)
    return [Table1Row(*key, runs=tuple(sorted(group, key=lambda r: r.seed)))
            for key, group in sorted(groups.items())]


def engine_key(root: str | Path, folder: Path, role: str) -> str:
    """The key of a run's `role` robot in table1_engine.json: its path relative to `root`."""
    return (Path(folder) / f"{role}.npy").relative_to(Path(root)).as_posix()


def read_engine_distances(root: str | Path) -> dict[str, float | None]:
    """``root/table1_engine.json`` ({} if there is none).

    Raises:
      ValueError: the file is not a JSON object of distances.
    """
    return read_kept(Path(root, ENGINE_FILE))


def measure_in_engine(root: str | Path, engine: PaperEngine, *,
                      progress: Callable[[str], None] = print) -> dict[str, float | None]:
    """Walk in `engine` the original, damaged and regrown robot of every run of
    `list_table1_runs` not yet in ``root/table1_engine.json`` (a grid already walked is not
    walked again), add them to that file and return all its distances (voxel lengths)."""
    robots = ((engine_key(root, run.folder, role),
               functools.partial(Robot.load, run.folder / f"{role}.npy"))
              for run in list_table1_runs(root) for role in ROLES)
    return walk_new(Path(root, ENGINE_FILE), robots, engine, progress=progress)
