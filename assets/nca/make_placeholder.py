"""Re-create the placeholder walker NCA shipped in this folder (see README.md).

A short evolution with the existing GA through the Python API (`mjregen.runs.run_evolution`):
3D feed-forward NCA, population 20, 5 generations, truncation 5, 2 elites, sigma 0.1 (the 3D
preset's), seed 0, 0.2 s of walking after the paper's 0.05 s settle, 2 worker threads (the "process"
backend could not pickle `Physics` at commit 3b3d481; f10b08b fixed that).
It was stopped after generation 2 to keep a 15-minute budget; see README.md.

Usage: python assets/nca/make_placeholder.py RUN_FOLDER
The best NCA is RUN_FOLDER/best/gen_NNNN.npz of the best generation (printed at the end).
"""

import json
import sys
from pathlib import Path

from mjregen.evolve import PRESETS
from mjregen.locomotion import LocomotionTask
from mjregen.nca import NCAConfig
from mjregen.parallel import make_backend
from mjregen.runs import run_evolution

POPULATION, GENERATIONS, TRUNCATION, ELITES, SEED, DURATION = 20, 5, 5, 2, 0, 0.2


def main(out: Path) -> None:
    task = LocomotionTask(nca=NCAConfig(dim=3, kind="ff"), duration=DURATION)
    ga = PRESETS["3d"].with_overrides(population=POPULATION, generations=GENERATIONS,
                                      truncation=TRUNCATION, elites=ELITES)
    task_config = {"task": "locomotion", "nca": task.nca.to_dict(), "physics": "Physics()",
                   "duration": DURATION}
    with make_backend("thread", workers=2) as backend:
        summary = run_evolution(task, ga, seed=SEED, out=out, backend=backend,
                                task_config=task_config)
    print(json.dumps({"out": str(summary.out), "best_fitness": summary.best_fitness,
                      "best_generation": summary.best_generation}))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
