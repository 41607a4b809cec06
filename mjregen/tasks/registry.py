"""Every task by the name its configuration carries (a run folder's config.json "task"
entry, written by the task's ``to_config``)."""

from __future__ import annotations

from mjregen.tasks.grow_regrow import GrowRegrowTask
from mjregen.tasks.locomotion import LocomotionTask
from mjregen.tasks.regrowth import RegrowthTask

Task = LocomotionTask | GrowRegrowTask | RegrowthTask
TASKS: dict[str, type[Task]] = {"locomotion": LocomotionTask, "grow-regrow": GrowRegrowTask,
                                "regrowth": RegrowthTask}


def task_from_config(config: dict) -> Task:
    """The task a "task" entry describes (descriptions of older formats migrate as each
    task's ``from_config`` reads them).

    Raises:
      ValueError: not a task description, or an unknown task.
      KeyError: an entry is missing.
    """
    if not isinstance(config, dict):
        raise ValueError(f"a task description is a JSON object, got {type(config).__name__}")
    name = config.get("task")
    if name not in TASKS:
        raise ValueError(f"unknown task {name!r}; mjregen has {', '.join(TASKS)}")
    return TASKS[name].from_config(config)
