"""Where a generation's wall time goes on each backend: one real generation of a run, taken
from its checkpoint, evaluated serially and on 2 threads (and 2 processes), job by job.

    python benchmarks/generation_phases.py RUN_FOLDER [RUN_FOLDER ...]
        [--backends serial thread process] [--rounds 2] [--json out.json]
    python benchmarks/generation_phases.py --markdown out.json

RUN_FOLDER holds a GA run's ``checkpoint.npz`` (a locomotion task): the population its next
generation evaluates is bred again from it, bit for bit. Each round evaluates it on each
backend, the backend started and warmed up first, with an empty robot cache, as in a run:
  growth     the NCA growth of the population (the driver, before any simulation)
  map        the backend's walk of the distinct robots (compile and simulate each)
  jobs       per robot: its worker, start and end (wall) and CPU time (its thread's; on
             processes the worker's thread)
From these: the workers' idle time inside the map (the generation's tail, and any wait
between jobs), and each job's wall / CPU (above 1 on threads: waiting for the GIL or for a
core). Medians over the rounds; every backend must give the serial fitnesses.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mjregen.growth.nca import grow
from mjregen.search.backends import Backend, Outcome, make_backend
from mjregen.search.ga import GeneticAlgorithm
from mjregen.search.run_folder import load_checkpoint, read_config
from mjregen.tasks.evaluation import RobotEvaluation, RobotJob, evaluate_robot
from mjregen.tasks.locomotion import LocomotionTask


@dataclass(frozen=True)
class JobTime:
    """One robot's evaluation: its worker (process and thread ids), wall start and end
    (s, ``time.time``: comparable across processes), CPU s of its thread and the robot's
    voxels."""

    worker: str
    start: float
    end: float
    cpu: float
    voxels: int


def timed_evaluation(job: RobotJob) -> tuple[RobotEvaluation, JobTime]:
    """`evaluate_robot` of `job` and its `JobTime` (a module function: processes pickle it)."""
    wall, cpu = time.time(), time.thread_time()
    result = evaluate_robot(job)
    return result, JobTime(f"{os.getpid()}:{threading.get_ident()}", wall, time.time(),
                           time.thread_time() - cpu, int(np.count_nonzero(job.grid)))


class RecordingBackend(Backend):
    """Runs `evaluate_robot` jobs on `inner` as `timed_evaluation` and keeps their times
    (``maps``: wall start, wall end and the jobs' times of each map call)."""

    def __init__(self, inner: Backend) -> None:
        super().__init__(inner.workers)
        self.inner = inner
        self.maps: list[tuple[float, float, list[JobTime]]] = []

    def map(self, fn: Callable, items: Sequence[RobotJob]) -> list[Outcome]:
        if fn is not evaluate_robot:
            raise ValueError("only evaluate_robot jobs are recorded")
        start = time.time()
        outcomes = self.inner.map(timed_evaluation, items)
        end = time.time()
        self.maps.append((start, end, [o.value[1] for o in outcomes if o.ok]))
        return [replace(o, value=o.value[0]) if o.ok else o for o in outcomes]


def population(folder: Path) -> tuple[LocomotionTask, np.ndarray, int]:
    """(the run's task, the genomes of its next generation, that generation's number)."""
    config = read_config(folder / "config.json")
    task = LocomotionTask.from_config(config["task"])
    state, arrays = load_checkpoint(folder / "checkpoint.npz")
    ga = GeneticAlgorithm.from_state_dict({**state, **arrays})
    return task, ga.ask(), ga.generation


PROBE_LOOP = 3 * 10**7  # additions of the speed probe


def probe() -> float:
    """CPU s of a fixed pure-Python loop in this thread: the machine's speed at the time
    (a shared machine's cores run faster or slower from minute to minute)."""
    cpu = time.thread_time()
    sum(range(PROBE_LOOP))
    return time.thread_time() - cpu


def one_round(task: LocomotionTask, genomes: np.ndarray, name: str) -> dict:
    """One generation's evaluation on backend `name` (serial: 1 worker, else 2), after the
    speed `probe`."""
    workers = 1 if name == "serial" else 2
    speed = probe()
    with make_backend(name, workers=workers) as inner:
        replace(task).evaluate(genomes[:workers], inner)  # warm up the workers
        backend = RecordingBackend(inner)
        wall, cpu = time.perf_counter(), time.process_time()
        grids = grow(task.nca, genomes).grids
        grow_wall, grow_cpu = time.perf_counter() - wall, time.process_time() - cpu
        result = replace(task).evaluate_grids(grids, backend)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    start, end, jobs = backend.maps[0]
    by_worker: dict[str, list[JobTime]] = {}
    for job in jobs:
        by_worker.setdefault(job.worker, []).append(job)
    busy = [sum(j.end - j.start for j in own) for own in by_worker.values()]
    finishes = sorted(max(j.end for j in own) for own in by_worker.values())
    job_wall = sum(j.end - j.start for j in jobs)
    job_cpu = sum(j.cpu for j in jobs)
    return {
        "backend": name, "workers": workers, "probe_s": speed, "wall_s": wall,
        "driver_cpu_s": cpu,
        "grow_wall_s": grow_wall, "grow_cpu_s": grow_cpu, "map_wall_s": end - start,
        "jobs": len(jobs), "job_wall_s": job_wall, "job_cpu_s": job_cpu,
        "job_wall_per_cpu": job_wall / job_cpu if job_cpu else float("nan"),
        "idle_in_map_s": workers * (end - start) - sum(busy),
        "tail_s": finishes[-1] - finishes[0] if len(finishes) > 1 else 0.0,
        "after_map_s": wall - grow_wall - (end - start),
        "fitness": result.fitness.tolist(),
        "job_times": [[j.worker, round(j.start - start, 4), round(j.end - start, 4),
                       round(j.cpu, 4), j.voxels] for j in jobs],
    }


def measure(run: str, backends: list[str], rounds_: int) -> dict:
    """`rounds_` interleaved rounds of each of `backends` on the next generation of the
    run in folder `run`; medians."""
    task, genomes, generation = population(Path(run))
    rounds: dict[str, list[dict]] = {name: [] for name in backends}
    for index in range(rounds_):
        for name in backends:
            sample = one_round(task, genomes, name)
            rounds[name].append(sample)
            print(f"round {index} {name}: {sample['wall_s']:.1f} s", flush=True)
    reference = rounds[backends[0]][0]["fitness"]
    rows = []
    for name, samples in rounds.items():
        row = {key: statistics.median(s[key] for s in samples)
               for key, value in samples[0].items() if isinstance(value, float)}
        row |= {"backend": name, "workers": samples[0]["workers"], "jobs": samples[0]["jobs"],
                "wall_s_rounds": [s["wall_s"] for s in samples],
                "probe_s_rounds": [s["probe_s"] for s in samples],
                "job_times_first_round": samples[0]["job_times"],
                "same_fitness": all(s["fitness"] == reference for s in samples)}
        rows.append(row)
    return {"run": run, "generation": generation, "population": len(genomes),
            "rounds": rounds_, "rows": rows}


def markdown_section(measurements: list[dict]) -> list[str]:
    """docs/performance.md's section: one block of rows per measured generation."""
    lines = ["## Where a generation's time goes on 2 cores", "",
             "`python benchmarks/generation_phases.py RUN_FOLDER --rounds 2`: one generation "
             "of a real 3D run, bred again from its checkpoint, evaluated serially, on 2 "
             "threads and on 2 worker processes, interleaved round by round, nothing else "
             "running on the machine; medians of the rounds. Growth: the NCA growth of the "
             "population, before any walk. Idle: the workers' time without a robot inside the "
             "walks of the generation (its tail included). Jobs: each distinct robot's compile "
             "and walks, their CPU s summed, and their wall / CPU (above 1: waiting for the "
             "GIL or for a core). Probe: CPU s of a fixed pure-Python loop before each "
             "round, the machine's speed at the time. Efficiency: serial wall / (wall x "
             "workers).", "",
             "| generation | backend | wall s (rounds) | probe s (rounds) | growth s | idle s "
             "| jobs' CPU s | jobs' wall / CPU | efficiency | the serial fitnesses |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for measured in measurements:
        rows = measured["rows"]
        serial = next((r["wall_s"] for r in rows if r["backend"] == "serial"), None)
        voxels = statistics.median(j[4] for j in rows[0]["job_times_first_round"])
        run = measured.get("made", f"`{measured['run']}`")  # how the run folder was made
        label = (f"{measured['generation']} of {run} ({rows[0]['jobs']} robots walked, "
                 f"median {voxels:.0f} voxels)")
        for index, row in enumerate(rows):
            efficiency = ("—" if serial is None
                          else f"{serial / row['wall_s'] / row['workers']:.2f}")
            lines.append(
                f"| {label if index == 0 else ''} | {row['backend']} | {row['wall_s']:.1f} "
                f"({', '.join(f'{w:.1f}' for w in row['wall_s_rounds'])}) | "
                f"{', '.join(f'{p:.2f}' for p in row['probe_s_rounds'])} | "
                f"{row['grow_wall_s']:.2f} | {row['idle_in_map_s']:.2f} | {row['job_cpu_s']:.1f} | "
                f"{row['job_wall_per_cpu']:.2f} | {efficiency} | "
                f"{'yes' if row['same_fitness'] else 'no'} |")
    return lines + ["", _summary(measurements)]


def _summary(measurements: list[dict]) -> str:
    """One sentence: the parts outside the walks, and each backend's efficiency range."""
    rows = [(m, r) for m in measurements for r in m["rows"]]
    serial = {id(m): r["wall_s"] for m, r in rows if r["backend"] == "serial"}
    outside = max((r["grow_wall_s"] + r["idle_in_map_s"]) / r["wall_s"] for _, r in rows)
    parts = [f"Growth and idle workers together: at most {outside:.1%} of a generation's wall "
             f"time"]
    for backend in ("thread", "process"):
        efficiencies = [serial[id(m)] / r["wall_s"] / r["workers"] for m, r in rows
                        if r["backend"] == backend and id(m) in serial]
        if efficiencies:
            parts.append(f"{backend} efficiency {min(efficiencies):.2f}–{max(efficiencies):.2f}")
    return "; ".join(parts) + "."


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="*", help="GA run folders with a checkpoint.npz")
    parser.add_argument("--backends", nargs="+", default=["serial", "thread", "process"],
                        choices=("serial", "thread", "process"))
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--json", type=Path, help="also write the measurements here")
    parser.add_argument("--markdown", type=Path,
                        help="print docs/performance.md's section from this JSON (nothing is "
                             "measured)")
    args = parser.parse_args()
    if args.markdown:
        print("\n".join(markdown_section(json.loads(args.markdown.read_text()))))
        return
    if not args.runs:
        parser.error("name at least one run folder (or --markdown JSON)")
    measured = [measure(run, args.backends, args.rounds) for run in args.runs]
    print("\n".join(markdown_section(measured)))
    if args.json:
        args.json.write_text(json.dumps(measured))


if __name__ == "__main__":
    main()
