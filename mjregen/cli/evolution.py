"""Commands of evolution runs: evolve (the GA or MAP-Elites), evolve-stats."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mjregen.cli.common import (
    add_ga_arguments,
    add_physics_arguments,
    add_run_folder_arguments,
    ga_config,
    physics_from_args,
    print_json,
    refuse_other_settings,
    seed,
    starts_count,
    task_settings,
    workers,
)
from mjregen.cli.quality_diversity import (
    add_map_elites_arguments,
    draws_gallery,
    optimizer,
    run_map_elites_command,
)
from mjregen.errors import MjregenError
from mjregen.tasks.starts import DEFAULT_STARTS


def add_evolve(subparsers: argparse._SubParsersAction) -> None:
    from mjregen.search import BACKENDS

    parser = subparsers.add_parser(
        "evolve",
        help="evolve NCAs for locomotion with the paper's genetic algorithm or MAP-Elites",
        description="Evolve NCAs whose grown robots walk far. Writes config.json, metrics.csv, "
        "each generation's best NCA and robot, fitness.png and a checkpoint into --out; "
        "--resume continues a killed run exactly. Settings default to the paper's preset for "
        "--dim (2d or 3d); every number can be overridden. With --optimizer map-elites: an "
        "archive of the fittest robot per cell of behaviour descriptors (--descriptors, "
        "--cells), --pop genomes per iteration for --gens iterations, mutated with the "
        "preset's sigma; the folder holds archive.npz, heatmap.png, qd.png, best.npz/.npy, "
        "gallery.png and the checkpoint.",
    )
    _add_task_arguments(parser.add_argument_group("what is evolved"))
    search = parser.add_argument_group("the GA (its preset, and numbers that override it)")
    add_ga_arguments(search, preset_help="GA preset (default: 2d or 3d by --dim)")
    scoring = parser.add_argument_group("physics and scoring")
    add_physics_arguments(scoring)
    scoring.add_argument("--starts", type=starts_count,
                         help="starts each robot walks from (every voxel moved by a seeded "
                              f"offset of --start-shift); its fitness is their mean (default "
                              f"{DEFAULT_STARTS})")
    search.add_argument("--seed", type=seed, help="seed of the GA and of the robots' starts "
                                                  "(default 0)")
    where = parser.add_argument_group("where the robots are simulated")
    where.add_argument("--backend", choices=BACKENDS, default="process",
                       help="where simulations run (default: local processes)")
    where.add_argument("--workers", type=workers, help="parallel workers (default: all cores)")
    where.add_argument("--address", help="Ray cluster address (with --backend ray)")
    folder = parser.add_argument_group("run folder and output")
    add_run_folder_arguments(folder,
                             resume_help="continue the run in --out with its stored settings")
    folder.add_argument("--json", action="store_true", help="print a JSON summary at the end")
    add_map_elites_arguments(parser)
    parser.set_defaults(handler=_evolve, renders=draws_gallery)


def _add_task_arguments(task: argparse._ArgumentGroup) -> None:
    """`evolve`'s options of what is evolved: optimiser, task, damage, network, body."""
    task.add_argument("--optimizer", choices=("ga", "map-elites"),
                      help="search: the paper's GA (the default) or MAP-Elites (ribs)")
    task.add_argument("--task", choices=("locomotion", "grow-regrow"),
                      help="what the robots are scored on: how far they walk "
                           "('locomotion', the default), or that and how well the same NCA "
                           "regrows them after --cut ('grow-regrow': fitness = locomotion "
                           "fitness - --cell-cost x wrongly regrown cells; with "
                           "--regrown-weight the regrown robot walks too)")
    task.add_argument("--cut", help="grow-regrow: the damage, 'paper' (the default: grid "
                                    "x-indices below the centre), 'half' (each robot's own "
                                    "lower half across its longest extent, which no robot "
                                    "avoids by growing elsewhere) or a half-space such as "
                                    "'z > 4'")
    task.add_argument("--cell-cost", type=float,
                      help="grow-regrow: voxel lengths of walking one wrongly regrown cell "
                           "costs (default 0.1)")
    task.add_argument("--regrown-weight", type=float,
                      help="grow-regrow: the regrown robot's share of the locomotion "
                           "fitness, in [0, 1] (default 0: it does not walk; 0.5: the "
                           "grown and the regrown robot count alike)")
    task.add_argument("--dim", type=int, choices=(2, 3), help="2D or 3D robots (default 3)")
    task.add_argument("--net", choices=("ff", "lstm"), help="NCA network (default ff)")
    task.add_argument("--body", choices=("grid", "sheet"),
                      help="how a grown grid becomes the robot: 'grid' (the default: the grid "
                           "itself; a 2D one moves in the x-z plane) or 'sheet' (--dim 2: the "
                           "pattern lies flat on the floor as one layer of voxels and walks in "
                           "3D for the 2D times, as the paper's 2D robots do)")


def _evolve(args: argparse.Namespace) -> int:
    from mjregen.search.backends import make_backend
    from mjregen.search.runs import run_evolution

    if args.backend == "serial" and args.workers is not None:
        raise MjregenError("--workers sets the process, thread or ray backend's workers; "
                           "--backend serial runs one evaluation at a time")
    if optimizer(args) == "map-elites":
        if args.task not in (None, "locomotion") or args.cut or _regrowth_flags(args):
            raise MjregenError("MAP-Elites searches the locomotion task only")
        if args.body == "sheet":
            raise MjregenError("--body sheet: MAP-Elites searches grown grids only")
        return run_map_elites_command(args)
    given = [flag for flag, value in (("--descriptors", args.descriptors), ("--cells", args.cells),
                                      ("--emitter", args.emitter), ("--emitters", args.emitters),
                                      ("--line-sigma", args.line_sigma)) if value is not None]
    if given:
        raise MjregenError(f"{', '.join(given)} set MAP-Elites; add --optimizer map-elites")
    task, ga, seed = _stored_run(args) if args.resume else _new_run(args)
    with make_backend(args.backend, workers=args.workers, address=args.address) as backend:
        summary = run_evolution(task, ga, seed=seed, out=args.out, backend=backend,
                                resume=args.resume, force=args.force, progress=not args.quiet)
    if args.json:
        print_json({"out": str(summary.out), "generations": summary.generations,
                    "best_fitness": summary.best_fitness,
                    "best_generation": summary.best_generation})
    else:
        print(f"best fitness {summary.best_fitness:.4f} in generation {summary.best_generation}; "
              f"run folder {summary.out}")
    return 0


def _new_run(args: argparse.Namespace) -> tuple:
    """Task, GA settings and seed of a new run from the flags (defaults: the preset of
    --dim, feed-forward, the locomotion task on grown grids)."""
    from mjregen.growth.nca import NCAConfig
    from mjregen.tasks.grow_regrow import GrowRegrowTask
    from mjregen.tasks.locomotion import LocomotionTask

    dim = args.dim or 3
    ga, seed = ga_config(args, f"{dim}d"), (0 if args.seed is None else args.seed)
    nca = NCAConfig(dim=dim, kind=args.net or "ff")
    common = dict(nca=nca, physics=physics_from_args(args), duration=args.duration,
                  starts=DEFAULT_STARTS if args.starts is None else args.starts,
                  start_seed=seed)
    regrowth = _regrowth_objective(args, nca)
    body = args.body or "grid"
    if body == "sheet" and (dim != 2 or regrowth is not None):
        raise MjregenError("--body sheet lays a 2D pattern flat: it needs --dim 2 and the "
                           "locomotion task")
    if regrowth is not None:
        return GrowRegrowTask(**common, **regrowth), ga, seed
    return LocomotionTask(**common, body=body), ga, seed


def _regrowth_flags(args: argparse.Namespace) -> list[str]:
    """The grow-regrow flags given."""
    return [flag for flag, value in (("--cut", args.cut), ("--cell-cost", args.cell_cost),
                                     ("--regrown-weight", args.regrown_weight))
            if value is not None]


def _regrowth_objective(args: argparse.Namespace, nca) -> dict | None:
    """--cut, --cell-cost and --regrown-weight of a new grow-regrow run of `nca` (an
    NCAConfig), None for the locomotion task."""
    if args.task != "grow-regrow":
        if _regrowth_flags(args):
            raise MjregenError(f"{', '.join(_regrowth_flags(args))}: grow-regrow settings; "
                               "add --task grow-regrow")
        return None
    from mjregen.tasks.grow_regrow import PAPER_CUT, GrowRegrowTask

    objective = {"cut": args.cut or PAPER_CUT,
                 "cell_cost": 0.1 if args.cell_cost is None else args.cell_cost,
                 "regrown_weight": 0.0 if args.regrown_weight is None else args.regrown_weight}
    try:
        GrowRegrowTask(nca=nca, **objective)
    except ValueError as error:
        raise MjregenError(f"grow-regrow: {error}") from None
    return objective


def _stored_run(args: argparse.Namespace) -> tuple:
    """Task, GA settings and seed of the run in ``args.out``; flags given must agree."""
    from mjregen.experiments.locomotion import stored_locomotion_run
    from mjregen.tasks.grow_regrow import GrowRegrowTask

    task, ga, seed = stored_locomotion_run(args.out)
    regrows = isinstance(task, GrowRegrowTask)
    refuse_other_settings(args.out, {
        "task": (args.task, "grow-regrow" if regrows else "locomotion"),
        "cut": (args.cut, task.cut if regrows else None),
        "cell-cost": (args.cell_cost, task.cell_cost if regrows else None),
        "regrown-weight": (args.regrown_weight, task.regrown_weight if regrows else None),
        "pop": (args.pop, ga.population), "gens": (args.gens, ga.generations),
        "truncation": (args.truncation, ga.truncation), "elites": (args.elites, ga.elites),
        "sigma": (args.sigma, ga.sigma), "seed": (args.seed, seed),
        **task_settings(args, task)})
    return task, ga, seed


def _compare_finals(group_args: list[list[str]], column: str, groups: dict):
    """The two groups' runs compared at the last generation every run reached."""
    from mjregen.search.compare import compare_groups
    from mjregen.search.stats import read_curve

    last = min(len(stats.generations) for stats in groups.values()) - 1
    finals = [[read_curve(run, column)[last] for run in runs] for _, *runs in group_args]
    return compare_groups(*finals)


def add_evolve_stats(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "evolve-stats",
        help="mean best fitness (MAP-Elites: QD score and coverage) with bootstrapped 95%% "
             "CIs over several runs; two groups are compared by exact tests",
        description="Plot the mean (over runs) of metrics.csv columns per generation (MAP-Elites: "
        "iteration), with bootstrapped 95% confidence bands (the runs' range for groups of "
        "fewer than 5 runs, where a bootstrap covers far less), one curve per group. Default "
        "columns: best for GA runs or mixed groups, qd_score and coverage when every run is a "
        "MAP-Elites run. With two groups, each run's value at the last generation all reached "
        "is compared by an exact Mann-Whitney U test and a permutation test of the means, with "
        "the smallest p the groups' sizes allow (3 runs against 2 cannot reach p < 0.2). "
        "Example: mjregen evolve-stats --group ff runs/ff_* --group lstm "
        "runs/lstm_* --out curves.png",
    )
    parser.add_argument("--group", nargs="+", action="append", required=True,
                        metavar=("LABEL", "RUN"), help="a label and its run folders")
    parser.add_argument("--column", action="append",
                        help="metrics.csv column (repeatable; default: see above)")
    parser.add_argument("--out", type=Path, required=True, help="PNG to write")
    parser.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    parser.add_argument("--json", action="store_true", help="print the curves as JSON")
    parser.set_defaults(handler=_evolve_stats)


def _check_stats_request(args: argparse.Namespace) -> None:
    """MjregenError for an --out that is not a .png (or exists without --force), a group
    without runs, or a label given twice."""
    from mjregen.errors import OutputExistsError

    if args.out.suffix.lower() != ".png":
        raise MjregenError(f"--out {args.out}: the curves are written as PNG; name a .png file")
    if args.out.exists() and not args.force:
        raise OutputExistsError(args.out)
    for label, *runs in args.group:
        if not runs:
            raise MjregenError(f"group {label!r} names no run folders")
    labels = [label for label, *_ in args.group]
    repeated = sorted({label for label in labels if labels.count(label) > 1})
    if repeated:
        raise MjregenError(f"group label(s) {', '.join(map(repr, repeated))} given more than "
                           "once: each --group needs its own label")


def _evolve_stats(args: argparse.Namespace) -> int:
    from mjregen.search.stats import (
        group_stats,
        is_map_elites_run,
        plot_panels,
        run_kind,
    )

    _check_stats_request(args)
    kinds = {label: run_kind(runs[0]) for label, *runs in args.group}
    if len(set(kinds.values())) > 1:
        raise MjregenError("the groups evolved for different tasks, whose fitnesses do not "
                           f"compare: {', '.join(f'{g} ({k})' for g, k in kinds.items())}")
    every_run = [run for _, *runs in args.group for run in runs]
    quality_diversity = all(is_map_elites_run(run) for run in every_run)
    columns = args.column or (["qd_score", "coverage"] if quality_diversity else ["best"])
    panels = {column: {label: group_stats(runs, column) for label, *runs in args.group}
              for column in columns}
    for label, stats in panels[columns[0]].items():
        if stats.truncated:
            print(f"note: group {label!r} cut to its shortest run, {len(stats.generations)} "
                  f"generations (runs have {', '.join(map(str, stats.run_lengths))})",
                  file=sys.stderr)
    plot_panels(panels, args.out, xlabel="iteration" if quality_diversity else "generation")
    comparisons = {column: _compare_finals(args.group, column, groups)
                   for column, groups in panels.items()} if len(args.group) == 2 else {}
    if args.json:
        curves = {column: {label: {"runs": s.n_runs, "mean": s.mean.tolist(),
                                   "low": s.low.tolist(), "high": s.high.tolist(),
                                   "band": s.band}
                           for label, s in groups.items()} for column, groups in panels.items()}
        for column, comparison in comparisons.items():
            curves[column]["comparison"] = {
                "sizes": list(comparison.sizes), "means": list(comparison.means),
                "u": comparison.u, "p_mann_whitney": comparison.p_mann_whitney,
                "p_permutation": comparison.p_permutation,
                "smallest_p": comparison.smallest_p, "exact": comparison.exact}
        print_json(curves[columns[0]] if len(columns) == 1 else curves)
    else:
        for column, groups in panels.items():
            for label, s in groups.items():
                print(f"{label}: {s.n_runs} run{'s' if s.n_runs > 1 else ''}, final mean "
                      f"{column} {s.mean[-1]:.4f} [{s.low[-1]:.4f}, {s.high[-1]:.4f}] "
                      f"({s.band})")
        for column, comparison in comparisons.items():
            labels = tuple(label for label, *_ in args.group)
            print(f"{column} at the last generation all reached: {comparison.sentence(labels)}")
        print(f"wrote {args.out}")
    return 0
