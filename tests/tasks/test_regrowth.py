"""Regeneration: damage operators, identity regrowth, similarity, a tiny regrowth evolution."""

from pathlib import Path

import numpy as np
import pytest
import torch

from mjregen.grid import Robot
from mjregen.growth.nca import NCA, NCAConfig
from mjregen.growth.networks import CellNetwork, network_to_genome, random_genomes
from mjregen.search.backends import SerialBackend
from mjregen.search.ga import GAConfig, GeneticAlgorithm
from mjregen.tasks.regrowth import (
    RegrowthTask,
    cut_half_space,
    paper_cut,
    remove_chunk,
    robot_similarity,
    similarity,
    state_of_growth,
    state_of_robot,
    state_of_saved,
)

BLOCK = Robot(np.pad(np.arange(1, 5).repeat(7 * 7 * 7 // 4 + 1)[:343].reshape(7, 7, 7), 1))


def identity_genome(config: NCAConfig) -> np.ndarray:
    """A hand-set feed-forward NCA that keeps every cell's state: hidden unit j is a step
    "own state >= j"; output m is step(m) - step(m + 1), 1.5 for m = state and 0 otherwise."""
    network = CellNetwork(config)
    own = 3**config.dim // 2
    with torch.no_grad():
        for p in network.parameters():
            p.zero_()
        for j in range(5):
            network.linear1.weight[j, own] = 30.0  # input is state / 3: pre-activation 10·state
            network.linear1.bias[j] = -10.0 * (j - 0.5)
            network.linear2.weight[j, j] = 1.0
            network.linear3.weight[j, j] = 1.0
            if j < 4:
                network.linear3.weight[j, j + 1] = -1.0
        network.linear3.bias[4] = np.tanh(1.0)  # step(5) is always "below": -tanh(1)
        network.linear3.bias[5] = 5.0  # alpha stays high
    return network_to_genome(network)


def test_paper_cut_removes_the_left_side_of_state_alpha_and_memory():
    config = NCAConfig(dim=3, kind="lstm")
    state = state_of_robot(BLOCK, config)
    cut = paper_cut(state)
    assert not cut.state[0, :4].any() and not cut.alpha[0, :4].any()
    assert torch.equal(cut.state[0, 4:], state.state[0, 4:])
    h, c = cut.memory
    assert not h[0, :3].any() and not c[0, :3].any()  # memory x 0..2 = grid x 1..3
    assert torch.all(h[0, 3:] == 1)
    assert Robot(cut.state[0].numpy()).n_voxels == 343 - 3 * 49
    side = cut_half_space(state, "z >= 7")
    assert Robot(side.state[0].numpy()).n_voxels == 343 - 49


def test_remove_chunk_removes_a_connected_piece_of_the_asked_size():
    config = NCAConfig(dim=3)
    state = state_of_robot(BLOCK, config)
    damaged = remove_chunk(state, size=20, seed=3)
    removed = (state.state[0] != 0) & (damaged.state[0] == 0)
    assert int(removed.sum()) == 20
    cells = [tuple(c) for c in np.argwhere(removed.numpy())]
    reached, frontier = {cells[0]}, [cells[0]]
    while frontier:  # face-connected
        cell = frontier.pop()
        for other in cells:
            if other not in reached and sum(abs(a - b) for a, b in zip(cell, other)) == 1:
                reached.add(other)
                frontier.append(other)
    assert len(reached) == 20
    assert torch.equal(remove_chunk(state, size=20, seed=3).state, damaged.state)  # seeded


def test_similarity_measures():
    original = BLOCK.grid
    cut = BLOCK.remove_half_space("x < 4").grid
    assert similarity(np.stack([original, cut]), original).tolist() == [729, 729 - 147]
    assert robot_similarity(np.stack([original, cut]), original).tolist() == [1.0, 196 / 343]
    assert robot_similarity(np.zeros((1, 9, 9, 9), np.int8), np.zeros((9, 9, 9), np.int8)).tolist() == [0.0]


@pytest.mark.parametrize("dim", [2, 3])
def test_identity_regrowth_restores_nothing(dim):
    config = NCAConfig(dim=dim)
    original = NCA(config, random_genomes(config, 1, seed=6, std=0.5)[0]).grow()
    damaged = paper_cut(state_of_growth(original))
    task = RegrowthTask(nca=config, original=original.grids[0], damaged=damaged)
    regrown = task.regrow(identity_genome(config)).grids[0]
    damaged_grid = damaged.state[0].numpy()
    assert np.array_equal(regrown, Robot(damaged_grid).cleaned().grid)
    result = task.evaluate(identity_genome(config)[None], SerialBackend())
    assert result.fitness[0] == similarity(regrown[None], original.grids[0])[0]
    assert result.fitness[0] < config.grid_size**dim  # the cut took something away


def test_state_of_growth_is_the_cleaned_final_state():
    config = NCAConfig(dim=3, kind="lstm")
    growth = NCA.random(config, seed=2).grow()
    state = state_of_growth(growth)
    assert np.array_equal(state.state[0].numpy(), growth.grids[0])
    assert torch.all(state.alpha[0][state.state[0] == 0][growth.states[0, -1][growth.grids[0] == 0] != 0] == 0)


def test_a_tiny_2d_regrowth_evolution_improves_similarity():
    config = NCAConfig(dim=2, kind="ff")
    original = Robot.from_body([[1, 3, 3, 0, 0], [2, 4, 3, 0, 0], [1, 4, 4, 2, 0], [2, 3, 3, 0, 0], [1, 1, 4, 4, 0]])
    task = RegrowthTask(nca=config, original=original.grid, damaged=paper_cut(state_of_robot(original, config)))
    ga = GeneticAlgorithm(GAConfig(population=40, generations=15, truncation=8, elites=4, sigma=0.1),
                          task.nca.genome_size, seed=0)
    best = []
    for _ in range(15):
        population = ga.ask()
        fitness = task.evaluate(population, SerialBackend()).fitness
        best.append(fitness.max())
        ga.tell(fitness)
    assert best[-1] > best[0]
    assert all(b >= a for a, b in zip(best, best[1:]))


def test_shipped_tripod_regrowth_nca_regrows_the_tripod_exactly():
    from mjregen.experiments.regrowth import replay_regrowth
    from mjregen.growth.checkpoint import load_nca

    nca, metadata = load_nca("assets/regen/tripod_ff.npz")
    tripod = Robot.load("assets/robots/paper/tripod.npy")
    task = RegrowthTask(nca=nca.config, original=tripod.grid, damaged=paper_cut(state_of_robot(tripod, nca.config)))
    regrown = task.regrow(nca.genome).grids[0]
    assert np.array_equal(regrown, tripod.grid) and metadata["similarity"] == 729
    robots = replay_regrowth("assets/regen/tripod_ff.npz").robots  # as the file records it
    assert np.array_equal(robots["regrown"].grid, tripod.grid)
    cut = tripod.grid.copy()
    cut[:4] = 0  # the paper's cut: grid x-indices 0-3
    assert np.array_equal(robots["damaged"].grid, Robot(cut).cleaned().grid)
    assert robots["damaged"].n_voxels < tripod.n_voxels


@pytest.mark.parametrize("name", ["walker_1", "walker_3"])
def test_shipped_walker_regrowth_ncas_regrow_what_walkers_json_records(name):
    """The regrowth experiment of docs/results.md, replayed from assets: the walker's grown
    CA state as grown (alphas and all), the paper's cut, the shipped regrowth NCA of each
    network; the regrown cells match walkers.json's record and the NCA's own."""
    import json

    from mjregen.growth.checkpoint import load_nca
    from mjregen.tasks.regrowth import similarity, state_of_growth

    record = next(w for w in json.loads(Path("assets/robots/walkers/walkers.json").read_text())["walkers"]
                  if w["name"] == name)
    walker, _ = load_nca(f"assets/robots/walkers/{name}.npz")
    growth = walker.grow()
    damaged = paper_cut(state_of_growth(growth))
    assert set(record["regrowth"]) == {"ff", "lstm"}
    for net, expected in record["regrowth"].items():
        regrowth, metadata = load_nca(f"assets/regen/{name}_{net}.npz")
        assert metadata["robot"] == name and metadata["start"] == "grown"
        task = RegrowthTask(nca=regrowth.config, original=growth.grids[0], damaged=damaged)
        regrown = task.regrow(regrowth.genome).grids
        cells = int(similarity(regrown, growth.grids[0])[0])
        assert cells == expected["similarity"]["regrown"] == metadata["similarity"], net
        assert regrown[0].any()


def test_genomes_seen_before_are_not_regrown_and_score_the_same(monkeypatch):
    """The GA's elites come back every generation: their grids come from the task's cache,
    with the same fitness a fresh task gives them."""
    config = NCAConfig(dim=2, kind="ff")
    walker = Robot.load("assets/robots/bimorph_walker_2d.npy")
    damaged = paper_cut(state_of_robot(walker, config))
    first, second = random_genomes(config, 6, seed=1), random_genomes(config, 6, seed=2)
    task = RegrowthTask(nca=config, original=walker.grid, damaged=damaged)
    regrown = []
    original_regrow = RegrowthTask.regrow

    def counting(self, genomes):
        regrown.append(len(genomes))
        return original_regrow(self, genomes)

    monkeypatch.setattr(RegrowthTask, "regrow", counting)
    task.evaluate(first, SerialBackend())
    mixed = np.concatenate([first[:3], second[:3], second[:1]])
    cached = task.evaluate(mixed, SerialBackend())
    monkeypatch.undo()
    assert regrown == [6, 3]  # the three new genomes, the repeated one once
    fresh = RegrowthTask(nca=config, original=walker.grid, damaged=damaged).evaluate(mixed, None)
    assert np.array_equal(cached.fitness, fresh.fitness)
    assert np.array_equal(cached.grids, fresh.grids)


def test_the_grown_state_keeps_the_alpha_of_empty_cells_that_are_alive():
    """The paper regrows from the CA state as grown: an empty cell that is alive keeps its
    alpha, and it takes part in the regrowth (a neighbour of alpha > 0.1 lives)."""
    config = NCAConfig(dim=3, kind="ff")
    for seed in range(20):
        growth = NCA.random(config, seed=seed).grow()
        alive_empty = (growth.grids[0] == 0) & (growth.final.alpha[0].numpy() > 0.1)
        if alive_empty.any():
            break
    else:
        pytest.fail("no random NCA grew an empty cell that is alive")
    state = state_of_growth(growth)
    assert np.array_equal(state.alpha[0].numpy(), growth.final.alpha[0].numpy())
    assert np.array_equal(state.state[0].numpy(), growth.grids[0])


def test_the_paper_biped_regrows_from_the_state_its_code_saved():
    from mjregen.experiments.regrowth import regrowth_source

    source = regrowth_source(paper="biped")
    saved = np.load("assets/robots/paper/biped_ca_state.npy")
    alpha = source.state.alpha[0].numpy()
    assert source.start == "saved" and np.allclose(alpha, saved[1], atol=1e-7)
    voxels = source.robot.grid != 0
    assert np.count_nonzero(alpha[voxels] <= 0.1) == 151 and np.count_nonzero(alpha[~voxels] > 0) == 1
    assert regrowth_source(paper="tripod").start == "alpha 1"


def test_a_saved_state_of_the_wrong_kind_is_refused():
    config = NCAConfig(dim=3, kind="ff")
    good = np.load("assets/robots/paper/biped_ca_state.npy")
    with pytest.raises(ValueError, match="shape"):
        state_of_saved(good[:, :7], config)
    bad = good.copy()
    bad[0, 4, 4, 4] = 7
    with pytest.raises(ValueError, match="material codes"):
        state_of_saved(bad, config)
    bad = good.copy()
    bad[1, 4, 4, 4] = np.nan
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        state_of_saved(bad, config)
