"""Regeneration: damage a grown robot's CA state and regrow it with a second NCA.

The paper's experiment: an NCA grows a robot; its left side (grid x-indices 0–3 of the
9-grid) is cut away, state and alpha zeroed; a second, separately evolved NCA of the same
family runs 10 growth steps from the damaged state, followed by the paper's cleaning. Its
fitness is the number of grid cells whose material equals the original's (out of 729 in
3D, 49 in 2D). That number counts the always-empty border and the empty space around the
robot, so `robot_similarity` also reports agreement restricted to cells that either robot
occupies.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import torch

from mjregen.grid import N_MATERIALS, Robot, half_space_mask
from mjregen.growth.nca import CAState, Growth, NCAConfig, grow
from mjregen.tasks.cache import LRUCache
from mjregen.tasks.evaluation import PopulationEvaluation

if TYPE_CHECKING:  # the search layer hands a task its backend
    from mjregen.search.backends import Backend


def state_of_growth(growth: Growth, index: int = 0) -> CAState:
    """The CA state of individual `index` as the paper's code keeps a grown robot, the state
    its regeneration damages: the cleaned grid as the states (cells the cleaning removed are
    empty), every cell's grown alpha (an empty cell that is alive keeps its alpha) and
    memory; a population of one."""
    final = growth.final
    memory = None if final.memory is None else tuple(m[index : index + 1].clone() for m in final.memory)
    return CAState(
        state=torch.from_numpy(growth.grids[index].astype(np.int64))[None],
        alpha=final.alpha[index : index + 1].clone(),
        memory=memory,
    )


def state_of_robot(robot: Robot, config: NCAConfig) -> CAState:
    """A CA state for a robot known only by its grid (e.g. the paper's tripod and multiped):
    state = the grid, alpha 1 on voxels and 0 elsewhere, LSTM memory ones (a fresh
    network's)."""
    if robot.shape != config.grid_shape:
        raise ValueError(f"robot shape {robot.shape} does not match the NCA grid {config.grid_shape}")
    state = torch.from_numpy(robot.grid.astype(np.int64))[None]
    return CAState(state, (state != 0).to(torch.float32), _fresh_memory(config, 1))


def state_of_saved(saved: np.ndarray, config: NCAConfig) -> CAState:
    """The CA state the paper's code saves for a grown robot, ``(2, *grid)`` (channel 0 the
    states, channel 1 the alphas; e.g. the shipped ``robots/paper/biped_ca_state.npy``), as
    a population of one; LSTM memory ones (the paper resets it on damage).

    Raises:
      ValueError: not ``(2, *config.grid_shape)``, states that are not material codes, or
        alphas outside [0, 1].
    """
    saved = np.asarray(saved)
    if saved.shape != (2, *config.grid_shape):
        raise ValueError(f"a saved CA state must have shape {(2, *config.grid_shape)}, "
                         f"got {saved.shape}")
    states, alphas = saved[0], saved[1]
    if not np.all(np.isin(states, np.arange(N_MATERIALS))):
        raise ValueError(f"saved states must be material codes 0..{N_MATERIALS - 1}")
    if not (np.all(np.isfinite(alphas)) and alphas.min() >= 0.0 and alphas.max() <= 1.0):
        raise ValueError("saved alphas must lie in [0, 1]")
    state = torch.from_numpy(states.astype(np.int64))[None]
    alpha = torch.from_numpy(alphas.astype(np.float32))[None]
    return CAState(state, alpha, _fresh_memory(config, 1))


def damaged_robot(state: CAState) -> Robot:
    """The robot a (damaged) CA state of a population of one holds, after the paper's
    cleaning."""
    return Robot(state.state[0].numpy().astype(np.int8)).cleaned()


def _fresh_memory(config: NCAConfig, population: int) -> tuple[torch.Tensor, torch.Tensor] | None:
    return CAState.seed(config, population).memory


def _erase(state: CAState, mask: np.ndarray) -> CAState:
    """Zero state, alpha and memory of the cells in `mask` (bool: the grid's shape for every
    individual alike, or ``(P, *grid)``, one mask per individual)."""
    cells = torch.from_numpy(mask)
    if cells.dim() == state.state.dim() - 1:
        cells = cells[None]
    memory = None
    if state.memory is not None:
        inner = cells[(slice(None),) + (slice(1, -1),) * (cells.dim() - 1)]  # memory: interior
        memory = tuple(torch.where(inner[..., None], 0.0, m) for m in state.memory)
    return CAState(
        state=torch.where(cells, 0, state.state),
        alpha=torch.where(cells, 0.0, state.alpha),
        memory=memory,
    )


def erase_cells(state: CAState, masks: np.ndarray) -> CAState:
    """Damage: erase, in each individual of `state`, the cells of its own mask (bool
    ``(P, *grid)``)."""
    if masks.shape != tuple(state.state.shape):
        raise ValueError(f"masks of shape {masks.shape} do not match the states "
                         f"{tuple(state.state.shape)}")
    return _erase(state, masks)


def cut_half_space(state: CAState, condition: str) -> CAState:
    """Damage: erase every cell whose grid index satisfies `condition` (e.g. ``"x < 4"``)."""
    return _erase(state, half_space_mask(tuple(state.state.shape[1:]), condition))


def paper_cut(state: CAState) -> CAState:
    """The paper's damage: the left side, grid x-indices below the centre (0–3 of 9)."""
    return cut_half_space(state, f"x < {state.state.shape[1] // 2}")


def remove_chunk(state: CAState, *, size: int, seed: int | np.random.Generator) -> CAState:
    """Damage: erase a random face-connected chunk of up to `size` voxels, grown from a
    random voxel by breadth-first search in random order."""
    rng = np.random.default_rng(seed)
    grid = state.state[0].numpy()
    voxels = np.argwhere(grid != 0)
    if len(voxels) == 0 or size < 1:
        return state
    start = tuple(voxels[rng.integers(len(voxels))])
    chunk, frontier = {start}, [start]
    dim = grid.ndim
    while frontier and len(chunk) < size:
        cell = frontier.pop(0)
        neighbours = [tuple(c + d * (a == axis) for a, c in enumerate(cell))
                      for axis in range(dim) for d in (-1, 1)]
        for neighbour in rng.permutation(len(neighbours)):
            n = neighbours[neighbour]
            if n not in chunk and grid[n] != 0 and len(chunk) < size:
                chunk.add(n)
                frontier.append(n)
    mask = np.zeros(grid.shape, dtype=bool)
    mask[tuple(np.array(sorted(chunk)).T)] = True
    return _erase(state, mask)


def similarity(grids: np.ndarray, original: np.ndarray) -> np.ndarray:
    """The paper's regeneration fitness: cells equal to `original`, per grid ``(P,)``."""
    return (grids == original).reshape(len(grids), -1).sum(axis=1)


def robot_similarity(grids: np.ndarray, original: np.ndarray) -> np.ndarray:
    """Fraction, per grid ``(P,)``, of the cells occupied by either robot whose material
    matches (1.0 = identical robots; empty space and the border do not count)."""
    occupied = ((grids != 0) | (original != 0)).reshape(len(grids), -1)
    equal = (grids == original).reshape(len(grids), -1) & occupied
    return equal.sum(axis=1) / np.maximum(occupied.sum(axis=1), 1)


@dataclass(frozen=True)
class RegrowthTask:
    """Evolve an NCA that regrows `original` from the `damaged` state.

    Attributes:
      nca: configuration of the regrowth NCA (its grid must match the robot's).
      original: int8 grid of the intact robot.
      damaged: the damaged CA state (a population of one). A feed-forward regrowth NCA
        ignores its memory; an LSTM one starts with fresh memory (ones), as the paper's code
        does, since the damaged state's memory belongs to another network.
      provenance: where `original` and the damage came from, as JSON (e.g. the source file,
        how its CA state was made, the damage condition); part of `to_config`.
      cache_size: regrown grids kept across generations by genome (least recently used
        dropped first): the GA's elites are not regrown again. Growth is deterministic and
        each individual's alone or in a batch, so the cache changes no result.
    """

    nca: NCAConfig
    original: np.ndarray
    damaged: CAState
    provenance: dict = field(default_factory=dict, compare=False)
    cache_size: int = 5_000
    _cache: LRUCache = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_cache", LRUCache(self.cache_size))

    def to_config(self) -> dict:
        """The task as JSON (a run folder's config.json "task" entry): the NCA, the
        provenance, the original grid and the damaged state."""
        return {"task": "regrowth", "nca": self.nca.to_dict(), **self.provenance,
                "original": np.asarray(self.original).tolist(),
                "damaged_state": self.damaged.state[0].tolist(),
                "damaged_alpha": self.damaged.alpha[0].tolist()}

    @classmethod
    def from_config(cls, config: dict) -> RegrowthTask:
        """The task `to_config` described (its other entries are the provenance).

        Raises:
          ValueError: `config` is not a regrowth task's, or its grids do not fit its NCA.
          KeyError: an entry is missing.
        """
        if config.get("task") != "regrowth":
            raise ValueError(f"not a regrowth task: {config.get('task')!r}")
        nca = NCAConfig.from_dict(config["nca"])
        original = np.asarray(config["original"], dtype=np.int8)
        state = torch.tensor(config["damaged_state"], dtype=torch.int64)[None]
        alpha = torch.tensor(config["damaged_alpha"], dtype=torch.float32)[None]
        for name, grid in (("original", original), ("damaged_state", state[0]),
                           ("damaged_alpha", alpha[0])):
            if tuple(grid.shape) != nca.grid_shape:
                raise ValueError(f"{name} has shape {tuple(grid.shape)}, the NCA's grid is "
                                 f"{nca.grid_shape}")
        stored = ("task", "nca", "original", "damaged_state", "damaged_alpha")
        return cls(nca=nca, original=original,
                   damaged=CAState(state, alpha, _fresh_memory(nca, 1)),
                   provenance={k: v for k, v in config.items() if k not in stored})

    def start(self, population: int) -> CAState:
        """The damaged state repeated for `population` individuals."""
        repeat = (population,) + (1,) * self.nca.dim
        return CAState(self.damaged.state.repeat(repeat), self.damaged.alpha.repeat(repeat),
                       _fresh_memory(self.nca, population))

    def regrow(self, genomes: np.ndarray) -> Growth:
        """Regrowth of every genome ``(P, G)`` (or one ``(G,)``) from the damaged state."""
        genomes = np.asarray(genomes).reshape(-1, self.nca.genome_size)
        return grow(self.nca, genomes, start=self.start(len(genomes)))

    def evaluate(self, genomes: np.ndarray, backend: Backend) -> PopulationEvaluation:
        """Fitness = `similarity` to the original (no physics; `backend` is not needed)."""
        genomes = np.asarray(genomes, dtype=np.float32)
        keys = [genome.tobytes() for genome in genomes]
        known = {key: self._cache.get(key) for key in keys if key in self._cache}
        first: dict[bytes, int] = {}  # each genome not seen before, regrown once
        for i, key in enumerate(keys):
            if key not in known:
                first.setdefault(key, i)
        if first:
            for key, grid in zip(first, self.regrow(genomes[list(first.values())]).grids):
                known[key] = grid
                self._cache.put(key, grid)
        grids = np.stack([known[key] for key in keys])
        score = similarity(grids, self.original)
        return PopulationEvaluation(
            fitness=score.astype(np.float64), grids=grids,
            details={"similarity": score, "robot_similarity": robot_similarity(grids, self.original),
                     "voxels": np.count_nonzero(grids.reshape(len(grids), -1), axis=1)},
            n_distinct=len({grid.tobytes() for grid in grids}),
        )
