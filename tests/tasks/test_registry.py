"""One registry of tasks: every task is rebuilt from the description it writes."""

import json

import numpy as np
import pytest

from mjregen.growth.nca import NCA, NCAConfig
from mjregen.growth.networks import random_genomes
from mjregen.physics import Physics
from mjregen.search.backends import SerialBackend
from mjregen.tasks.grow_regrow import GrowRegrowTask
from mjregen.tasks.locomotion import LocomotionTask
from mjregen.tasks.regrowth import RegrowthTask, paper_cut, state_of_growth
from mjregen.tasks.registry import TASKS, task_from_config


def regrowth_task(kind: str = "lstm") -> RegrowthTask:
    config = NCAConfig(dim=3, kind=kind)
    original = NCA(config, random_genomes(config, 1, seed=6, std=0.5)[0]).grow()
    return RegrowthTask(nca=config, original=original.grids[0],
                        damaged=paper_cut(state_of_growth(original)),
                        provenance={"source": "a test", "damage": "paper"})


@pytest.mark.parametrize("task", [
    LocomotionTask(nca=NCAConfig(dim=2), physics=Physics().replace(settle_time=0.1), starts=2),
    GrowRegrowTask(nca=NCAConfig(dim=3), cell_cost=0.25, regrown_weight=0.5),
    regrowth_task(),
], ids=lambda task: type(task).__name__)
def test_every_task_is_rebuilt_from_the_json_it_writes(task):
    description = json.loads(json.dumps(task.to_config()))
    rebuilt = task_from_config(description)
    assert type(rebuilt) is TASKS[description["task"]] is type(task)
    assert rebuilt.to_config() == task.to_config()


def test_a_rebuilt_regrowth_task_scores_as_the_original():
    task = regrowth_task()
    rebuilt = task_from_config(json.loads(json.dumps(task.to_config())))
    genomes = random_genomes(task.nca, 4, seed=2)
    first, second = task.evaluate(genomes, SerialBackend()), rebuilt.evaluate(genomes, SerialBackend())
    assert np.array_equal(first.fitness, second.fitness)
    assert np.array_equal(first.grids, second.grids)
    assert rebuilt.provenance == {"source": "a test", "damage": "paper"}


def test_unknown_tasks_and_grids_that_do_not_fit_are_refused():
    with pytest.raises(ValueError, match="unknown task 'swimming'"):
        task_from_config({"task": "swimming"})
    with pytest.raises(ValueError, match="JSON object"):
        task_from_config(["locomotion"])
    description = regrowth_task().to_config()
    description["original"] = np.zeros((7, 7, 7), dtype=int).tolist()
    with pytest.raises(ValueError, match="original has shape"):
        task_from_config(description)
