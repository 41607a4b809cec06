#!/usr/bin/env python3
"""Run every experiment of docs/results.md: the four evolution conditions (2D/3D x
feed-forward/LSTM, several runs each), then regrowth of three diverse evolved 3D walkers
after the paper's cut, with their locomotion recovery.

At ``--scale paper`` (the default) this is the paper's full protocol: 2D population 300 x
500 generations x 10 runs, 3D 100 x 300 x 24, regrowth 1000 x 1000 with both networks
(about 300 CPU-hours, a week on two cores; use --only and several machines, or Ray via
`mjregen evolve --backend ray`). ``--scale quick`` is the reduced scale of the shipped results (about 75 minutes
on two cores); ``--scale smoke`` takes seconds. --pop/--gens/--runs override the scale.

Everything is resumable: run the same command again after a kill and every run continues
where it stopped (finished runs are left alone). Run folders: runs/results/<condition>/seed_<n>
and runs/results/regen_<walker>_<net>/seed_<n> (`mjregen.experiments.paper`). --dry-run prints the
equivalent `mjregen` commands and the amount of work without running anything.

Examples:
  python scripts/paper_experiments.py --dry-run
  python scripts/paper_experiments.py --scale quick --workers 2
  python scripts/paper_experiments.py --scale quick --only 3d_ff --only 3d_lstm
  python scripts/paper_experiments.py --scale quick --only regen

Afterwards: python scripts/ship_assets.py --best --walkers && python scripts/results_report.py
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from mjregen.errors import MjregenError
from mjregen.experiments import paper as ex
from mjregen.experiments import regrowth
from mjregen.experiments import walkers as wk
from mjregen.figures import regrowth_figures
from mjregen.search.runs import RunFolderError

STAGES = tuple(ex.CONDITIONS) + ("regen",)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description="Run (or resume) every experiment of docs/results.md at a scale.",
        epilog="example: python scripts/paper_experiments.py --scale quick --workers 2")
    parser.add_argument("--scale", choices=sorted(ex.SCALES), default="paper",
                        help="paper (default), quick (the shipped results) or smoke (tests)")
    parser.add_argument("--only", action="append", choices=STAGES, metavar="STAGE",
                        help=f"run only this condition or 'regen' (repeatable; one of "
                             f"{', '.join(STAGES)})")
    parser.add_argument("--pop", type=int, help="evolution population (overrides the scale)")
    parser.add_argument("--gens", type=int, help="evolution generations (overrides the scale)")
    parser.add_argument("--runs", type=int, help="runs per condition (overrides the scale)")
    parser.add_argument("--regen-pop", type=int, help="regrowth population")
    parser.add_argument("--regen-gens", type=int, help="regrowth generations")
    parser.add_argument("--regen-net", action="append", choices=ex.NETS,
                        help="regrowth network (repeatable; default: the scale's)")
    parser.add_argument("--workers", type=int, default=1,
                        help="simulation processes per evolution (default 1: serial)")
    parser.add_argument("--root", type=Path, default=ex.DEFAULT_ROOT,
                        help=f"results folder (default {ex.DEFAULT_ROOT})")
    parser.add_argument("--dry-run", action="store_true",
                        help="print the commands and the amount of work; run nothing")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    return parser


def plan(args: argparse.Namespace) -> tuple[list[ex.EvolutionJob], bool]:
    """(evolution jobs, whether the regrowth stage runs)."""
    scale = ex.SCALES[args.scale]
    stages = args.only or list(STAGES)
    conditions = [s for s in stages if s in ex.CONDITIONS]
    jobs = ex.evolution_jobs(scale, root=args.root, conditions=conditions, population=args.pop,
                             generations=args.gens, runs=args.runs) if conditions else []
    return jobs, "regen" in stages


def describe(args: argparse.Namespace, jobs: list[ex.EvolutionJob], regen: bool) -> str:
    """The dry-run text: scale, commands, work."""
    scale = ex.SCALES[args.scale]
    lines = [f"# scale {scale.name}: {scale.description}"]
    if args.pop or args.gens or args.runs:
        lines.append(f"# overrides: pop {args.pop}, gens {args.gens}, runs {args.runs}")
    cpu = 0.0
    for job in jobs:
        cpu += job.evaluations() * ex.CPU_PER_EVALUATION[job.condition.dim]
        lines.append(job.command(workers=args.workers))
    if jobs:
        evaluations = sum(j.evaluations() for j in jobs)
        lines.append(f"# evolutions: {len(jobs)} runs, {evaluations} evaluations, roughly "
                     f"{cpu / 3600:.1f} CPU-h at ~{ex.CPU_PER_EVALUATION[2]:g} CPU-s per 2D and "
                     f"~{ex.CPU_PER_EVALUATION[3]:g} per 3D evaluation (about "
                     f"{cpu / 3600 / max(args.workers, 1):.1f} h wall with {args.workers} "
                     "worker(s))")
    if regen:
        walkers = wk.walkers_folder(args.root) / "walkers.json"
        if walkers.is_file():
            for job in regrowth.regen_jobs(scale, wk.load_or_pick_walkers(args.root), root=args.root,
                                     population=args.regen_pop, generations=args.regen_gens,
                                     nets=tuple(args.regen_net) if args.regen_net else None):
                lines.append(job.command())
        else:
            ga = ex.scaled_ga(ex.PRESETS["regen"], args.regen_pop or scale.regen_population,
                              args.regen_gens or scale.regen_generations)
            nets = args.regen_net or scale.regen_nets or ["the walker's own"]
            lines.append(f"# regrowth: after the 3D evolutions, three walkers are picked into "
                         f"{walkers.parent} (mjregen.experiments.walkers.pick_walkers), then per walker "
                         f"and network ({', '.join(nets)}):")
            lines.append(f"mjregen regen --checkpoint {walkers.parent}/walker_<i>.npz --net <net> "
                         f"--pop {ga.population} --gens {ga.generations} --truncation "
                         f"{ga.truncation} --elites {ga.elites} --sigma {ga.sigma:g} --seed 0 "
                         f"--no-video --out {args.root}/regen_walker_<i>_<net>/seed_0")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    jobs, regen = plan(args)
    if args.dry_run:
        print(describe(args, jobs, regen))
        return 0
    start = time.perf_counter()
    for i, job in enumerate(jobs, start=1):
        print(f"[{i}/{len(jobs)}] {job.command(workers=args.workers)}", flush=True)
        try:
            summary = ex.run_evolution_job(job, workers=args.workers, progress=not args.quiet)
        except RunFolderError as error:
            raise MjregenError(f"{error} (a run started before mjregen's physics defaults or the "
                               "scale changed cannot be resumed: use another --root)") from None
        print(f"    best fitness {summary.best_fitness:.4f} (generation {summary.best_generation})"
              f", {time.perf_counter() - start:.0f} s so far", flush=True)
    if regen:
        scale = ex.SCALES[args.scale]
        walkers = wk.load_or_pick_walkers(args.root)
        print(f"walkers: {', '.join(w['name'] + ' = ' + w['run'] + ' gen ' + str(w['generation']) for w in walkers)}")
        for job in regrowth.regen_jobs(scale, walkers, root=args.root, population=args.regen_pop,
                                 generations=args.regen_gens,
                                 nets=tuple(args.regen_net) if args.regen_net else None):
            print(job.command(), flush=True)
            run = regrowth.run_regen_job(job, progress=not args.quiet)
            if run is not None:
                regrowth_figures(run.robots, run.regrowth.states[0], job.out)
    print(f"done in {time.perf_counter() - start:.0f} s; next: python scripts/ship_assets.py "
          f"--root {args.root} --best --walkers && python scripts/results_report.py --root {args.root}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.workers < 1:
        print("paper_experiments: error: --workers must be >= 1", file=sys.stderr)
        return 2
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    try:
        return run(args)
    except (MjregenError, OSError, ValueError) as error:
        print(f"paper_experiments: error: {error}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
