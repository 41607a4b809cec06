"""MAP-Elites over flat genomes, as an ask/tell optimiser built on ribs (pyribs).

An archive (`ribs.archives.GridArchive`) has one cell per combination of behaviour
descriptor bins and keeps the fittest genome found for each cell (its elite). Each iteration,
every emitter asks for a batch: at first the GA's initial distribution, N(0, init_std²) per
gene; then elites drawn uniformly from the archive plus Gaussian noise (``emitter
"gaussian"``: sigma·N(0, I), like the GA's mutation) or iso+line noise (``"iso-line"``:
sigma·N(0, I) plus line_sigma·N(0, 1)·(another elite - the parent)). `tell` places the batch
by its fitness and descriptors. The optimiser never evaluates anything itself.

Exact continuation: `state_bytes` pickles the ribs scheduler (archive, emitters and their
random generators), as ribs recommends for checkpoints; `from_state_bytes` restores it and
the run continues bit for bit. Every random generator is seeded from the one seed.
"""

from __future__ import annotations

import io
import math
import pickle
from dataclasses import asdict, dataclass, field, replace
from types import ModuleType

import numpy as np

from mjregen.errors import CheckpointError, MjregenError

EMITTERS = ("gaussian", "iso-line")


class MissingRibsError(MjregenError, ImportError):
    """MAP-Elites needs the ribs package, which is not installed."""


def import_ribs() -> ModuleType:
    """ribs, imported on first use (its import takes seconds); MissingRibsError without it."""
    try:
        import ribs
        import ribs.archives
        import ribs.emitters
        import ribs.schedulers
    except ImportError:
        raise MissingRibsError("MAP-Elites needs ribs: pip install 'mjregen[qd]' (or pip "
                               "install ribs)") from None
    return ribs


MAX_CELLS = 1_000_000  # cells of an archive (ribs allocates every cell's genome up front)


@dataclass(frozen=True)
class MapElitesConfig:
    """Settings of a MAP-Elites search (see the module docstring).

    Attributes:
      iterations: ask/tell rounds.
      batch: genomes evaluated per iteration, shared evenly by the emitters.
      emitters: emitters (each asks for batch / emitters genomes).
      sigma: standard deviation of the Gaussian noise per gene.
      line_sigma: "iso-line" emitters' step along the line between two elites.
      emitter: "gaussian" or "iso-line".
      descriptors: behaviour descriptor names (`mjregen.tasks.descriptors.DESCRIPTORS`).
      cells: bins per descriptor, one number per descriptor.
      init_std: standard deviation of the first genomes per gene (the GA's).
    """

    iterations: int
    batch: int
    emitters: int = 4
    sigma: float = 0.1
    line_sigma: float = 0.2
    emitter: str = "gaussian"
    descriptors: tuple[str, ...] = ("voxels", "muscle")
    cells: tuple[int, ...] = (20, 10)
    init_std: float = 0.1

    def __post_init__(self) -> None:
        object.__setattr__(self, "descriptors", tuple(self.descriptors))
        object.__setattr__(self, "cells", tuple(int(c) for c in self.cells))
        for name in ("iterations", "batch", "emitters"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"MAP-Elites {name} must be a positive integer, got {value!r}")
        if self.batch % self.emitters:
            raise ValueError(f"MAP-Elites batch ({self.batch}) must be a multiple of the "
                             f"number of emitters ({self.emitters})")
        for name in ("sigma", "line_sigma", "init_std"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"MAP-Elites {name} must be positive and finite, got {value!r}")
        if self.emitter not in EMITTERS:
            raise ValueError(f"unknown emitter {self.emitter!r}; choose one of "
                             + ", ".join(EMITTERS))
        if len(self.cells) != len(self.descriptors):
            raise ValueError(f"give one number of cells per descriptor: {len(self.cells)} for "
                             f"{len(self.descriptors)} ({', '.join(self.descriptors)})")
        if any(c < 1 for c in self.cells):
            raise ValueError(f"cells per descriptor must be >= 1, got {self.cells}")
        if math.prod(self.cells) > MAX_CELLS:
            raise ValueError(f"{' x '.join(map(str, self.cells))} = {math.prod(self.cells):,} "
                             f"cells: an archive holds at most {MAX_CELLS:,} (each cell keeps a "
                             "genome of thousands of numbers); use fewer cells per descriptor")

    def to_dict(self) -> dict:
        out = asdict(self)
        out.update(descriptors=list(self.descriptors), cells=list(self.cells))
        return out

    @classmethod
    def from_dict(cls, values: dict) -> MapElitesConfig:
        return cls(**values)

    def with_overrides(self, **overrides: object) -> MapElitesConfig:
        """A copy with the given fields replaced (None values are ignored)."""
        return replace(self, **{k: v for k, v in overrides.items() if v is not None})

    def summary(self) -> str:
        """One line: "batch 100, iterations 300, 4 gaussian emitters, sigma 0.1, cells
        voxels 20 x muscle 10"."""
        cells = " x ".join(f"{n} {c}" for n, c in zip(self.descriptors, self.cells))
        return (f"batch {self.batch}, iterations {self.iterations}, {self.emitters} "
                f"{self.emitter} emitters, sigma {self.sigma:g}, cells {cells}")


@dataclass
class ArchiveSnapshot:
    """The archive's elites, each row one filled cell.

    Attributes:
      index: int ``(E,)`` flat cell index; ``cells`` the grid's shape.
      genomes: float32 ``(E, genome_size)``.
      fitness: float64 ``(E,)``.
      descriptors: float64 ``(E, D)``.
      extra: per-elite fields stored beside them (e.g. "grid", "distance").
    """

    index: np.ndarray
    genomes: np.ndarray
    fitness: np.ndarray
    descriptors: np.ndarray
    cells: tuple[int, ...]
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    def fitness_grid(self) -> np.ndarray:
        """float64 array of shape `cells`: each cell's elite's fitness, NaN where empty."""
        values = np.full(int(np.prod(self.cells)), np.nan)
        values[self.index] = self.fitness
        return values.reshape(self.cells)


class MapElites:
    """Ask/tell MAP-Elites (see the module docstring).

    Args:
      config: the search's settings.
      genome_size: genes per individual.
      ranges: (low, high) of each descriptor; values outside fall into the edge cells.
      seed: seeds every random generator of the search.
      qd_score_offset: subtracted from every elite's fitness in the QD score (a value below
        every fitness the task gives, so that each elite adds a positive amount).
      extra_fields: {name: (shape, dtype)} stored with each elite (e.g. its robot grid).
    """

    def __init__(self, config: MapElitesConfig, genome_size: int, *,
                 ranges: list[tuple[float, float]], seed: int, qd_score_offset: float,
                 extra_fields: dict[str, tuple[tuple[int, ...], type]] | None = None) -> None:
        ribs = import_ribs()
        if genome_size < 1:
            raise ValueError(f"genome_size must be positive, got {genome_size}")
        if len(ranges) != len(config.descriptors):
            raise ValueError(f"{len(ranges)} ranges for {len(config.descriptors)} descriptors")
        self.config = config
        self.genome_size = genome_size
        self.iteration = 0
        seeds = np.random.SeedSequence(seed).generate_state(1 + 2 * config.emitters)
        archive = ribs.archives.GridArchive(solution_dim=genome_size, dims=list(config.cells),
                              ranges=[tuple(map(float, r)) for r in ranges],
                              qd_score_offset=float(qd_score_offset), seed=int(seeds[0]),
                              solution_dtype=np.float32, extra_fields=extra_fields or None)
        each = config.batch // config.emitters
        emitters = []
        for k in range(config.emitters):
            start = np.random.default_rng(seeds[1 + 2 * k]).normal(
                0.0, config.init_std, size=(each, genome_size)).astype(np.float32)
            common = dict(initial_solutions=start, batch_size=each, seed=int(seeds[2 + 2 * k]))
            if config.emitter == "gaussian":
                emitters.append(ribs.emitters.GaussianEmitter(archive, sigma=config.sigma,
                                                              **common))
            else:
                emitters.append(ribs.emitters.IsoLineEmitter(
                    archive, iso_sigma=config.sigma, line_sigma=config.line_sigma, **common))
        self._scheduler = ribs.schedulers.Scheduler(archive, emitters)
        self._asked: np.ndarray | None = None

    @property
    def archive(self):  # -> ribs.archives.GridArchive (imported on first use)
        """The ribs archive."""
        return self._scheduler.archive

    def ask(self) -> np.ndarray:
        """This iteration's genomes, float32 ``(batch, genome_size)``."""
        self._asked = np.asarray(self._scheduler.ask(), dtype=np.float32)
        return self._asked.copy()

    def tell(self, fitness: np.ndarray, descriptors: np.ndarray, **extra: np.ndarray) -> None:
        """Place the asked genomes by `fitness` ``(batch,)`` (higher is better) and
        `descriptors` ``(batch, D)``; `extra` holds each one's extra fields.

        Raises:
          RuntimeError: `ask` was not called for this iteration.
          ValueError: wrong shapes, NaN in `fitness` or non-finite descriptors.
        """
        if self._asked is None:
            raise RuntimeError("call ask() before tell()")
        fitness = np.asarray(fitness, dtype=np.float64)
        descriptors = np.asarray(descriptors, dtype=np.float64)
        batch, dims = len(self._asked), len(self.config.descriptors)
        if fitness.shape != (batch,):
            raise ValueError(f"fitness must have shape ({batch},), got {fitness.shape}")
        if descriptors.shape != (batch, dims):
            raise ValueError(f"descriptors must have shape ({batch}, {dims}), got "
                             f"{descriptors.shape}")
        if np.any(np.isnan(fitness)):
            raise ValueError("fitness contains NaN; give failed individuals a finite penalty")
        if not np.all(np.isfinite(descriptors)):
            raise ValueError("descriptors must be finite")
        self._scheduler.tell(fitness, descriptors, **extra)
        self.iteration += 1
        self._asked = None

    def snapshot(self) -> ArchiveSnapshot:
        """The archive's elites now."""
        data = self.archive.data()
        extra = {k: v for k, v in data.items()
                 if k not in ("solution", "objective", "measures", "threshold", "index")}
        return ArchiveSnapshot(index=np.asarray(data["index"], dtype=np.int64),
                               genomes=np.asarray(data["solution"], dtype=np.float32),
                               fitness=np.asarray(data["objective"], dtype=np.float64),
                               descriptors=np.asarray(data["measures"], dtype=np.float64),
                               cells=self.config.cells, extra=extra)

    def stats(self) -> dict[str, float]:
        """QD score (sum of elites' fitness - offset), coverage (filled cells / cells),
        elites and the best elite's fitness."""
        stats = self.archive.stats
        return {"qd_score": float(stats.qd_score), "coverage": float(stats.coverage),
                "elites": int(stats.num_elites),
                "best": float(stats.obj_max) if stats.num_elites else float("nan")}

    def state_bytes(self) -> bytes:
        """Everything needed to continue exactly (between iterations)."""
        if self._asked is not None:
            raise RuntimeError("save the search between iterations (after tell)")
        return pickle.dumps({"config": self.config.to_dict(), "genome_size": self.genome_size,
                             "iteration": self.iteration, "scheduler": self._scheduler},
                            protocol=pickle.HIGHEST_PROTOCOL)

    @classmethod
    def from_state_bytes(cls, data: bytes) -> MapElites:
        """The search `state_bytes` saved. Only load your own run's files: this unpickles.

        Raises:
          CheckpointError: the bytes are not a saved MAP-Elites search.
        """
        import_ribs()
        try:
            state = _SearchUnpickler(io.BytesIO(data)).load()
            config = MapElitesConfig.from_dict(state["config"])
            search = cls.__new__(cls)
            search.config, search.genome_size = config, int(state["genome_size"])
            search.iteration, search._scheduler = int(state["iteration"]), state["scheduler"]
            search._asked = None
        except (pickle.UnpicklingError, EOFError, KeyError, TypeError, ValueError,
                AttributeError, ImportError) as error:
            raise CheckpointError(f"not a saved MAP-Elites search: {type(error).__name__}: "
                                  f"{error}") from None
        return search


class _SearchUnpickler(pickle.Unpickler):
    """Unpickles only what a saved search holds: numpy's and ribs' objects."""

    ALLOWED_ROOTS = ("numpy", "ribs")

    def find_class(self, module: str, name: str) -> object:
        if module.split(".")[0] not in self.ALLOWED_ROOTS:
            raise pickle.UnpicklingError(f"a saved search does not hold {module}.{name}")
        return super().find_class(module, name)
