"""MAP-Elites: the ask/tell optimiser over ribs and its run folders (exact resume, archive,
pictures, no silent overwrite)."""

import csv
import json

import numpy as np
import pytest

from mjregen.errors import CheckpointError
from mjregen.grid import Robot
from mjregen.growth.checkpoint import load_nca
from mjregen.growth.nca import NCAConfig, grow
from mjregen.search.backends import SerialBackend
from mjregen.search.map_elites import MapElites, MapElitesConfig
from mjregen.search.qd_runs import read_archive, run_map_elites
from mjregen.search.run_folder import RunFolderError, read_progress
from mjregen.tasks.descriptors import describe, descriptor_ranges
from mjregen.tasks.evaluation import PopulationEvaluation

CONFIG = MapElitesConfig(iterations=5, batch=12, emitters=3, sigma=0.1,
                         descriptors=("voxels", "muscle"), cells=(8, 5))


class SphereTask:
    """Fitness = -|genome - 0.05|² (cheap, deterministic); robots grown for real (2D)."""

    nca = NCAConfig(dim=2, kind="ff")

    def to_config(self):
        return {"task": "sphere"}
    lowest_fitness = -1e3

    def evaluate(self, genomes, backend):
        fitness = -((genomes.astype(np.float64) - 0.05) ** 2).sum(axis=1)
        return PopulationEvaluation(fitness=fitness, grids=grow(self.nca, genomes).grids)


class Killed(Exception):
    pass


def run(out, config=CONFIG, **kwargs):
    return run_map_elites(SphereTask(), config, seed=5, out=out, backend=SerialBackend(),
                          progress=False, **kwargs)


def rows(out):
    with open(out / "metrics.csv") as handle:
        return list(csv.DictReader(handle))


def toy_search(seed=1, **overrides):
    return MapElites(CONFIG.with_overrides(**overrides), 6, ranges=[(0, 10), (0, 1)],
                     seed=seed, qd_score_offset=-100.0)


def toy_round(search):
    genomes = search.ask()
    descriptors = np.stack([np.abs(genomes[:, 0]) * 40, np.abs(genomes[:, 1]) * 4], axis=1)
    search.tell(-(genomes.astype(np.float64) ** 2).sum(axis=1), descriptors)
    return genomes


def test_the_archive_keeps_the_fittest_genome_of_each_cell():
    search = toy_search()
    seen = {}
    for _ in range(4):
        genomes = toy_round(search)
        descriptors = np.stack([np.abs(genomes[:, 0]) * 40, np.abs(genomes[:, 1]) * 4], axis=1)
        cells = search.archive.index_of(descriptors)
        for cell, genome in zip(cells, genomes):
            fitness = -(genome.astype(np.float64) ** 2).sum()
            if cell not in seen or fitness > seen[cell][0]:
                seen[cell] = (fitness, genome)
    snapshot = search.snapshot()
    assert sorted(snapshot.index.tolist()) == sorted(seen)
    for cell, fitness, genome in zip(snapshot.index, snapshot.fitness, snapshot.genomes):
        assert fitness == pytest.approx(seen[cell][0])
        assert np.array_equal(genome, seen[cell][1])
    stats = search.stats()
    assert stats["elites"] == len(seen)
    assert stats["coverage"] == pytest.approx(len(seen) / 40)
    assert stats["qd_score"] == pytest.approx(sum(f + 100.0 for f, _ in seen.values()))
    assert stats["best"] == pytest.approx(max(f for f, _ in seen.values()))
    assert np.isnan(snapshot.fitness_grid()).sum() == 40 - len(seen)


def test_first_genomes_follow_the_initial_distribution_then_elites_are_mutated():
    search = toy_search(batch=300, emitters=3, init_std=0.1)
    first = toy_round(search)
    assert first.dtype == np.float32 and first.shape == (300, 6)
    assert first.std() == pytest.approx(0.1, rel=0.1)
    parents = search.snapshot().genomes
    second = search.ask()  # each child is an elite plus sigma-noise
    nearest = np.min(np.linalg.norm(second[:, None, :] - parents[None], axis=2), axis=1)
    assert np.median(nearest) < 0.1 * np.sqrt(6) * 1.5


def test_same_seed_same_search_other_seed_another():
    a, b, c = toy_search(seed=1), toy_search(seed=1), toy_search(seed=2)
    for _ in range(3):
        ga, gb, gc = toy_round(a), toy_round(b), toy_round(c)
    assert np.array_equal(ga, gb) and not np.array_equal(ga, gc)


def test_saved_state_continues_bit_for_bit():
    for emitter in ("gaussian", "iso-line"):
        search = toy_search(emitter=emitter)
        toy_round(search)
        copy = MapElites.from_state_bytes(search.state_bytes())
        assert copy.iteration == 1
        for _ in range(2):
            assert np.array_equal(toy_round(search), toy_round(copy))
        assert search.stats() == copy.stats()


def test_bad_input_is_refused():
    search = toy_search()
    with pytest.raises(RuntimeError, match="ask"):
        search.tell(np.zeros(12), np.zeros((12, 2)))
    search.ask()
    with pytest.raises(ValueError, match="shape"):
        search.tell(np.zeros(11), np.zeros((12, 2)))
    with pytest.raises(ValueError, match="NaN"):
        search.tell(np.full(12, np.nan), np.zeros((12, 2)))
    with pytest.raises(ValueError, match="finite"):
        search.tell(np.zeros(12), np.full((12, 2), np.inf))
    with pytest.raises(CheckpointError, match="not a saved MAP-Elites search"):
        MapElites.from_state_bytes(b"not a pickle")
    import pickle

    with pytest.raises(CheckpointError, match="does not hold posix.system"):
        MapElites.from_state_bytes(pickle.dumps(__import__("os").system))
    with pytest.raises(ValueError, match="multiple of the number of emitters"):
        MapElitesConfig(iterations=1, batch=10, emitters=3)
    with pytest.raises(ValueError, match="one number of cells per descriptor"):
        MapElitesConfig(iterations=1, batch=4, descriptors=("voxels",), cells=(3, 3))
    with pytest.raises(ValueError, match="unknown emitter"):
        MapElitesConfig(iterations=1, batch=4, emitter="cma")
    with pytest.raises(ValueError, match="at most 1,000,000"):  # before any memory is taken
        MapElitesConfig(iterations=1, batch=4, cells=(2000, 2000))


def test_run_folder_contents(tmp_path):
    out = tmp_path / "run"
    summary = run(out)
    table = rows(out)
    assert [int(r["iteration"]) for r in table] == list(range(5))
    qd = [float(r["qd_score"]) for r in table]
    assert all(b >= a for a, b in zip(qd, qd[1:]))  # elites are only ever replaced by fitter
    assert summary.qd_score == pytest.approx(qd[-1], rel=1e-6)
    config = json.loads((out / "config.json").read_text())
    assert config["map_elites"]["cells"] == [8, 5] and config["seed"] == 5
    stored = read_archive(out / "archive.npz")
    assert stored.descriptors == ("voxels", "muscle") and stored.nca == SphereTask.nca
    assert len(stored.snapshot.index) == summary.elites == int(table[-1]["elites"])
    grids = stored.snapshot.extra["grid"]
    assert np.allclose(describe(grids, stored.descriptors), stored.snapshot.descriptors)
    for row in range(len(grids)):  # each elite's stored robot is what its genome grows
        assert np.array_equal(stored.nca_of(row).grow().robot().grid, grids[row])
    assert stored.ranges == tuple(descriptor_ranges(("voxels", "muscle"), (7, 7)))
    nca, meta = load_nca(out / "best.npz")
    assert meta["fitness"] == pytest.approx(summary.best_fitness)
    assert Robot.load(out / "best.npy") == nca.grow().robot()
    for picture in ("heatmap.png", "qd.png"):
        assert (out / picture).read_bytes()[:4] == b"\x89PNG"


def test_resume_after_a_kill_equals_an_uninterrupted_run(tmp_path):
    full = run(tmp_path / "full")

    def kill_after_iteration_2(row):
        if row["iteration"] == 2:
            raise Killed

    with pytest.raises(Killed):
        run(tmp_path / "killed", on_iteration=kill_after_iteration_2)
    assert len(rows(tmp_path / "killed")) == 3
    progress = read_progress(tmp_path / "killed")
    assert (progress.counter, progress.done, progress.planned, progress.complete) == (
        "iteration", 3, 5, False)
    assert progress.elapsed == float(rows(tmp_path / "killed")[-1]["elapsed"]) > 0
    resumed = run(tmp_path / "killed", resume=True)
    assert resumed.qd_score == full.qd_score and resumed.best_fitness == full.best_fitness
    keys = ("iteration", "qd_score", "coverage", "elites", "best", "batch_best", "batch_mean")
    assert [[r[k] for k in keys] for r in rows(tmp_path / "killed")] == \
           [[r[k] for k in keys] for r in rows(tmp_path / "full")]
    a, b = read_archive(tmp_path / "full" / "archive.npz"), read_archive(tmp_path / "killed" / "archive.npz")
    assert np.array_equal(a.snapshot.index, b.snapshot.index)
    assert np.array_equal(a.snapshot.genomes, b.snapshot.genomes)
    # a finished run whose archive was lost: its resume writes it again from the checkpoint
    (tmp_path / "killed" / "archive.npz").unlink()
    again = run(tmp_path / "killed", resume=True)
    assert again.qd_score == full.qd_score
    c = read_archive(tmp_path / "killed" / "archive.npz")
    assert np.array_equal(a.snapshot.genomes, c.snapshot.genomes)
    (tmp_path / "killed" / "metrics.csv").unlink()  # and whose metrics were lost: refused
    with pytest.raises(RunFolderError, match="metrics.csv lists no iteration"):
        run(tmp_path / "killed", resume=True)


def test_runs_are_never_overwritten_and_bad_checkpoints_are_named(tmp_path):
    out = tmp_path / "run"
    run(out, CONFIG.with_overrides(iterations=2))
    before = (out / "archive.npz").read_bytes()
    with pytest.raises(RunFolderError, match="not empty"):
        run(out, CONFIG.with_overrides(iterations=2))
    with pytest.raises(RunFolderError, match="different settings"):
        run(out, CONFIG.with_overrides(iterations=2, sigma=0.2), resume=True)
    (out / "checkpoint.npz").write_bytes(b"garbage")
    with pytest.raises(CheckpointError, match="cannot read run checkpoint"):
        run(out, CONFIG.with_overrides(iterations=2), resume=True)
    assert (out / "archive.npz").read_bytes() == before
    with pytest.raises(CheckpointError, match="cannot read MAP-Elites archive"):
        read_archive(out / "config.json")
