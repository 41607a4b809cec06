"""The genetic algorithm's mechanics on cheap analytic fitness functions."""

import numpy as np
import pytest

from mjregen.search.ga import PRESETS, GAConfig, GeneticAlgorithm


def nearest(children: np.ndarray, candidates: np.ndarray) -> np.ndarray:
    distances = ((children[:, None, :] - candidates[None, :, :]) ** 2).sum(-1)
    return distances.argmin(axis=1)


def test_initial_population_is_normal_with_init_std():
    ga = GeneticAlgorithm(GAConfig(population=200, generations=1, truncation=10, elites=1, sigma=0.1), 500, seed=0)
    population = ga.ask()
    assert population.shape == (200, 500) and population.dtype == np.float32
    assert abs(population.std() - 0.1) < 0.002 and abs(population.mean()) < 0.002


def test_elites_survive_unchanged_and_children_come_from_the_top_t():
    config = GAConfig(population=60, generations=1, truncation=5, elites=3, sigma=0.01, init_std=1.0)
    ga = GeneticAlgorithm(config, 200, seed=1)
    population = ga.ask()
    fitness = np.random.default_rng(2).normal(size=60)
    ranking = ga.tell(fitness)
    assert np.array_equal(ranking, np.argsort(-fitness))
    ranked = population[ranking]
    nxt = ga.ask()
    assert np.array_equal(nxt[:3], ranked[:3])  # elites first, best first, bit for bit
    children = nxt[3:]
    parents = nearest(children, ranked)
    assert parents.max() < 5  # only the top T breed
    assert set(parents) == set(range(5))  # uniformly: with 57 children all 5 are used
    noise = children - ranked[parents]
    assert abs(noise.std() - 0.01) < 0.0005 and abs(noise.mean()) < 0.0005  # sigma


def test_best_fitness_never_drops_and_a_sphere_is_optimised():
    target = np.linspace(-1, 1, 20)
    config = GAConfig(population=50, generations=60, truncation=10, elites=5, sigma=0.05)
    ga = GeneticAlgorithm(config, 20, seed=3)
    best = []
    for _ in range(config.generations):
        population = ga.ask()
        fitness = -((population - target) ** 2).sum(axis=1)
        best.append(fitness.max())
        ga.tell(fitness)
    assert np.all(np.diff(best) >= 0)  # elitism with a deterministic fitness
    assert best[0] < -6 and best[-1] > -0.5


def test_same_seed_same_run_and_state_dict_resumes_bit_for_bit():
    config = PRESETS["3d"].with_overrides(population=30, truncation=6, elites=4)

    def fitness(population):
        return np.sin(population).sum(axis=1)

    def run(ga, generations):
        out = []
        for _ in range(generations):
            population = ga.ask()
            out.append(population)
            ga.tell(fitness(population))
        return out

    full = run(GeneticAlgorithm(config, 50, seed=9), 6)
    again = run(GeneticAlgorithm(config, 50, seed=9), 6)
    assert all(np.array_equal(a, b) for a, b in zip(full, again))
    first = GeneticAlgorithm(config, 50, seed=9)
    head = run(first, 3)
    resumed = GeneticAlgorithm.from_state_dict(first.state_dict())
    assert resumed.generation == 3
    tail = run(resumed, 3)
    assert all(np.array_equal(a, b) for a, b in zip(full, head + tail))
    assert not np.array_equal(run(GeneticAlgorithm(config, 50, seed=10), 1)[0], full[0])


def test_a_saved_state_holds_only_what_the_population_was_bred_from():
    """After a generation the state keeps the ranked top max(truncation, elites) genomes
    and the random state before breeding (a fifth of the population at the paper's
    settings); a state holding the whole population (earlier checkpoints) continues the
    same."""
    config = GAConfig(population=30, generations=9, truncation=6, elites=4, sigma=0.1)
    rng = np.random.default_rng(0)

    def step(ga):
        population = ga.ask()
        ga.tell(rng.normal(size=len(population)))
        return population

    ga = GeneticAlgorithm(config, 40, seed=2)
    assert "population" in ga.state_dict()  # nothing told yet
    for _ in range(2):
        step(ga)
    state = ga.state_dict()
    assert "population" not in state and state["parents"].shape == (6, 40)
    lean = GeneticAlgorithm.from_state_dict(state)
    whole = GeneticAlgorithm.from_state_dict(
        {**{k: v for k, v in state.items() if k != "parents"}, "population": ga.ask(),
         "rng_state": ga.rng.bit_generator.state})
    assert np.array_equal(lean.ask(), ga.ask()) and np.array_equal(whole.ask(), ga.ask())
    fitness = rng.normal(size=30)
    for other in (lean, whole):
        other.tell(fitness)
    ga.tell(fitness)
    assert np.array_equal(lean.ask(), ga.ask()) and np.array_equal(whole.ask(), ga.ask())
    with pytest.raises(ValueError, match="parents have shape"):
        GeneticAlgorithm.from_state_dict({**state, "parents": state["parents"][:3]})


def test_presets_are_the_papers_settings():
    assert PRESETS["2d"] == GAConfig(300, 500, 60, 1, 0.03)
    assert PRESETS["3d"] == GAConfig(100, 300, 20, 20, 0.1)
    assert PRESETS["3d-paper-text"].sigma == 0.03
    assert PRESETS["regen"] == GAConfig(1000, 1000, 200, 200, 0.1)
    assert PRESETS["3d"].scaled(20).with_overrides(sigma=None).population == 20
    with pytest.raises(ValueError, match="no child is ever mutated"):  # 20 elites fill it
        PRESETS["3d"].with_overrides(population=20)


def test_misuse_raises():
    ga = GeneticAlgorithm(GAConfig(10, 1, 2, 1, 0.1), 5, seed=0)
    with pytest.raises(RuntimeError, match="ask"):
        ga.tell(np.zeros(10))
    ga.ask()
    with pytest.raises(ValueError, match="shape"):
        ga.tell(np.zeros(9))
    with pytest.raises(ValueError, match="NaN"):
        ga.tell(np.full(10, np.nan))
    for bad in [dict(population=0), dict(elites=11), dict(truncation=11), dict(sigma=-1.0), dict(sigma=float("nan"))]:
        with pytest.raises(ValueError):
            GAConfig(10, 1, 2, 1, 0.1).with_overrides(**bad)


def test_presets_keep_their_shares_at_another_population():
    assert PRESETS["2d"].scaled(50) == GAConfig(50, 500, 10, 1, 0.03)  # 60/300, the one elite
    assert PRESETS["3d"].scaled(30) == GAConfig(30, 300, 6, 6, 0.1)
    assert PRESETS["3d"].scaled(2).truncation == 1
    with pytest.raises(ValueError, match="positive integer"):
        PRESETS["3d"].scaled(0)


def test_cli_population_scales_the_preset_and_explicit_numbers_win():
    from mjregen.cli import build_parser
    from mjregen.cli.common import ga_config

    parse = build_parser().parse_args
    ga = ga_config(parse(["evolve", "--dim", "2", "--pop", "50", "--out", "x"]), "2d")
    assert (ga.population, ga.truncation, ga.elites) == (50, 10, 1)
    ga = ga_config(parse(["evolve", "--pop", "50", "--truncation", "7", "--out", "x"]), "3d")
    assert (ga.population, ga.truncation, ga.elites) == (50, 7, 10)
