"""The paper's genetic algorithm over flat genomes, as an ask/tell optimiser.

Calling order: ``ask()`` gives the population to evaluate, ``tell(fitness)`` ranks it and
breeds the next one; repeat. The optimiser never evaluates anything itself.

One generation (the paper's code): everyone is evaluated (elites again too) and sorted by
fitness; the top `elites` join the next population unchanged; the other
``population - elites`` are children, each of a parent drawn uniformly from the top
`truncation`, child = parent + sigma·N(0, I) on every gene. No crossover. The first
population is N(0, init_std²) per gene.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np


@dataclass(frozen=True)
class GAConfig:
    """Settings of the genetic algorithm (see the module docstring)."""

    population: int
    generations: int
    truncation: int
    elites: int
    sigma: float
    init_std: float = 0.1

    def __post_init__(self) -> None:
        for name in ("population", "generations", "truncation"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"GA {name} must be a positive integer, got {value!r}")
        if not 0 <= self.elites < self.population:
            raise ValueError(
                f"GA elites must be in 0..{self.population - 1} (fewer than the population, "
                f"{self.population}, or no child is ever mutated), got {self.elites}")
        if self.truncation > self.population:
            raise ValueError(
                f"GA truncation ({self.truncation}) cannot exceed the population ({self.population})"
            )
        for name in ("sigma", "init_std"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"GA {name} must be positive and finite, got {value!r}")

    def to_dict(self) -> dict:
        return asdict(self)

    def with_overrides(self, **overrides: object) -> GAConfig:
        """A copy with the given fields replaced (None values are ignored)."""
        return replace(self, **{k: v for k, v in overrides.items() if v is not None})

    def scaled(self, population: int) -> GAConfig:
        """This GA at another population: truncation and elites keep their share of the
        population (at least 1 when this one has any); the other fields unchanged.

        Raises:
          ValueError: `population` is not a positive integer.
        """
        if isinstance(population, bool) or not isinstance(population, (int, np.integer)) \
                or population < 1:
            raise ValueError(f"GA population must be a positive integer, got {population!r}")

        def share(count: int) -> int:
            if count == 0:
                return 0
            return min(population, max(1, round(population * count / self.population)))

        return replace(self, population=int(population), truncation=share(self.truncation),
                       elites=share(self.elites))

    def summary(self) -> str:
        """One line: "pop 100, gens 300, truncation 20, elites 20, sigma 0.1"."""
        return (f"pop {self.population}, gens {self.generations}, truncation "
                f"{self.truncation}, elites {self.elites}, sigma {self.sigma:g}")


# The paper's settings (its code; "3d-paper-text" has the sigma its text and README state).
PRESETS: dict[str, GAConfig] = {
    "2d": GAConfig(population=300, generations=500, truncation=60, elites=1, sigma=0.03),
    "3d": GAConfig(population=100, generations=300, truncation=20, elites=20, sigma=0.1),
    "3d-paper-text": GAConfig(population=100, generations=300, truncation=20, elites=20, sigma=0.03),
    "regen": GAConfig(population=1000, generations=1000, truncation=200, elites=200, sigma=0.1),
}


class GeneticAlgorithm:
    """Ask/tell truncation-selection GA with elitism.

    Args:
      config: the GA settings.
      genome_size: genes per individual.
      seed: seeds the only random generator this object uses.
    """

    def __init__(self, config: GAConfig, genome_size: int, *, seed: int | np.random.Generator) -> None:
        if genome_size < 1:
            raise ValueError(f"genome_size must be positive, got {genome_size}")
        self.config = config
        self.genome_size = genome_size
        self.rng = np.random.default_rng(seed)
        self.generation = 0
        self._population = self.rng.normal(
            0.0, config.init_std, size=(config.population, genome_size)
        ).astype(np.float32)
        self._asked = False
        self._pool: np.ndarray | None = None  # what the population was bred from
        self._breed_state: dict | None = None

    def ask(self) -> np.ndarray:
        """The current population, float32 ``(population, genome_size)``; elites first."""
        self._asked = True
        return self._population.copy()

    def tell(self, fitness: np.ndarray) -> np.ndarray:
        """Rank the asked population by `fitness` ``(population,)`` (higher is better) and
        breed the next one. Returns the ranking (indices, best first; ties keep order).

        Raises:
          RuntimeError: `ask` was not called for this generation.
          ValueError: wrong shape, or NaN in `fitness` (evaluators must give unstable or
            failed individuals a finite penalty).
        """
        if not self._asked:
            raise RuntimeError("call ask() before tell()")
        fitness = np.asarray(fitness, dtype=np.float64)
        if fitness.shape != (self.config.population,):
            raise ValueError(f"fitness must have shape ({self.config.population},), got {fitness.shape}")
        if np.any(np.isnan(fitness)):
            raise ValueError("fitness contains NaN; give failed individuals a finite penalty")
        ranking = np.argsort(-fitness, kind="stable")
        self._pool = self._population[ranking[: max(self.config.truncation, self.config.elites)]]
        self._breed_state = self.rng.bit_generator.state
        self._population = self._breed(self._pool)
        self.generation += 1
        self._asked = False
        return ranking

    def _breed(self, pool: np.ndarray) -> np.ndarray:
        """The next population from the ranked best ``pool`` (elites and parents): the top
        `elites` unchanged, then children of parents drawn from the top `truncation`."""
        n_children = self.config.population - self.config.elites
        parents = self.rng.integers(0, self.config.truncation, size=n_children)
        noise = self.rng.standard_normal(size=(n_children, self.genome_size))
        children = (pool[parents] + self.config.sigma * noise).astype(np.float32)
        return np.concatenate([pool[: self.config.elites], children])

    def state_dict(self) -> dict:
        """Everything needed to continue exactly: the generation and, once a generation is
        told, only what the current population was bred from (the ranked best
        ``max(truncation, elites)`` genomes and the random state before breeding), from
        which `from_state_dict` breeds it again bit for bit; before that the population
        itself. A run's checkpoint is then max(truncation, elites)/population of the
        population's size (the paper's GAs: a fifth)."""
        state = {"config": self.config.to_dict(), "genome_size": self.genome_size,
                 "generation": self.generation}
        if self._pool is None:  # nothing told yet (or since a checkpoint of a population)
            return {**state, "population": self._population.copy(),
                    "rng_state": self.rng.bit_generator.state}
        return {**state, "parents": self._pool.copy(), "rng_state": self._breed_state}

    @classmethod
    def from_state_dict(cls, state: dict) -> GeneticAlgorithm:
        """Rebuild an optimiser saved with `state_dict` (or with a whole "population", as
        earlier checkpoints hold it); it continues bit for bit.

        Raises:
          ValueError: the saved genomes do not have the configuration's shape.
        """
        ga = cls(GAConfig(**state["config"]), int(state["genome_size"]), seed=0)
        ga.generation = int(state["generation"])
        ga.rng.bit_generator.state = state["rng_state"]
        if "parents" in state:
            pool = np.asarray(state["parents"], dtype=np.float32)
            expected = (max(ga.config.truncation, ga.config.elites), ga.genome_size)
            if pool.shape != expected:
                raise ValueError(f"saved parents have shape {pool.shape}, expected {expected}")
            ga._pool, ga._breed_state = pool.copy(), state["rng_state"]
            ga._population = ga._breed(ga._pool)
            return ga
        population = np.asarray(state["population"], dtype=np.float32)
        if population.shape != (ga.config.population, ga.genome_size):
            raise ValueError(
                f"saved population has shape {population.shape}, expected "
                f"({ga.config.population}, {ga.genome_size})"
            )
        ga._population = population.copy()
        return ga
