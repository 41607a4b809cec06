"""One NCA that grows and regrows: its damage and regrowth are the paper's regrowth with
the growing network itself, and its fitness adds the walk and the regrowth's similarity."""

import numpy as np
import pytest

from mjregen.growth.nca import NCAConfig, grow, random_genomes
from mjregen.physics import Physics
from mjregen.search.backends import SerialBackend
from mjregen.tasks.grow_regrow import GrowRegrowTask, own_similarity, regrow_after_cut
from mjregen.tasks.locomotion import LocomotionTask
from mjregen.tasks.regrowth import RegrowthTask, paper_cut, similarity, state_of_growth

FAST = Physics().replace(settle_time=0.01)


def test_feed_forward_regrowth_is_the_papers_regrowth_by_the_same_network():
    config = NCAConfig(dim=3, kind="ff")
    genomes = random_genomes(config, 4, seed=2)
    growth = grow(config, genomes)
    regrown = regrow_after_cut(config, genomes, growth)
    for i, genome in enumerate(genomes):
        paper = RegrowthTask(nca=config, original=growth.grids[i],
                             damaged=paper_cut(state_of_growth(growth, i)))
        assert np.array_equal(regrown[i], paper.regrow(genome).grids[0])
        assert own_similarity(regrown, growth.grids)[i] == similarity(regrown[i:i + 1],
                                                                      growth.grids[i])[0]


def test_an_lstm_regrows_with_its_own_memory():
    config = NCAConfig(dim=2, kind="lstm")
    genomes = random_genomes(config, 6, seed=3)
    growth = grow(config, genomes)
    regrown = regrow_after_cut(config, genomes, growth)
    fresh = [RegrowthTask(nca=config, original=growth.grids[i],
                          damaged=paper_cut(state_of_growth(growth, i))).regrow(g).grids[0]
             for i, g in enumerate(genomes)]
    # the same network continues (memory kept); the paper's second network starts afresh
    assert any(not np.array_equal(a, b) for a, b in zip(regrown, fresh))


def test_fitness_is_the_walk_minus_the_wrongly_regrown_cells():
    config = NCAConfig(dim=2, kind="ff")
    genomes = random_genomes(config, 5, seed=4)
    task = GrowRegrowTask(nca=config, physics=FAST, duration=0.02, cell_cost=0.25)
    result = task.evaluate(genomes, SerialBackend())
    walk = LocomotionTask(nca=config, physics=FAST, duration=0.02).evaluate(genomes,
                                                                            SerialBackend())
    growth = grow(config, genomes)
    score = own_similarity(regrow_after_cut(config, genomes, growth), growth.grids)
    assert np.array_equal(result.details["similarity"], score)
    assert np.allclose(result.fitness, walk.fitness - 0.25 * (49 - score))
    assert np.all(result.fitness >= task.lowest_fitness)
    free = GrowRegrowTask(nca=config, physics=FAST, duration=0.02, cell_cost=0.0)
    assert np.allclose(free.evaluate(genomes, SerialBackend()).fitness, walk.fitness)


def test_a_regrown_weight_walks_the_regrown_robot_too():
    config = NCAConfig(dim=2, kind="ff")
    genomes = random_genomes(config, 5, seed=4)
    task = GrowRegrowTask(nca=config, physics=FAST, duration=0.02, cell_cost=0.25,
                          regrown_weight=0.25)
    result = task.evaluate(genomes, SerialBackend())
    walking = LocomotionTask(nca=config, physics=FAST, duration=0.02)
    growth = grow(config, genomes)
    regrown = regrow_after_cut(config, genomes, growth)
    grown_walk = walking.evaluate_grids(growth.grids, SerialBackend())
    regrown_walk = walking.evaluate_grids(regrown, SerialBackend())
    assert not np.array_equal(regrown, growth.grids)  # some regrowth differs: walked anew
    assert np.array_equal(result.details["regrown_locomotion"], regrown_walk.fitness)
    assert np.array_equal(result.details["regrown_distance"], regrown_walk.details["distance"])
    assert np.array_equal(result.details["locomotion"], grown_walk.fitness)
    score = own_similarity(regrown, growth.grids)
    expected = 0.75 * grown_walk.fitness + 0.25 * regrown_walk.fitness - 0.25 * (49 - score)
    stable = grown_walk.stable & regrown_walk.stable
    assert stable.all()  # so that the mix is what is compared
    assert np.allclose(result.fitness, expected)
    assert result.grids.shape == growth.grids.shape and result.n_distinct == len(
        {g.tobytes() for g in growth.grids})


def test_configuration_round_trip_and_bad_settings():
    task = GrowRegrowTask(nca=NCAConfig(dim=3, kind="lstm"), duration=0.3, cut="z > 4",
                          cell_cost=0.2)
    again = GrowRegrowTask.from_config(task.to_config())
    assert again == task and again.to_config() == task.to_config()
    weighted = GrowRegrowTask(nca=NCAConfig(dim=3), regrown_weight=0.5)
    assert GrowRegrowTask.from_config(weighted.to_config()).regrown_weight == 0.5
    earlier = {k: v for k, v in task.to_config().items() if k != "regrown_weight"}
    assert GrowRegrowTask.from_config(earlier) == task  # written before the weight existed
    for weight in (-0.1, 1.5, float("nan")):
        with pytest.raises(ValueError, match="regrown_weight"):
            GrowRegrowTask(nca=NCAConfig(dim=3), regrown_weight=weight)
    with pytest.raises(ValueError, match="cell_cost"):
        GrowRegrowTask(nca=NCAConfig(dim=3), cell_cost=-1.0)
    with pytest.raises(ValueError, match="axis"):
        GrowRegrowTask(nca=NCAConfig(dim=2), cut="y > 2")
    with pytest.raises(ValueError, match="not a grow-regrow task"):
        GrowRegrowTask.from_config(LocomotionTask(nca=NCAConfig(dim=3)).to_config())


def test_the_half_cut_takes_each_robots_own_lower_half_which_no_robot_can_grow_away_from():
    from mjregen.grid import Material
    from mjregen.tasks.grow_regrow import damaged_states, half_cut

    paper_like = np.zeros((9, 9, 9), np.int8)
    paper_like[1:8, 3:6, 1:4] = int(Material.SOFT)
    assert half_cut(paper_like) == "x < 4"  # a robot across x 1-7: the paper's cut
    column = np.zeros((9, 9, 9), np.int8)
    column[7, 7, 1:8] = int(Material.MUSCLE_MINUS)
    assert half_cut(column) == "z < 4"  # one voxel wide: cut across its height
    assert half_cut(np.zeros((9, 9), np.int8)) == "x < 0"  # nothing to cut

    config = NCAConfig(dim=3, kind="lstm")
    growth = grow(config, random_genomes(config, 3, seed=5))
    growth.grids[0] = column  # a robot away from the paper's cut, as evolution found one
    paper = damaged_states(config, growth, "paper")
    half = damaged_states(config, growth, "half")
    assert np.array_equal(paper.state[0].numpy(), column)  # the paper's cut misses it
    assert np.count_nonzero(half.state[0].numpy()) == 4  # z 4-7 are left
    for i, grid in enumerate(growth.grids):
        if np.count_nonzero(grid) > 1:  # every robot of more than one voxel loses cells
            assert np.count_nonzero(half.state[i].numpy()) < np.count_nonzero(grid)
        axis, _, middle = half_cut(grid).split()
        k = "xyz".index(axis)
        kept = np.moveaxis(half.state[i].numpy(), k, 0)
        assert not kept[: int(middle)].any()  # state erased below the middle ...
        alpha = np.moveaxis(half.alpha[i].numpy(), k, 0)
        assert not alpha[: int(middle)].any()  # ... alpha too ...
        memory = np.moveaxis(half.memory[0][i].numpy(), k, 0)  # ... and LSTM memory (interior)
        assert not memory[: max(int(middle) - 1, 0)].any()


def test_a_half_cut_task_evaluates_and_round_trips():
    config = NCAConfig(dim=2, kind="ff")
    genomes = random_genomes(config, 4, seed=6)
    task = GrowRegrowTask(nca=config, physics=FAST, duration=0.02, cut="half", cell_cost=0.25)
    again = GrowRegrowTask.from_config(task.to_config())
    assert again == task and again.cut == "half"
    result = task.evaluate(genomes, SerialBackend())
    growth = grow(config, genomes)
    score = own_similarity(regrow_after_cut(config, genomes, growth, "half"), growth.grids)
    assert np.array_equal(result.details["similarity"], score)
