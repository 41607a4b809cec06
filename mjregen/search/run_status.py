"""The state of run folders, for whoever watches long evolutions: how far each run has come,
whether a process runs it now, and about how long it has left."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from mjregen.search.run_folder import RunProgress, is_run_folder, read_progress
from mjregen.search.run_lock import holder_of

METHODS = {"generation": "GA", "iteration": "MAP-Elites"}  # metrics.csv's step column -> method


@dataclass(frozen=True)
class RunStatus:
    """One run folder's state.

    Attributes:
      folder: the run folder.
      progress: its steps done and planned, their wall time and the best fitness.
      holder: the live process that runs it now, described; None when none does.
      resumable: it holds a checkpoint.npz to continue from.
    """

    folder: Path
    progress: RunProgress
    holder: str | None
    resumable: bool

    @property
    def method(self) -> str:
        return METHODS[self.progress.counter]

    @property
    def state(self) -> str:
        """One of finished, running (a process holds the folder) or stopped."""
        if self.progress.complete:
            return "finished"
        return "running" if self.holder is not None else "stopped"

    @property
    def hours_left(self) -> float:
        """Wall time (h) the steps not done would take at the pace of those done: NaN for a
        run with none done, 0 for a finished one."""
        progress = self.progress
        if progress.complete:
            return 0.0
        if not progress.done:
            return math.nan
        return progress.elapsed / progress.done * (progress.planned - progress.done) / 3600


def find_run_folders(paths: list[Path]) -> list[Path]:
    """The run folders among `paths` and under them (at any depth), each once, sorted."""
    found: set[Path] = set()
    for path in paths:
        if is_run_folder(path):
            found.add(path)
        found.update(config.parent for config in path.rglob("config.json")
                     if is_run_folder(config.parent))
    return sorted(found)


def run_status(folder: Path) -> RunStatus:
    """`RunStatus` of the run in `folder`.

    Raises:
      RunFolderError: its config.json or metrics.csv cannot be read.
    """
    return RunStatus(folder=folder, progress=read_progress(folder), holder=holder_of(folder),
                     resumable=(folder / "checkpoint.npz").is_file())
