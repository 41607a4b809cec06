"""The paper's engine (a folder with its ``vxa.py``, as in benchmarks/speed.py) run on an
mjregen grid with a chosen time-step fraction and window, for the accuracy study.

``vxa.py`` writes a robot into the paper's own settings (``vxa_text(grid, out_dir)``) and
names the optimised engine binary (``ENGINES["O3"]``); here the text's ``DtFrac`` (the
engine's step as a fraction of its own stability rule, 0.9 in the paper), the simulated
time and the start of the distance measurement are replaced before it runs.
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import tempfile
from pathlib import Path

import numpy as np


def load_vxa(folder: Path):
    """The engine folder's ``vxa.py`` as a module."""
    spec = importlib.util.spec_from_file_location("vxa", Path(folder) / "vxa.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run_engine(vxa, grid: np.ndarray, *, dt_fraction: float, stop: float, measure_from: float
               ) -> dict:
    """{"distance": voxel lengths from `measure_from` s to `stop` s, "cpu_s": the engine
    process's CPU seconds} of one engine run."""
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        text = vxa.vxa_text(np.asarray(grid), folder)
        for tag, value in (("DtFrac", dt_fraction), ("StopConditionValue", stop),
                           ("InitCmTime", measure_from)):
            text, count = re.subn(rf"<{tag}>[^<]*</{tag}>", f"<{tag}>{value!r}</{tag}>", text)
            if count != 1:
                raise RuntimeError(f"the engine's template has {count} <{tag}> elements")
        (folder / "robot.vxa").write_text(text)
        process = subprocess.Popen([str(vxa.ENGINES["O3"]), "-f", str(folder / "robot.vxa")],
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                   cwd=folder)
        _, status, usage = os.wait4(process.pid, 0)  # it exits with 1 after a normal run
        fitness = (folder / "fitness.xml").read_text() if (folder / "fitness.xml").exists() \
            else ""
        match = re.search(r"<NormFinalDist>([^<]+)</NormFinalDist>", fitness)
        if match is None:
            raise RuntimeError(f"the engine wrote no distance (exit status {status >> 8}) at "
                               f"DtFrac {dt_fraction}")
        return {"distance": float(match.group(1)), "cpu_s": usage.ru_utime + usage.ru_stime}
