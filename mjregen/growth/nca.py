"""Neural cellular automata that grow robot grids, as in the paper's code, batched in torch.

Every interior cell of the grid carries a material code (`state`) and a maturity (`alpha`);
LSTM networks also give each cell a memory ``(h, c)``. One growth step, for every cell at
once (synchronous), with the same network everywhere:

* input: the cell's Moore neighbourhood including itself, all states then all alphas,
  flattened in the paper's (z, y, x) order (x fastest), divided by 3;
* a cell is alive iff the largest alpha in its neighbourhood exceeds 0.1 (previous step);
  then state = argmax of the network's 5 state outputs and alpha = sigmoid(6th output),
  LSTM memory = the LSTM's new ``(h, c)``; otherwise state, alpha and memory become 0;
* the one-cell border stays empty.

Growth starts from the centre cell (state soft, alpha 1; memory ones everywhere) and runs
10 steps. The whole population grows in one batched computation: each individual's weights
are a slice of a ``(P, G)`` genome tensor and every layer is one batched matmul.

Genomes are float32 vectors in the order of ``torch.nn.utils.parameters_to_vector`` of
`CellNetwork` (the paper's ``MorphNet`` layout), so genome <-> network is exact.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import torch

from mjregen.errors import InvalidGenomeError
from mjregen.grid import N_MATERIALS, Material, Robot, clean_grids
from mjregen.growth.config import NCAConfig
from mjregen.growth.networks import (
    CellNetwork,
    PopulationNetworks,
    check_genomes,
    genome_to_network,
    random_genomes,
)


@dataclass
class CAState:
    """The full CA state of a population.

    Attributes:
      state: int64 ``(P, *grid)`` material codes.
      alpha: float32 ``(P, *grid)`` maturities.
      memory: LSTM ``(h, c)``, each float32 ``(P, *interior, hidden)`` with
        ``interior = grid - 2`` per axis (the border has no cell); None for feed-forward.
    """

    state: torch.Tensor
    alpha: torch.Tensor
    memory: tuple[torch.Tensor, torch.Tensor] | None

    @classmethod
    def seed(cls, config: NCAConfig, population: int) -> CAState:
        """The paper's start: centre cell soft with alpha 1, memory ones everywhere."""
        state = torch.zeros((population, *config.grid_shape), dtype=torch.int64)
        alpha = torch.zeros((population, *config.grid_shape), dtype=torch.float32)
        centre = (slice(None),) + (config.grid_size // 2,) * config.dim
        state[centre] = int(Material.SOFT)
        alpha[centre] = 1.0
        memory = None
        if config.kind == "lstm":
            shape = (population,) + (config.grid_size - 2,) * config.dim + (config.hidden,)
            memory = (torch.ones(shape), torch.ones(shape))
        return cls(state, alpha, memory)


@dataclass
class Growth:
    """What a population's growth produced.

    Attributes:
      states: int8 ``(P, steps + 1, *grid)``, the grid before growth and after every step
        (not cleaned).
      alphas: float32 ``(P, steps + 1, *grid)``, the matching maturities.
      final: the full CA state after the last step (for regeneration).
      grids: int8 ``(P, *grid)``, the final grids after the paper's cleaning.
    """

    states: np.ndarray
    alphas: np.ndarray
    final: CAState
    grids: np.ndarray

    def robot(self, index: int = 0) -> Robot:
        """The cleaned robot grown by individual `index`."""
        return Robot(self.grids[index])


def neighbourhoods(values: torch.Tensor, dim: int) -> torch.Tensor:
    """Moore neighbourhoods (self included) of every interior cell.

    Args:
      values: ``(P, *grid)``.
    Returns:
      ``(P, N, 3**dim)`` with N interior cells in C order of ``[x, (y,) z]`` and each
      neighbourhood flattened in the paper's (z, y, x) order, x fastest.
    """
    windows = values
    for axis in range(1, dim + 1):
        windows = windows.unfold(axis, 3, 1)
    # windows: (P, *interior, offset_x, (offset_y,) offset_z) -> offsets reversed to z, y, x
    order = (0, *range(1, dim + 1), *reversed(range(dim + 1, 2 * dim + 1)))
    windows = windows.permute(order)
    return windows.reshape(values.shape[0], -1, 3**dim)


def growth_step(config: NCAConfig, networks: PopulationNetworks, ca: CAState) -> CAState:
    """One synchronous update of every interior cell (see the module docstring)."""
    population = ca.state.shape[0]
    state_nb = neighbourhoods(ca.state.to(torch.float32), config.dim)
    alpha_nb = neighbourhoods(ca.alpha, config.dim)
    inputs = torch.cat([state_nb, alpha_nb], dim=-1) / config.input_scale
    memory = None
    if ca.memory is not None:
        memory = tuple(m.reshape(population, -1, config.hidden) for m in ca.memory)
    outputs, new_memory = networks(inputs, memory)
    alive = alpha_nb.amax(dim=-1) > config.alive_threshold  # (P, N)

    interior_shape = (population,) + (config.grid_size - 2,) * config.dim
    interior = (slice(None),) + (slice(1, -1),) * config.dim
    state = torch.zeros_like(ca.state)
    alpha = torch.zeros_like(ca.alpha)
    state[interior] = torch.where(alive, outputs[..., :N_MATERIALS].argmax(dim=-1), 0).reshape(interior_shape)
    alpha[interior] = torch.where(alive, torch.sigmoid(outputs[..., N_MATERIALS]), 0.0).reshape(interior_shape)
    next_memory = None
    if new_memory is not None:
        keep = alive.unsqueeze(-1)
        next_memory = tuple(
            torch.where(keep, m, 0.0).reshape(*interior_shape, config.hidden) for m in new_memory
        )
    return CAState(state, alpha, next_memory)


CHUNK = 16  # individuals grown together: small enough for the caches, big enough to batch


def _batches(population: int, threads: int) -> list[slice]:
    """Consecutive batches of at most `CHUNK` individuals, about equal in size and as many
    as the next multiple of `threads` (or one fewer), so that the threads finish together."""
    count = -(-population // CHUNK)
    count = -(-count // threads) * threads
    size = -(-population // count)
    return [slice(begin, begin + size) for begin in range(0, population, size)]


_THREAD_SETTING = threading.Lock()  # held while a growth reads and changes torch's threads


@contextmanager
def _one_thread_per_op() -> Iterator[None]:
    """torch's intra-op threads set to one while the block runs (threads started inside
    take that setting), then back to what they were."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


@torch.no_grad()
def _check_start(config: NCAConfig, start: CAState, population: int) -> None:
    """ValueError unless `start` holds `population` states on the NCA's grid, with LSTM
    memory exactly when the NCA is an LSTM."""
    if tuple(start.state.shape) != (population, *config.grid_shape):
        raise ValueError(
            f"start state shape {tuple(start.state.shape)} does not match {population} "
            f"individuals on a {config.grid_shape} grid"
        )
    if (start.memory is None) != (config.kind == "ff"):
        raise ValueError("start state needs LSTM memory exactly when the NCA is an LSTM")


@torch.no_grad()
def _grow_batch(config: NCAConfig, genomes: np.ndarray, start: CAState, n_steps: int,
                part: slice) -> tuple[torch.Tensor, torch.Tensor, CAState]:
    """(states, alphas) of every step and the final state of the individuals `part`."""
    networks = PopulationNetworks(config, genomes[part])
    ca = CAState(
        start.state[part],
        start.alpha[part],
        None if start.memory is None else (start.memory[0][part], start.memory[1][part]),
    )
    history = [ca]
    for _ in range(n_steps):
        ca = growth_step(config, networks, ca)
        history.append(ca)
    return (torch.stack([h.state for h in history], dim=1),
            torch.stack([h.alpha for h in history], dim=1), ca)


def _in_batches(grow_batch, population: int) -> list:
    """`grow_batch(part)` of each batch (`_batches`) of the `population` individuals, side
    by side on up to ``torch.get_num_threads()`` threads, each running its operations on one
    thread; the results in batch order."""
    with _THREAD_SETTING:  # growths in other threads wait: torch's setting is global
        threads = min(torch.get_num_threads(), population)
        parts = _batches(population, threads)
        with _one_thread_per_op():
            if threads <= 1:
                return [grow_batch(part) for part in parts]
            pool = ThreadPoolExecutor(threads)
            try:
                return list(pool.map(grow_batch, parts))
            finally:  # an interrupt drops the batches not started
                pool.shutdown(wait=True, cancel_futures=True)


def grow(
    config: NCAConfig,
    genomes: np.ndarray,
    *,
    start: CAState | None = None,
    steps: int | None = None,
) -> Growth:
    """Grow a population: every genome's NCA runs `steps` steps from `start`.

    Individuals are independent and every one gets bit-identical results whether it grows
    alone or in a population; they are processed in batches of at most `CHUNK` (cache
    blocking), the batches side by side on up to ``torch.get_num_threads()`` threads, each
    running its operations on one thread. (torch's own intra-op threads meet after every
    one of the growth's many short operations, so beside other busy processes a thread that
    loses its core stalls its partners: tens of times the time, `benchmarks/growth.py
    --load`.)

    Args:
      config: the NCA configuration.
      genomes: float32 ``(G,)`` for one individual or ``(P, G)`` for a population.
      start: the initial CA state (P individuals); default the paper's centre seed. A
        damaged state here makes this regrowth.
      steps: growth steps; default ``config.steps``.
    Returns:
      A `Growth` with P individuals; its `grids` are cleaned as in the paper.
    """
    genomes = check_genomes(config, genomes).reshape(-1, config.genome_size)
    population = len(genomes)
    if population == 0:
        raise InvalidGenomeError("no genomes to grow: the population is empty")
    start = CAState.seed(config, population) if start is None else start
    _check_start(config, start, population)
    n_steps = config.steps if steps is None else steps

    batch = functools.partial(_grow_batch, config, genomes, start, n_steps)
    states, alphas, finals = zip(*_in_batches(batch, population))
    final = CAState(
        torch.cat([f.state for f in finals]),
        torch.cat([f.alpha for f in finals]),
        None if finals[0].memory is None else tuple(torch.cat([f.memory[i] for f in finals]) for i in (0, 1)),
    )
    all_states = torch.cat(states).numpy().astype(np.int8)
    return Growth(
        states=all_states,
        alphas=torch.cat(alphas).numpy(),
        final=final,
        grids=clean_grids(all_states[:, -1], config.dim),
    )


@dataclass(frozen=True)
class NCA:
    """One NCA: its configuration and its genome (float32 ``(G,)``)."""

    config: NCAConfig
    genome: np.ndarray

    def __post_init__(self) -> None:
        genome = check_genomes(self.config, self.genome)
        if genome.ndim != 1:
            raise InvalidGenomeError(f"an NCA has one genome of shape ({self.config.genome_size},)")
        genome = genome.copy()
        genome.flags.writeable = False
        object.__setattr__(self, "genome", genome)

    @classmethod
    def random(cls, config: NCAConfig, *, seed: int | np.random.Generator) -> NCA:
        """An NCA with the paper's initial genes N(0, 0.1²)."""
        return cls(config, random_genomes(config, 1, seed=seed)[0])

    def grow(self, *, start: CAState | None = None, steps: int | None = None) -> Growth:
        """Grow this NCA's robot (a population of one)."""
        return grow(self.config, self.genome, start=start, steps=steps)

    def network(self) -> CellNetwork:
        """The cell network as a torch module holding exactly this genome."""
        return genome_to_network(self.config, self.genome)
