"""The paper's engine, Voxelyze as the paper's code runs it, as a user's folder holds it.

mjregen ships no engine: a folder given by the user holds it with its runner ``vxa.py``,
which writes a robot into the paper's settings, runs the engine and, as a command
(``python vxa.py ROBOT.npy``), prints ``{"distance": voxel lengths, ...}`` as JSON.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mjregen.errors import MjregenError
from mjregen.grid import Robot


@dataclass(frozen=True)
class PaperEngine:
    """The engine in `folder` (its ``vxa.py``).

    Raises:
      MjregenError: `folder` holds no ``vxa.py``.
    """

    folder: Path

    def __post_init__(self) -> None:
        object.__setattr__(self, "folder", Path(self.folder))
        if not (self.folder / "vxa.py").is_file():
            raise MjregenError(f"{self.folder} holds no vxa.py: give the folder of the "
                               "paper's engine and its runner")

    def distance(self, robot: Robot) -> float | None:
        """The distance the engine walks `robot` (voxel lengths, its settle and walk: the
        paper's 3D evaluation); None for a 2D robot (the engine runs 3D grids).

        Raises:
          MjregenError: the runner failed or printed no distance.
        """
        if robot.dim != 3:
            return None
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "robot.npy"
            np.save(path, np.asarray(robot.grid))
            done = subprocess.run([sys.executable, str(self.folder / "vxa.py"), str(path)],
                                  capture_output=True, text=True, check=False)
        try:
            if done.returncode:
                raise ValueError(f"exit status {done.returncode}: {done.stderr.strip()[-300:]}")
            return float(json.loads(done.stdout)["distance"])
        except (ValueError, KeyError, TypeError) as error:
            raise MjregenError(f"the paper's engine ({self.folder / 'vxa.py'}) gave no "
                               f"distance: {error}") from None
