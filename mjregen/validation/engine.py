"""The paper's engine, Voxelyze as the paper's code runs it, as a user's folder holds it.

mjregen ships no engine: a folder given by the user holds it with its runner ``vxa.py``,
which provides ``run(grid) -> {"distance": voxel lengths, "cpu_s": ...}`` (one run with the
paper's settings), ``vxa_text(grid, folder)`` (the robot written into the paper's settings)
and ``ENGINES["O3"]`` (the optimised engine binary).
"""

from __future__ import annotations

import functools
import importlib.util
import os
import re
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import numpy as np

from mjregen.errors import MjregenError
from mjregen.grid import Robot
from mjregen.physics.params import PAPER_TIMES

PAPER_DT_FRACTION = 0.9  # the paper's step, as a fraction of the engine's own rule (DtFrac)


@functools.cache
def _runner(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location("vxa", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@dataclass(frozen=True)
class PaperEngine:
    """The engine in `folder` (its ``vxa.py``).

    Raises:
      MjregenError: `folder` holds no ``vxa.py``.
    """

    folder: Path

    def __post_init__(self) -> None:
        object.__setattr__(self, "folder", Path(self.folder).resolve())
        if not (self.folder / "vxa.py").is_file():
            raise MjregenError(f"{self.folder} holds no vxa.py: give the folder of the "
                               "paper's engine and its runner")

    @property
    def runner(self) -> ModuleType:
        """The folder's ``vxa.py`` as a module (imported once per folder)."""
        return _runner(self.folder / "vxa.py")

    def run(self, grid: np.ndarray) -> dict:
        """One run with the paper's settings: {"distance": voxel lengths, "cpu_s": the
        engine's CPU seconds, ...} (the runner's answer).

        Raises:
          MjregenError: the runner failed.
        """
        try:
            return self.runner.run(np.asarray(grid))
        except Exception as error:  # the runner is the user's code: any failure is its
            raise MjregenError(f"the paper's engine ({self.folder / 'vxa.py'}) failed: "
                               f"{type(error).__name__}: {error}") from error

    def distance(self, robot: Robot, *, times: tuple[float, float] | None = None
                 ) -> float | None:
        """The distance the engine walks `robot` (voxel lengths); None for a 2D robot (one
        in the x-z plane: the engine runs 3D grids).

        Args:
          times: (settle, measured) s; None or the paper's 3D (0.05, 0.5) = the runner's
            own run, otherwise `run_window` at the paper's step fraction 0.9 (a sheet:
            the paper's 2D times, (1.0, 0.25)).
        Raises:
          MjregenError: the runner failed or gave no distance.
        """
        if robot.dim != 3:
            return None
        if times is not None and tuple(times) != PAPER_TIMES[3]:
            settle, measured = times
            return self.run_window(robot.grid, dt_fraction=PAPER_DT_FRACTION,
                                   stop=settle + measured, measure_from=settle)["distance"]
        answer = self.run(robot.grid)
        try:
            return float(answer["distance"])
        except (KeyError, TypeError, ValueError) as error:
            raise MjregenError(f"the paper's engine ({self.folder / 'vxa.py'}) gave no "
                               f"distance: {answer!r}") from error

    def run_window(self, grid: np.ndarray, *, dt_fraction: float, stop: float,
                   measure_from: float, settings: dict[str, float] | None = None) -> dict:
        """One run of the optimised engine with its step at `dt_fraction` of its own
        stability rule (the paper's 0.9), `stop` s simulated and the distance measured from
        `measure_from` s: {"distance": voxel lengths, "cpu_s": the engine process's CPU s,
        "dy": voxel lengths, the distance's y component, "on_floor": voxels touching the
        floor at the end (each None when the engine did not write it)}.
        `settings`: other elements of the paper's settings set to other values, by tag (e.g.
        ``{"SelfColEnabled": 0}``: no self-collision).

        Raises:
          MjregenError: the settings' template lacks one of those elements, or the engine
            wrote no distance.
        """
        with tempfile.TemporaryDirectory() as folder:
            folder = Path(folder)
            text = self.runner.vxa_text(np.asarray(grid), folder)
            for tag, value in (("DtFrac", dt_fraction), ("StopConditionValue", stop),
                               ("InitCmTime", measure_from), *(settings or {}).items()):
                text, count = re.subn(rf"<{tag}>[^<]*</{tag}>", f"<{tag}>{value!r}</{tag}>",
                                      text)
                if count != 1:
                    raise MjregenError(f"the engine's settings have {count} <{tag}> elements")
            (folder / "robot.vxa").write_text(text)
            process = subprocess.Popen([str(self.runner.ENGINES["O3"]), "-f",
                                        str(folder / "robot.vxa")], stdout=subprocess.DEVNULL,
                                       stderr=subprocess.DEVNULL, cwd=folder)
            _, status, usage = os.wait4(process.pid, 0)  # it exits with 1 after a normal run
            written = folder / "fitness.xml"
            fitness = written.read_text() if written.exists() else ""
        distance = _fitness_value(fitness, "NormFinalDist")
        if distance is None:
            raise MjregenError(f"the engine wrote no distance (exit status {status >> 8}) at "
                               f"DtFrac {dt_fraction}")
        return {"distance": distance, "cpu_s": usage.ru_utime + usage.ru_stime,
                "dy": _fitness_value(fitness, "finalDistY"),
                "on_floor": _fitness_value(fitness, "NumTouchingFloor")}


def _fitness_value(text: str, tag: str) -> float | None:
    """The number in the engine's fitness file `text` under `tag`, or None."""
    match = re.search(rf"<{tag}>([^<]+)</{tag}>", text)
    return None if match is None else float(match.group(1))
