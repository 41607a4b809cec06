"""Commands of evolution runs: evolve, evolve-stats."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mjregen.cli.common import (
    add_ga_arguments,
    add_physics_arguments,
    add_run_folder_arguments,
    ga_config,
    physics_from_args,
    seed,
    workers,
)
from mjregen.errors import MjregenError


def add_evolve(subparsers: argparse._SubParsersAction) -> None:
    from mjregen.search import BACKENDS

    parser = subparsers.add_parser(
        "evolve",
        help="evolve NCAs for locomotion with the paper's genetic algorithm",
        description="Evolve NCAs whose grown robots walk far. Writes config.json, metrics.csv, "
        "each generation's best NCA and robot, fitness.png and a checkpoint into --out; "
        "--resume continues a killed run exactly. Settings default to the paper's preset for "
        "--dim (2d or 3d); every number can be overridden.",
    )
    parser.add_argument("--task", choices=("locomotion",), default="locomotion",
                        help="what the robots are scored on (the only task: locomotion)")
    parser.add_argument("--dim", type=int, choices=(2, 3), help="2D or 3D robots (default 3)")
    parser.add_argument("--net", choices=("ff", "lstm"), help="NCA network (default ff)")
    add_ga_arguments(parser, preset_help="GA preset (default: 2d or 3d by --dim)")
    add_physics_arguments(parser)
    parser.add_argument("--seed", type=seed, help="seed of the GA (default 0)")
    parser.add_argument("--backend", choices=BACKENDS, default="process",
                        help="where simulations run (default: local processes)")
    parser.add_argument("--workers", type=workers, help="parallel workers (default: all cores)")
    parser.add_argument("--address", help="Ray cluster address (with --backend ray)")
    add_run_folder_arguments(parser, resume_help="continue the run in --out with its stored settings")
    parser.add_argument("--json", action="store_true", help="print a JSON summary at the end")
    parser.set_defaults(handler=_evolve)


def _evolve(args: argparse.Namespace) -> int:
    from mjregen.experiments.locomotion import evolve_locomotion
    from mjregen.growth.nca import NCAConfig
    from mjregen.search.backends import make_backend

    if args.resume:
        task, ga, seed = _stored_run(args)
        nca, physics, duration = task.nca, task.physics, task.duration
    else:
        dim = args.dim or 3
        ga, seed = ga_config(args, f"{dim}d"), (0 if args.seed is None else args.seed)
        nca = NCAConfig(dim=dim, kind=args.net or "ff")
        physics, duration = physics_from_args(args), args.duration
    with make_backend(args.backend, workers=args.workers, address=args.address) as backend:
        summary = evolve_locomotion(out=args.out, nca=nca, ga=ga, seed=seed, backend=backend,
                                    physics=physics, duration=duration, resume=args.resume,
                                    force=args.force, progress=not args.quiet)
    if args.json:
        print(json.dumps({"out": str(summary.out), "generations": summary.generations,
                          "best_fitness": summary.best_fitness,
                          "best_generation": summary.best_generation}))
    else:
        print(f"best fitness {summary.best_fitness:.4f} in generation {summary.best_generation}; "
              f"run folder {summary.out}")
    return 0


def _stored_run(args: argparse.Namespace) -> tuple:
    """Task, GA settings and seed of the run in ``args.out``; flags given must agree."""
    from mjregen.experiments.locomotion import stored_locomotion_run

    task, ga, seed = stored_locomotion_run(args.out)
    given = {"dim": (args.dim, task.nca.dim), "net": (args.net, task.nca.kind),
             "pop": (args.pop, ga.population), "gens": (args.gens, ga.generations),
             "truncation": (args.truncation, ga.truncation), "elites": (args.elites, ga.elites),
             "sigma": (args.sigma, ga.sigma), "seed": (args.seed, seed),
             "duration": (args.duration, task.duration),
             "settle": (args.settle, task.physics.scene.settle_time),
             "bonds": (args.bonds, getattr(task.physics.pipeline, "bond_element", None)),
             "timestep-rule": (args.timestep_rule, task.physics.pipeline.timestep_rule)}
    if args.physics is not None and physics_from_args(args) != task.physics:
        given["physics"] = (args.physics, "other physics")
    conflicts = [f"--{k} {v} (run has {s})" for k, (v, s) in given.items() if v is not None and v != s]
    if conflicts:
        raise MjregenError(f"{args.out} was started with other settings: {', '.join(conflicts)}")
    return task, ga, seed


def add_evolve_stats(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "evolve-stats",
        help="mean best fitness with bootstrapped 95%% CIs over several runs",
        description="Plot the mean (over runs) of a metrics.csv column per generation, with a "
        "bootstrapped 95% confidence band, one curve per group. Example: "
        "mjregen evolve-stats --group ff runs/ff_* --group lstm runs/lstm_* --out curves.png",
    )
    parser.add_argument("--group", nargs="+", action="append", required=True,
                        metavar=("LABEL", "RUN"), help="a label and its run folders")
    parser.add_argument("--column", default="best", help="metrics.csv column (default best)")
    parser.add_argument("--out", type=Path, required=True, help="PNG to write")
    parser.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    parser.add_argument("--json", action="store_true", help="print the curves as JSON")
    parser.set_defaults(handler=_evolve_stats)


def _evolve_stats(args: argparse.Namespace) -> int:
    from mjregen.errors import OutputExistsError
    from mjregen.search.stats import group_stats, plot_groups, run_kind

    if args.out.exists() and not args.force:
        raise OutputExistsError(args.out)
    groups = {}
    for label, *runs in args.group:
        if not runs:
            raise MjregenError(f"group {label!r} names no run folders")
        groups[label] = group_stats(runs, args.column)
    kinds = {label: run_kind(runs[0]) for label, *runs in args.group}
    if len(set(kinds.values())) > 1:
        raise MjregenError("the groups evolved for different tasks, whose fitnesses do not "
                           f"compare: {', '.join(f'{g} ({k})' for g, k in kinds.items())}")
    for label, stats in groups.items():
        if stats.truncated:
            print(f"note: group {label!r} cut to its shortest run, {len(stats.generations)} "
                  f"generations (runs have {', '.join(map(str, stats.run_lengths))})",
                  file=sys.stderr)
    plot_groups(groups, args.out, ylabel=args.column)
    if args.json:
        print(json.dumps({label: {"runs": s.n_runs, "mean": s.mean.tolist(), "low": s.low.tolist(),
                                  "high": s.high.tolist()} for label, s in groups.items()}))
    else:
        for label, s in groups.items():
            print(f"{label}: {s.n_runs} runs, final mean {s.mean[-1]:.4f} "
                  f"[{s.low[-1]:.4f}, {s.high[-1]:.4f}]")
        print(f"wrote {args.out}")
    return 0
