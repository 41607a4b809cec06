"""The locomotion fitness pipeline: distinct robots simulated once, backends agree,
diverging and raising evaluations are contained."""

import json

import numpy as np
import pytest

import mjregen.tasks.locomotion as locomotion
from mjregen.grid import Material, Robot
from mjregen.growth.nca import NCAConfig, grow
from mjregen.growth.networks import random_genomes
from mjregen.physics import Physics
from mjregen.physics.simulation import simulate
from mjregen.search.backends import ProcessBackend, SerialBackend, ThreadBackend, make_backend
from mjregen.tasks.evaluation import HARD_STEP_COST, expected_cost
from mjregen.tasks.fitness import (
    EMPTY_FITNESS,
    UNSTABLE_FITNESS,
    VOXEL_COST,
    locomotion_fitness,
    starts_fitness,
)

NCA = NCAConfig(dim=2, kind="ff")
QUICK = Physics().replace(settle_time=0.01)
TASK = locomotion.LocomotionTask(nca=NCA, physics=QUICK, duration=0.02)


class CountingBackend(SerialBackend):
    def __init__(self):
        super().__init__()
        self.items = 0

    def map(self, fn, items):
        self.items += len(items)
        return super().map(fn, items)


def population():
    genomes = random_genomes(NCA, 6, seed=4, std=0.5)
    return np.concatenate([genomes, genomes[:3]])  # 3 duplicates


def fresh_task(**kwargs) -> locomotion.LocomotionTask:
    """A task with an empty result cache."""
    return locomotion.LocomotionTask(nca=NCA, physics=QUICK, duration=0.02, **kwargs)


def test_each_distinct_robot_is_simulated_once_and_scored_like_simulate():
    genomes = population()
    backend = CountingBackend()
    result = fresh_task().evaluate(genomes, backend)
    grids = grow(NCA, genomes).grids
    distinct_nonempty = {g.tobytes() for g in grids if g.any()}
    assert backend.items == len(distinct_nonempty) and result.n_distinct == len({g.tobytes() for g in grids})
    assert np.array_equal(result.fitness[:3], result.fitness[6:])
    for i, grid in enumerate(grids):
        expected = (locomotion_fitness(simulate(grid, physics=QUICK, duration=0.02))
                    if grid.any() else EMPTY_FITNESS[2])
        assert result.fitness[i] == expected


def test_the_costliest_robots_are_handed_out_first():
    """A worker that starts the largest robot last keeps the others waiting at the end of
    a generation: jobs go out by expected cost, largest first (scores above are still each
    robot's own)."""
    submitted = []

    class Recording(SerialBackend):
        def map(self, fn, items):
            submitted.extend(expected_cost(job.grid) for job in items)
            return super().map(fn, items)

    fresh_task().evaluate(random_genomes(NCA, 12, seed=7, std=0.5), Recording())
    assert len(set(submitted)) > 2 and submitted == sorted(submitted, reverse=True)


def test_a_hard_voxel_makes_a_robot_costlier_than_its_voxel_count():
    soft = np.zeros((5, 5, 5), dtype=np.int8)
    soft[1:4, 1:4, 1:4] = Material.SOFT
    mixed = soft.copy()
    mixed[2, 2, 2] = Material.HARD
    assert expected_cost(soft) == 27 and expected_cost(mixed) == 27 * HARD_STEP_COST


def test_robots_seen_in_earlier_generations_come_from_the_cache_with_the_same_result():
    """Elites and recurring shapes are not simulated again; results are identical, and a
    cache too small to hold a generation only costs time."""
    genomes = population()
    task, backend = fresh_task(), CountingBackend()
    first = task.evaluate(genomes, backend)
    simulated = backend.items
    again = task.evaluate(genomes[::-1], backend)  # same robots, another order
    assert backend.items == simulated  # nothing new simulated
    assert np.array_equal(again.fitness, first.fitness[::-1])
    assert np.array_equal(again.details["distance"], first.details["distance"][::-1],
                          equal_nan=True)
    tiny, counting = fresh_task(cache_size=1), CountingBackend()
    tiny.evaluate(genomes, counting)
    repeat = tiny.evaluate(genomes, counting)
    assert counting.items == 2 * simulated - 1 and np.array_equal(repeat.fitness, first.fitness)


def test_3d_fitness_subtracts_the_voxel_cost():
    nca3 = NCAConfig(dim=3, kind="ff")
    task = locomotion.LocomotionTask(nca=nca3, physics=Physics().replace(settle_time=0.005), duration=0.005)
    genomes = random_genomes(nca3, 3, seed=1)
    result = task.evaluate(genomes, SerialBackend())
    for i in range(3):
        if result.details["voxels"][i]:
            expected = result.details["distance"][i] - VOXEL_COST * result.details["voxels"][i]
            assert result.fitness[i] == pytest.approx(expected)
        else:
            assert result.fitness[i] == EMPTY_FITNESS[3]


def test_all_backends_give_identical_fitness():
    genomes = population()
    reference = TASK.evaluate(genomes, SerialBackend()).fitness
    for backend in (ThreadBackend(2), ProcessBackend(2)):
        with backend:
            assert np.array_equal(TASK.evaluate(genomes, backend).fitness, reference), backend.name
    pytest.importorskip("ray")
    with make_backend("ray", workers=2) as backend:
        assert np.array_equal(TASK.evaluate(genomes, backend).fitness, reference)


def test_a_diverging_simulation_is_penalised_not_raised():
    unstable = locomotion.LocomotionTask(nca=NCA, physics=QUICK.replace(timestep_safety=20.0), duration=0.02)
    result = unstable.evaluate(population(), SerialBackend())
    simulated = result.details["voxels"] > 0
    assert simulated.any()
    assert np.all(~result.stable[simulated]) and np.all(result.fitness[simulated] == UNSTABLE_FITNESS[2])
    assert not result.failed.any()


def test_a_raising_evaluation_is_contained(monkeypatch):
    def explode(job):
        raise RuntimeError("solver exploded")

    monkeypatch.setattr(locomotion, "evaluate_robot", explode)
    task = fresh_task()
    result = task.evaluate(population(), SerialBackend())
    simulated = result.details["voxels"] > 0
    assert np.all(result.failed[simulated]) and np.all(result.fitness[simulated] == UNSTABLE_FITNESS[2])
    assert result.errors and "solver exploded" in result.errors[0]
    assert not task._cache  # a failure is not a result: it is tried again next generation


def test_a_task_and_its_run_configuration_are_one():
    task = locomotion.LocomotionTask(nca=NCAConfig(dim=3, kind="lstm"),
                                     physics=Physics().replace(settle_time=0.02), duration=0.1)
    config = task.to_config()
    assert json.loads(json.dumps(config)) == config  # what config.json holds
    again = locomotion.LocomotionTask.from_config(config)
    assert (again.nca, again.physics, again.duration) == (task.nca, task.physics, task.duration)
    with pytest.raises(ValueError, match="not a locomotion task: 'regrowth'"):
        locomotion.LocomotionTask.from_config({**config, "task": "regrowth"})


def test_a_robot_is_scored_by_the_mean_of_its_starts():
    """K starts: the fitness is the mean of the K walks' fitnesses (each `simulate` from
    start k of the task's seed), the details their mean, shortest and spread."""
    genomes = population()[:4]
    task = fresh_task(starts=3, start_seed=5)
    result = task.evaluate(genomes, SerialBackend())
    grids = grow(NCA, genomes).grids
    checked = 0
    for i, grid in enumerate(grids):
        if not grid.any():
            continue
        walks = [simulate(grid, physics=QUICK, duration=0.02, start_seed=5, start=k)
                 for k in range(3)]
        distances = [w.distance for w in walks]
        assert result.fitness[i] == np.mean([locomotion_fitness(w) for w in walks])
        assert result.details["distance"][i] == np.mean(distances)
        assert result.details["distance_min"][i] == min(distances)
        assert result.details["distance_std"][i] == pytest.approx(np.std(distances))
        checked += 1
    assert checked >= 2
    other = fresh_task(starts=3, start_seed=6).evaluate(genomes, SerialBackend())
    assert not np.array_equal(other.fitness, result.fitness)  # the seed names the starts


def test_one_unstable_start_makes_the_robot_unstable(monkeypatch):
    """Of two starts, one diverged: the robot is unstable and gets the penalty, never the
    other start's fitness."""
    import dataclasses

    from mjregen.tasks import evaluation

    walk = simulate(Robot.load("assets/robots/bimorph_walker_2d.npy"), physics=QUICK,
                    duration=0.02)
    diverged = dataclasses.replace(walk, stable=False, reason="runaway speed",
                                   distance=float("nan"))
    monkeypatch.setattr(evaluation, "simulate_starts", lambda *a, **k: [walk, diverged])
    job = evaluation.RobotJob(np.zeros((7, 7), dtype=np.int8), QUICK, 0.02, 2)
    scored = evaluation.evaluate_robot(job)
    assert not scored.stable and scored.reason == "runaway speed"
    assert scored.fitness == UNSTABLE_FITNESS[2] and np.isnan(scored.distance)


def test_backends_agree_on_scores_from_several_starts():
    genomes = population()
    reference = fresh_task(starts=2, start_seed=1).evaluate(genomes, SerialBackend()).fitness
    for backend in (ThreadBackend(2), ProcessBackend(2)):
        with backend:
            scored = fresh_task(starts=2, start_seed=1).evaluate(genomes, backend).fitness
            assert np.array_equal(scored, reference), backend.name


def test_a_task_described_before_starts_reads_as_one_exact_start():
    config = TASK.to_config()
    assert config["starts"] == 1 and config["start_seed"] == 0
    older = {k: v for k, v in config.items() if k not in ("starts", "start_seed")}
    older["physics"] = {**older["physics"], "format": 4,
                        "scene": {k: v for k, v in older["physics"]["scene"].items()
                                  if k != "start_shift"}}
    task = locomotion.LocomotionTask.from_config(older)
    assert (task.starts, task.start_seed, task.physics.scene.start_shift) == (1, 0, 0.0)


@pytest.mark.parametrize("kwargs", [{"starts": 0}, {"starts": 1.5}, {"starts": True},
                                    {"starts": 1001}, {"start_seed": -1}])
def test_bad_starts_are_refused(kwargs):
    with pytest.raises(ValueError, match="start"):
        fresh_task(**kwargs)


def test_several_exact_starts_are_refused():
    """With start shift 0 every start is the exact start: two would be one walk twice."""
    with pytest.raises(ValueError, match="need a start shift > 0"):
        locomotion.LocomotionTask(nca=NCA, physics=QUICK.replace(start_shift=0.0), starts=2)
    assert locomotion.LocomotionTask(nca=NCA, physics=QUICK.replace(start_shift=0.0)).starts == 1


def test_a_sheet_is_the_pattern_laid_flat_walked_in_3d_and_scored_by_the_2d_rule():
    """The paper's 2D robots: its code writes the grown pattern into Voxelyze as one layer
    (Z_Voxels 1) and scores the distance alone."""
    task = fresh_task(body="sheet")
    patterns = grow(NCA, population()).grids
    result = task.evaluate_grids(patterns, SerialBackend())
    assert result.grids.shape == patterns.shape + (3,)
    for pattern, fitness in zip(patterns, result.fitness):
        sheet = np.zeros(pattern.shape + (3,), dtype=np.int8)
        sheet[:, :, 1] = pattern
        walked = simulate(sheet, physics=QUICK, duration=0.02)
        assert walked.dim == 3
        assert fitness == (walked.distance if pattern.any() else EMPTY_FITNESS[2])
    assert np.any(result.fitness > 0)  # not only empty robots


def test_a_sheet_walks_for_the_paper_2d_times_unless_they_are_set():
    sheet = locomotion.LocomotionTask(nca=NCA, body="sheet")
    assert sheet.robot_physics.scene.timing(3) == (1.0, 0.25)  # a 3D robot, 2D times
    assert sheet.robot_physics.replace(settle_time=None, measured_time=None,
                                       settle_rest=None) == sheet.physics
    assert fresh_task(body="sheet").robot_physics.scene.timing(3) == (0.01, 0.25)
    assert locomotion.LocomotionTask(nca=NCA).robot_physics == Physics()  # a grid: unchanged


def test_a_body_is_part_of_the_task_configuration():
    task = fresh_task(body="sheet")
    config = task.to_config()
    assert config["body"] == "sheet"
    assert locomotion.LocomotionTask.from_config(config) == task
    older = {k: v for k, v in TASK.to_config().items() if k != "body"}
    assert locomotion.LocomotionTask.from_config(older).body == "grid"
    with pytest.raises(ValueError, match="unknown body 'plate'; choose one of grid, sheet"):
        fresh_task(body="plate")
    with pytest.raises(ValueError, match="a sheet body lays a 2D pattern flat; this NCA is 3D"):
        locomotion.LocomotionTask(nca=NCAConfig(dim=3, kind="ff"), body="sheet")


def test_a_sheet_run_described_before_the_settle_rest_keeps_the_full_settle():
    """Physics format 5 had no settle rest: a sheet run written then resumes with the full
    settle it was started with; a grid run's physics reads unchanged."""
    for body, rest in (("sheet", 0.0), ("grid", None)):
        config = fresh_task(body=body).to_config()
        config["physics"]["format"] = 5
        del config["physics"]["scene"]["settle_rest"]
        assert locomotion.LocomotionTask.from_config(config).physics.scene.settle_rest == rest
    assert fresh_task(body="sheet").robot_physics.scene.settle_rest == 1e-6  # today's


def test_the_fitness_rule_can_be_the_other_dimension():
    robot = np.zeros((5, 5, 3), dtype=np.int8)
    robot[1:4, 1:4, 1] = Material.MUSCLE_PLUS
    walked = simulate(robot, physics=QUICK, duration=0.02)
    assert locomotion_fitness(walked, rule=2) == walked.distance
    assert locomotion_fitness(walked) == locomotion_fitness(walked, rule=3) == pytest.approx(
        walked.distance - VOXEL_COST * 9)
    with pytest.raises(ValueError, match="no locomotion fitness rule for dimension 4"):
        locomotion_fitness(walked, rule=4)


def test_the_score_of_several_starts_is_their_mean_unless_one_is_unstable():
    import dataclasses

    from mjregen.physics.simulation import simulate_starts

    robot = np.zeros((5, 5, 3), dtype=np.int8)
    robot[1:4, 1:4, 1] = Material.MUSCLE_PLUS
    walks = simulate_starts(robot, physics=QUICK, duration=0.02, starts=range(3))
    assert len({w.distance for w in walks}) == 3  # the starts differ
    for rule in (2, 3):
        assert starts_fitness(walks, rule=rule) == pytest.approx(
            np.mean([locomotion_fitness(w, rule=rule) for w in walks]), rel=1e-15)
    fallen = [walks[0], dataclasses.replace(walks[1], stable=False, reason="NaN"), walks[2]]
    assert starts_fitness(fallen) == UNSTABLE_FITNESS[3]
    assert starts_fitness(fallen, rule=2) == UNSTABLE_FITNESS[2]
