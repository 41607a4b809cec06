"""Three good and diverse 3D walkers from the evolution runs, for the regrowth experiment.

Candidates are the distinct best-of-generation robots of the 3D runs (`mjregen.experiments.paper`
folders) that walked and are one piece; `pick_walkers` takes the farthest walker, then the
most different ones (`DIVERSITY`); `load_or_pick_walkers` picks once and keeps the choice
in ``<root>/walkers/walkers.json``.
"""

from __future__ import annotations

import json
import math
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mjregen.errors import MjregenError
from mjregen.experiments.paper import CONDITIONS, DEFAULT_ROOT, list_runs
from mjregen.fileio import atomic_open
from mjregen.grid import Material, Robot, count_pieces

MIN_WALK = 0.25  # a walker covers at least this fraction of the farthest candidate's distance
DIVERSITY = (
    "Candidates: every distinct best-of-generation robot of the 3D runs that walked (distance > 0) "
    "and is one face-connected piece. Pool: the 30 that walked farthest, of those that walked at "
    "least a quarter of the farthest one's distance (so every pick is a real walker, not a "
    "morphological outlier that stands still). Features: voxel count; "
    "fractions of soft, hard, muscle + and muscle - voxels; feet (face-connected pieces of the "
    "lowest layer); length, width and height in voxels; each standardised over the pool. "
    "Greedy farthest-point selection: the farthest walker first, then repeatedly the candidate "
    "farthest (Euclidean, in standardised features) from all walkers already picked.")
FEATURES = ("voxels", "soft", "hard", "muscle_plus", "muscle_minus", "feet", "length", "width",
            "height")


def pieces(robot: Robot) -> int:
    """Number of face-connected pieces of the robot."""
    return count_pieces(robot.grid != 0)


def morphology(robot: Robot) -> dict[str, float]:
    """The features `pick_walkers` compares (3D robots).

    voxels: count; soft, hard, muscle_plus, muscle_minus: fractions of the voxels; feet:
    face-connected pieces of the lowest occupied layer (what stands on the floor before the
    settle); length, width, height: extent along x, y, z in voxels.
    """
    grid = robot.grid
    occupied = np.argwhere(grid != 0)
    n = len(occupied)
    if n == 0:
        return {name: 0.0 for name in FEATURES}
    counts = robot.material_counts()
    low = occupied[:, -1].min()
    sole = np.zeros_like(grid)
    sole[..., low] = grid[..., low]
    extent = occupied.max(axis=0) - occupied.min(axis=0) + 1
    return {"voxels": float(n),
            **{m.name.lower(): counts.get(m, 0) / n for m in Material if m != Material.EMPTY},
            "feet": float(pieces(Robot(sole))),
            "length": float(extent[0]), "width": float(extent[1]), "height": float(extent[-1])}


@dataclass(frozen=True)
class Candidate:
    """A generation's best robot of a 3D run: files, the run's measures, its morphology."""

    run: Path
    condition: str
    seed: int
    generation: int
    fitness: float
    distance: float
    robot: Robot = field(repr=False)
    features: dict[str, float]

    @property
    def files(self) -> tuple[Path, Path]:
        stem = self.run / "best" / f"gen_{self.generation:04d}"
        return stem.with_suffix(".npz"), stem.with_suffix(".npy")


def walker_candidates(root: str | Path = DEFAULT_ROOT) -> list[Candidate]:
    """Every distinct best-of-generation robot of every 3D run under `root` that walked
    (finite distance > 0) and is one piece; the first occurrence of each grid is kept."""
    from mjregen.growth.checkpoint import load_nca

    seen: set[bytes] = set()
    found = []
    for name, runs in list_runs(root).items():
        if CONDITIONS[name].dim != 3:
            continue
        for run in runs:
            for generation in range(run.generations_done):
                npz, npy = run.best_files(generation)
                if not (npz.is_file() and npy.is_file()):
                    continue
                robot = Robot.load(npy)
                key = robot.grid.tobytes()
                if key in seen:
                    continue
                seen.add(key)
                metadata = load_nca(npz)[1]
                distance = float(metadata.get("distance", math.nan))
                if not (math.isfinite(distance) and distance > 0) or pieces(robot) != 1:
                    continue
                found.append(Candidate(run.path, name, run.seed, generation,
                                       float(metadata["fitness"]), distance, robot,
                                       morphology(robot)))
    return found


def pick_walkers(candidates: list[Candidate], *, count: int = 3, pool: int = 30) -> list[Candidate]:
    """Good and diverse walkers: of the candidates that walked at least `MIN_WALK` × the
    farthest one's distance, the `pool` that walked farthest; then greedy farthest-point
    selection in the space of `FEATURES`, each standardised over the pool (z-scores;
    constant features drop out): the farthest walker first, then repeatedly the candidate
    whose smallest distance to those already picked is largest (ties: farther walker).
    Fewer than `count` if there are fewer such walkers."""
    ranked = sorted(candidates, key=lambda c: (-c.distance, c.condition, c.seed, c.generation))
    if ranked:
        ranked = [c for c in ranked if c.distance >= MIN_WALK * ranked[0].distance]
    ranked = ranked[:pool]
    if not ranked:
        return []
    values = np.array([[c.features[f] for f in FEATURES] for c in ranked])
    spread = values.std(axis=0)
    z = (values - values.mean(axis=0)) / np.where(spread > 0, spread, 1.0)
    picked = [0]
    while len(picked) < min(count, len(ranked)):
        gaps = np.min(np.linalg.norm(z[:, None, :] - z[None, picked, :], axis=2), axis=1)
        gaps[picked] = -1.0
        picked.append(int(np.argmax(gaps)))  # argmax keeps the first (farther walker) on ties
    return [ranked[i] for i in picked]


def walkers_folder(root: str | Path = DEFAULT_ROOT) -> Path:
    return Path(root) / "walkers"


def load_or_pick_walkers(root: str | Path = DEFAULT_ROOT, *, count: int = 3,
                         pool: int = 30) -> list[dict]:
    """The walkers of the regrowth experiment: read ``<root>/walkers/walkers.json``, or pick
    them (`pick_walkers` over `walker_candidates`) and write it with each walker's NCA and
    robot as ``walker_<i>.npz/.npy`` beside it. Picked once: later runs reuse the file.

    Returns:
      One dict per walker: name, npz, npy (paths), source run, condition, seed, generation,
      fitness, distance, features.
    Raises:
      MjregenError: there are no 3D runs with a walking, one-piece robot.
    """
    folder = walkers_folder(root)
    index = folder / "walkers.json"
    if index.is_file():
        return json.loads(index.read_text())["walkers"]
    candidates = walker_candidates(root)
    chosen = pick_walkers(candidates, count=count, pool=pool)
    if not chosen:
        raise MjregenError(f"no 3D run under {root} has a best robot that walks and is one "
                           "piece; run the 3D evolutions first")
    folder.mkdir(parents=True, exist_ok=True)
    walkers = []
    for i, c in enumerate(chosen, start=1):
        name = f"walker_{i}"
        npz, npy = c.files
        shutil.copyfile(npz, folder / f"{name}.npz")
        shutil.copyfile(npy, folder / f"{name}.npy")
        walkers.append({"name": name, "npz": str(folder / f"{name}.npz"),
                        "npy": str(folder / f"{name}.npy"), "run": str(c.run),
                        "condition": c.condition, "seed": c.seed, "generation": c.generation,
                        "fitness": c.fitness, "distance": c.distance, "features": c.features})
    with atomic_open(index, "w") as handle:
        json.dump({"diversity": DIVERSITY, "pool": pool, "candidates": len(candidates),
                   "walkers": walkers}, handle, indent=2)
    return walkers
