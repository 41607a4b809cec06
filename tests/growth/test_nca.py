"""Neural CA growth: the paper's rule on hand-set networks, batching, genomes, checkpoints."""

import itertools
import math

import numpy as np
import pytest
import torch

from mjregen.errors import CheckpointError, InvalidGenomeError
from mjregen.grid import Material, clean_grids
from mjregen.growth.checkpoint import load_nca, save_nca
from mjregen.growth.nca import CHUNK, NCA, CAState, NCAConfig, grow
from mjregen.growth.networks import (
    CellNetwork,
    PopulationNetworks,
    network_to_genome,
    random_genomes,
)

SOFT, HARD = int(Material.SOFT), int(Material.HARD)


def hand_set(config: NCAConfig, **params: dict) -> np.ndarray:
    """Genome of a network whose parameters are all zero except the given entries.

    `params` maps a parameter name (dots as double underscores) to {index: value}."""
    network = CellNetwork(config)
    with torch.no_grad():
        for p in network.parameters():
            p.zero_()
        named = dict(network.named_parameters())
        for name, entries in params.items():
            for index, value in entries.items():
                named[name.replace("__", ".")][index] = value
    return network_to_genome(network)


def chebyshev_from_centre(config: NCAConfig) -> np.ndarray:
    """Chebyshev distance of every grid cell from the centre cell."""
    coords = np.indices(config.grid_shape) - config.grid_size // 2
    return np.abs(coords).max(axis=0)


def interior(config: NCAConfig) -> np.ndarray:
    mask = np.zeros(config.grid_shape, dtype=bool)
    mask[(slice(1, -1),) * config.dim] = True
    return mask


# --- sizes and genomes -------------------------------------------------------------------


@pytest.mark.parametrize(
    "dim, kind, size", [(3, "ff", 8070), (3, "lstm", 27238), (2, "ff", 5766), (2, "lstm", 26086)]
)
def test_parameter_counts_match_the_papers_networks(dim, kind, size):
    config = NCAConfig(dim=dim, kind=kind)
    assert config.genome_size == size
    assert sum(p.numel() for p in CellNetwork(config).parameters()) == size


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("kind", ["ff", "lstm"])
def test_the_configs_genome_layout_is_the_networks(dim, kind):
    config = NCAConfig(dim=dim, kind=kind, hidden=7, lstm_input=5)
    network = CellNetwork(config)
    assert config.parameter_layout == tuple((name, tuple(p.shape))
                                            for name, p in network.named_parameters())


def test_genome_network_round_trip_is_exact():
    for kind in ("ff", "lstm"):
        nca = NCA.random(NCAConfig(kind=kind), seed=5)
        genome = network_to_genome(nca.network())
        assert genome.dtype == np.float32
        assert np.array_equal(genome, nca.genome)


def test_genome_order_is_the_papers_parameter_order():
    names = [name for name, _ in CellNetwork(NCAConfig(kind="lstm")).named_parameters()]
    assert names == [
        "linear1.weight", "linear1.bias",
        "lstm.weight_ih_l0", "lstm.weight_hh_l0", "lstm.bias_ih_l0", "lstm.bias_hh_l0",
        "linear2.weight", "linear2.bias",
    ]


@pytest.mark.parametrize("kind", ["ff", "lstm"])
def test_batched_networks_compute_what_the_torch_modules_compute(kind):
    config = NCAConfig(kind=kind)
    genomes = random_genomes(config, 3, seed=1, std=0.5)
    rng = np.random.default_rng(2)
    x = torch.tensor(rng.normal(size=(3, 50, config.n_inputs)), dtype=torch.float32)
    memory = None
    if kind == "lstm":
        memory = tuple(torch.tensor(rng.normal(size=(3, 50, 64)), dtype=torch.float32) for _ in range(2))
    out, new_memory = PopulationNetworks(config, genomes)(x, memory)
    for i in range(3):
        module = NCA(config, genomes[i]).network()
        with torch.no_grad():
            expected, expected_memory = module(x[i], None if memory is None else (memory[0][i], memory[1][i]))
        torch.testing.assert_close(out[i], expected, rtol=1e-5, atol=1e-5)
        if kind == "lstm":
            torch.testing.assert_close(new_memory[0][i], expected_memory[0], rtol=1e-5, atol=1e-5)
            torch.testing.assert_close(new_memory[1][i], expected_memory[1], rtol=1e-5, atol=1e-5)


# --- the growth rule on hand-set networks -------------------------------------------------


def test_constant_network_fills_a_growing_box():
    # All weights zero; output biases say "hard" with alpha sigmoid(5): after step k every
    # interior cell within distance k of the centre is hard, the rest stays empty.
    config = NCAConfig(dim=3)
    genome = hand_set(config, linear3__bias={HARD: 1.0, 5: 5.0})
    growth = NCA(config, genome).grow()
    distance = chebyshev_from_centre(config)
    assert np.array_equal(growth.states[0, 0], np.where(distance == 0, SOFT, 0))
    for step in (1, 2, 3, 10):
        expected = np.where((distance <= step) & interior(config), HARD, 0)
        assert np.array_equal(growth.states[0, step], expected), step
        alpha = growth.alphas[0, step]
        assert np.allclose(alpha[expected > 0], 1 / (1 + math.exp(-5)))
        assert np.all(alpha[expected == 0] == 0)
    assert growth.robot().n_voxels == 343


def test_alive_rule_kills_cells_whose_neighbourhood_is_immature():
    # Alpha output sigmoid(-10) < 0.1: step 1 fills the seed's neighbourhood (the seed's
    # alpha is 1), step 2 finds no mature cell anywhere and everything dies.
    config = NCAConfig(dim=3)
    growth = NCA(config, hand_set(config, linear3__bias={HARD: 1.0, 5: -10.0})).grow()
    assert np.count_nonzero(growth.states[0, 1]) == 27
    assert not growth.states[0, 2:].any() and not growth.alphas[0, 2:].any()
    assert growth.robot().is_empty


@pytest.mark.parametrize("dim", [2, 3])
def test_filled_cells_turn_hard_and_empty_cells_soft(dim):
    # Hidden unit 0 = tanh(tanh(own state)); hard score 10·that, soft score 0.5: a cell that
    # was filled becomes hard, an empty living cell soft. After step k: distance < k hard,
    # distance k soft.
    config = NCAConfig(dim=dim)
    own_state = (3**dim) // 2  # the centre of the neighbourhood
    genome = hand_set(
        config,
        linear1__weight={(0, own_state): 3.0},  # inputs are divided by 3
        linear2__weight={(0, 0): 1.0},
        linear3__weight={(HARD, 0): 10.0},
        linear3__bias={0: -5.0, SOFT: 0.5, 3: -5.0, 4: -5.0, 5: 5.0},
    )
    growth = NCA(config, genome).grow(steps=3)
    distance = chebyshev_from_centre(config)
    for step in (1, 2, 3):
        expected = np.where(distance < step, HARD, np.where(distance == step, SOFT, 0))
        expected = np.where(interior(config), expected, 0)
        assert np.array_equal(growth.states[0, step], expected), step


@pytest.mark.parametrize(
    "dim, offset, input_index",
    [
        # the paper flattens the neighbourhood in (z, y, x) order, x fastest
        (3, (0, 0, 1), 2 * 9 + 1 * 3 + 1),  # the cell above (+z)
        (3, (1, 0, 0), 1 * 9 + 1 * 3 + 2),  # +x
        (3, (0, -1, 0), 1 * 9 + 0 * 3 + 1),  # -y
        (2, (0, 1), 2 * 3 + 1),  # +z in [x, z]
        (2, (-1, 0), 1 * 3 + 0),  # -x
    ],
)
def test_neighbourhood_input_order_is_the_papers(dim, offset, input_index):
    # The network answers "hard" iff the neighbour at input `input_index` is filled. From the
    # seed, exactly the cell that sees the seed at `offset` turns hard after one step.
    config = NCAConfig(dim=dim)
    genome = hand_set(
        config,
        linear1__weight={(0, input_index): 3.0},
        linear2__weight={(0, 0): 1.0},
        linear3__weight={(HARD, 0): 10.0},
        linear3__bias={SOFT: 0.5, 5: 5.0},
    )
    state = NCA(config, genome).grow(steps=1).states[0, 1]
    centre = np.array([config.grid_size // 2] * dim)
    hard = [tuple(i) for i in np.argwhere(state == HARD)]
    assert hard == [tuple(centre - np.array(offset))]
    assert np.count_nonzero(state) == 3**dim


def test_lstm_memory_starts_at_ones_and_is_zeroed_for_dead_cells():
    # Zero weights; gate biases make input/forget/output gates 1 and the cell input
    # tanh(0.5): a living cell's c grows by tanh(0.5) per step, h = tanh(c). Cells that
    # were dead restart from c = 0.
    config = NCAConfig(dim=3, kind="lstm")
    bias = {i: 20.0 for i in range(0, 128)}  # input and forget gates
    bias.update({i: 0.5 for i in range(128, 192)})  # cell input
    bias.update({i: 20.0 for i in range(192, 256)})  # output gate
    genome = hand_set(config, lstm__bias_ih_l0=bias, linear2__bias={SOFT: 1.0, 5: 5.0})
    g = math.tanh(0.5)
    growth = NCA(config, genome).grow(steps=1)
    h, c = (m[0].numpy() for m in growth.final.memory)
    distance = chebyshev_from_centre(config)[1:-1, 1:-1, 1:-1]  # memory covers the interior
    assert np.allclose(c[distance <= 1], 1 + g) and np.all(c[distance > 1] == 0)
    assert np.allclose(h[distance <= 1], math.tanh(1 + g)) and np.all(h[distance > 1] == 0)
    c2 = NCA(config, genome).grow(steps=2).final.memory[1][0].numpy()
    assert np.allclose(c2[distance <= 1], 1 + 2 * g)
    assert np.allclose(c2[distance == 2], g)  # was dead (zeroed) after step 1
    assert np.all(c2[distance == 3] == 0)


# --- batching, determinism, history ------------------------------------------------------


@pytest.mark.parametrize("dim, kind", list(itertools.product((2, 3), ("ff", "lstm"))))
def test_batched_growth_equals_one_at_a_time_exactly(dim, kind):
    config = NCAConfig(dim=dim, kind=kind)
    genomes = random_genomes(config, CHUNK + 9, seed=11, std=0.3)
    batch = grow(config, genomes)
    for i in range(len(genomes)):
        alone = grow(config, genomes[i])
        assert np.array_equal(alone.states[0], batch.states[i])
        assert np.array_equal(alone.alphas[0], batch.alphas[i])
        assert np.array_equal(alone.grids[0], batch.grids[i])
        if kind == "lstm":
            for a, b in zip(alone.final.memory, batch.final.memory):
                assert torch.equal(a[0], b[i])
    # the population is not trivial: robots differ
    assert len({g.tobytes() for g in batch.grids}) > len(genomes) // 2


def test_same_seed_same_robot():
    config = NCAConfig(dim=3, kind="ff")
    a, b = NCA.random(config, seed=42), NCA.random(config, seed=42)
    assert np.array_equal(a.genome, b.genome)
    assert a.grow().robot() == b.grow().robot()
    assert not np.array_equal(a.genome, NCA.random(config, seed=43).genome)
    genomes = random_genomes(config, 200, seed=0)
    assert abs(genomes.std() - 0.1) < 0.001 and abs(genomes.mean()) < 0.001


def test_growth_history_and_cleaning():
    config = NCAConfig(dim=3, kind="lstm")
    growth = grow(config, random_genomes(config, 4, seed=3, std=0.3))
    assert growth.states.shape == (4, 11, 9, 9, 9) and growth.states.dtype == np.int8
    assert growth.alphas.shape == (4, 11, 9, 9, 9)
    assert np.count_nonzero(growth.states[:, 0]) == 4 and np.all(growth.states[:, 0, 4, 4, 4] == SOFT)
    assert not growth.states[:, :, ~interior(config)].any()  # the border never grows
    assert np.array_equal(growth.grids, clean_grids(growth.states[:, -1], 3))
    assert np.array_equal(growth.final.state.numpy(), growth.states[:, -1])


def test_growth_from_a_given_state_continues_it():
    config = NCAConfig(dim=2, kind="lstm")
    nca = NCA.random(config, seed=8)
    first = nca.grow(steps=4)
    rest = nca.grow(start=first.final, steps=6)
    full = nca.grow(steps=10)
    assert np.array_equal(rest.states[0], full.states[0, 4:])
    damaged = CAState(first.final.state.clone(), first.final.alpha.clone(), first.final.memory)
    damaged.state[:, :3] = 0
    damaged.alpha[:, :3] = 0
    regrown = nca.grow(start=damaged, steps=1)
    assert not regrown.states[0, 0, :3].any()
    with pytest.raises(ValueError, match="start state shape"):
        grow(config, random_genomes(config, 2, seed=0), start=first.final)


# --- bad input ---------------------------------------------------------------------------


def test_bad_genomes():
    config = NCAConfig(dim=3)
    with pytest.raises(InvalidGenomeError, match="8070"):
        grow(config, np.zeros(100, dtype=np.float32))
    with pytest.raises(InvalidGenomeError, match="NaN"):
        grow(config, np.full(8070, np.nan))
    with pytest.raises(InvalidGenomeError, match="shape"):
        NCA(config, np.zeros((2, 8070)))


@pytest.mark.parametrize(
    "kwargs, message",
    [({"dim": 4}, "dim"), ({"kind": "gru"}, "kind"), ({"steps": 0}, "steps"), ({"grid_size": 8}, "odd")],
)
def test_bad_configs(kwargs, message):
    with pytest.raises(ValueError, match=message):
        NCAConfig(**kwargs)


# --- checkpoints -------------------------------------------------------------------------


def test_checkpoint_round_trip(tmp_path):
    nca = NCA.random(NCAConfig(dim=2, kind="lstm", steps=7), seed=4)
    path = save_nca(tmp_path / "nca.npz", nca, metadata={"fitness": 1.5, "seed": 4})
    loaded, metadata = load_nca(path)
    assert loaded.config == nca.config
    assert np.array_equal(loaded.genome, nca.genome)
    assert metadata == {"fitness": 1.5, "seed": 4}
    assert loaded.grow().robot() == nca.grow().robot()


def test_checkpoint_errors(tmp_path):
    nca = NCA.random(NCAConfig(dim=2), seed=0)
    path = save_nca(tmp_path / "nca.npz", nca)
    with pytest.raises(FileExistsError):
        save_nca(path, NCA.random(NCAConfig(dim=2), seed=1))
    assert np.array_equal(load_nca(path)[0].genome, nca.genome)  # untouched
    with pytest.raises(FileNotFoundError):
        load_nca(tmp_path / "missing.npz")
    with pytest.raises(CheckpointError, match=".npz"):
        save_nca(tmp_path / "nca.pt", nca)
    np.save(tmp_path / "robot.npy", np.zeros((7, 7)))
    with pytest.raises(CheckpointError, match=".npz"):
        load_nca(tmp_path / "robot.npy")
    disguised = tmp_path / "disguised.npz"
    disguised.write_bytes((tmp_path / "robot.npy").read_bytes())
    with pytest.raises(CheckpointError, match="single array"):
        load_nca(disguised)
    corrupt = tmp_path / "corrupt.npz"
    corrupt.write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(CheckpointError, match="not a readable"):
        load_nca(corrupt)
    other = tmp_path / "other.npz"
    np.savez(other, weights=np.zeros(3))
    with pytest.raises(CheckpointError, match="missing"):
        load_nca(other)
    short = tmp_path / "short.npz"
    np.savez(short, format=np.array("mjregen-nca-1"), config=np.array('{"dim": 2}'),
             metadata=np.array("{}"), genome=np.zeros(10, dtype=np.float32))
    with pytest.raises(CheckpointError, match="genome shape"):
        load_nca(short)
    pickled = tmp_path / "pickled.npz"
    np.savez(pickled, format=np.array("mjregen-nca-1"), config=np.array([{"dim": 2}], dtype=object),
             metadata=np.array("{}"), genome=nca.genome)
    with pytest.raises(CheckpointError):
        load_nca(pickled)


@pytest.mark.parametrize("kind", ["ff", "lstm"])
def test_growth_on_several_threads_equals_one_thread_exactly_and_keeps_the_setting(kind):
    config = NCAConfig(dim=3, kind=kind)
    genomes = random_genomes(config, 3 * CHUNK + 5, seed=4)
    threads = torch.get_num_threads()
    try:
        torch.set_num_threads(1)
        serial = grow(config, genomes)
        torch.set_num_threads(3)
        threaded = grow(config, genomes)
        assert torch.get_num_threads() == 3
    finally:
        torch.set_num_threads(threads)
    assert np.array_equal(serial.states, threaded.states)
    assert np.array_equal(serial.alphas, threaded.alphas)
    assert np.array_equal(serial.grids, threaded.grids)
    if kind == "lstm":
        assert all(torch.equal(a, b) for a, b in zip(serial.final.memory, threaded.final.memory))


def test_growth_of_one_or_a_few_robots_runs_each_op_on_one_thread(monkeypatch):
    """torch's intra-op threads stall beside busy processes, so no growth uses them: one
    robot grows with torch set to one thread, a population smaller than a batch is split
    over the threads, and the setting is back afterwards."""
    from mjregen.growth import nca as nca_module

    seen = []
    step = nca_module.growth_step

    def recording_step(config, networks, ca):
        seen.append((torch.get_num_threads(), len(ca.state)))
        return step(config, networks, ca)

    pools = []

    class RecordingPool(nca_module.ThreadPoolExecutor):
        def __init__(self, workers: int) -> None:
            pools.append(workers)
            super().__init__(workers)

    monkeypatch.setattr(nca_module, "growth_step", recording_step)
    monkeypatch.setattr(nca_module, "ThreadPoolExecutor", RecordingPool)
    config = NCAConfig(dim=3, kind="ff")
    threads = torch.get_num_threads()
    try:
        torch.set_num_threads(2)
        grow(config, random_genomes(config, 1, seed=0))
        assert {setting for setting, _ in seen} == {1}
        assert torch.get_num_threads() == 2
        seen.clear()
        grow(config, random_genomes(config, 4, seed=0))
        assert {setting for setting, _ in seen} == {1}
        # two halves on a pool of two threads (which thread runs which is the pool's choice:
        # on a loaded machine one thread may finish its half before the other starts)
        assert pools == [2] and len(seen) == 2 * config.steps
        assert {size for _, size in seen} == {2}
    finally:
        torch.set_num_threads(threads)


def test_an_individual_grows_the_same_at_any_place_in_a_population():
    """The output layer's batched matmul rounded differently for every other individual
    (its output block not aligned in memory): with these genomes individual 5 of 9 grew
    another robot in the population than alone."""
    config = NCAConfig(dim=3, kind="lstm")
    genomes = random_genomes(config, 53, seed=4)[27:36]
    population = grow(config, genomes)
    for i, genome in enumerate(genomes):
        alone = grow(config, genome)
        assert np.array_equal(population.states[i], alone.states[0]), i
        assert np.array_equal(population.alphas[i], alone.alphas[0]), i


def test_an_empty_population_is_refused_by_name():
    config = NCAConfig(dim=3, kind="ff")
    with pytest.raises(InvalidGenomeError, match="population is empty"):
        grow(config, np.zeros((0, config.genome_size), dtype=np.float32))


@pytest.mark.parametrize("config, message", [
    ([3, "ff"], "a JSON object"), ("3d", "a JSON object"),
    ({"dim": 3.0, "kind": "ff"}, "dim must be 2 or 3"), ({"dim": True, "kind": "ff"}, "dim"),
    ({"dim": 3, "kind": "ff", "hidden": "64"}, "hidden must be a positive integer"),
    ({"dim": 3, "kind": "ff", "steps": True}, "steps must be a positive integer"),
    ({"dim": 3, "kind": "ff", "input_scale": "x"}, "input_scale must be a finite number"),
])
def test_a_checkpoint_whose_config_has_wrong_types_is_named(tmp_path, config, message):
    import json

    from mjregen.errors import CheckpointError
    from mjregen.growth.checkpoint import FORMAT

    path = tmp_path / "odd.npz"
    np.savez(path, format=np.array(FORMAT), config=np.array(json.dumps(config)),
             metadata=np.array("{}"), genome=np.zeros(10, dtype=np.float32))
    with pytest.raises(CheckpointError, match=f"odd.npz has an invalid NCA config: .*{message}"):
        load_nca(path)

