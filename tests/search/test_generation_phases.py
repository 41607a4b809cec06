"""`benchmarks/generation_phases.py`: the generation it times is the run's next one, and its
job-by-job record changes no fitness."""

from __future__ import annotations

import numpy as np

from mjregen.growth.nca import NCAConfig
from mjregen.physics import Physics
from mjregen.search.backends import SerialBackend
from mjregen.search.ga import GAConfig
from mjregen.search.runs import run_evolution
from mjregen.tasks.locomotion import LocomotionTask

from repo_modules import load_module

phases = load_module("benchmarks/generation_phases.py")

GA = GAConfig(population=5, generations=2, truncation=2, elites=1, sigma=0.3, init_std=0.5)


def tiny_run(out):
    task = LocomotionTask(nca=NCAConfig(dim=2, kind="ff"),
                          physics=Physics().replace(settle_time=0.01), duration=0.02)
    return task, run_evolution(task, GA, seed=5, out=out, backend=SerialBackend(),
                               progress=False)


def test_the_timed_generation_is_the_runs_next_and_keeps_its_fitnesses(tmp_path):
    task, summary = tiny_run(tmp_path / "run")
    stored, genomes, generation = phases.population(tmp_path / "run")
    assert generation == GA.generations and genomes.shape == (GA.population, task.genome_size)
    assert np.array_equal(genomes[0], summary.best_genome)  # the elite leads the next one
    with SerialBackend() as backend:
        plain = stored.evaluate(genomes, backend)
    measured = phases.measure(str(tmp_path / "run"), ["serial", "thread"], 1)
    assert measured["generation"] == generation
    for row in measured["rows"]:
        assert row["same_fitness"] and row["jobs"] == plain.n_distinct
        assert row["job_cpu_s"] > 0 and row["probe_s"] > 0
        assert row["idle_in_map_s"] >= -1e-3 and row["map_wall_s"] <= row["wall_s"]
        assert len(row["job_times_first_round"]) == plain.n_distinct
    serial = measured["rows"][0]
    assert np.allclose(serial["wall_s_rounds"], [serial["wall_s"]])
    section = "\n".join(phases.markdown_section([measured]))
    assert f"| {generation} of `{tmp_path / 'run'}`" in section and "|  | thread |" in section
