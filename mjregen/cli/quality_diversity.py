"""`mjregen evolve --optimizer map-elites`: its arguments, its run and its gallery."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mjregen.cli.common import (
    physics_from_args,
    print_json,
    refuse_other_settings,
    task_settings,
)
from mjregen.errors import MjregenError
from mjregen.tasks.starts import DEFAULT_STARTS

GA_ONLY = ("preset", "truncation", "elites")  # GA settings MAP-Elites has no use for
SIGMA = {2: 0.03, 3: 0.1}  # the paper's GA mutation per --dim


def add_map_elites_arguments(parser: argparse.ArgumentParser) -> None:
    """The MAP-Elites settings of `mjregen evolve`."""
    from mjregen.tasks.descriptors import DESCRIPTORS

    group = parser.add_argument_group("MAP-Elites (with --optimizer map-elites)")
    names = ", ".join(f"{name} ({d.summary})" for name, d in DESCRIPTORS.items())
    group.add_argument("--descriptors", type=_names,
                       help=f"behaviour descriptors, comma separated (default voxels,muscle): "
                            f"{names}")
    group.add_argument("--cells", type=_counts,
                       help="cells per descriptor, comma separated, or one number for all "
                            "(default: one per value for counts up to 20 values, else 20; "
                            "10 for fractions)")
    group.add_argument("--emitter", choices=("gaussian", "iso-line"),
                       help="how elites are mutated: sigma*N(0, I) ('gaussian', the default) "
                            "or plus a step along the line to another elite ('iso-line')")
    group.add_argument("--emitters", type=int, help="emitters sharing --pop (default 4)")
    group.add_argument("--line-sigma", type=float,
                       help="iso-line emitters' step along the line (default 0.2)")
    group.add_argument("--no-gallery", action="store_true",
                       help="skip gallery.png (rendered elites; needs OpenGL)")


def _names(text: str) -> tuple[str, ...]:
    from mjregen.tasks.descriptors import check_descriptors

    try:
        return check_descriptors(part.strip() for part in text.split(",") if part.strip())
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _counts(text: str) -> tuple[int, ...]:
    try:
        counts = tuple(int(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"cells are whole numbers, comma separated; got "
                                         f"{text!r}") from None
    if any(c < 1 for c in counts):
        raise argparse.ArgumentTypeError(f"cells must be >= 1, got {text!r}")
    return counts


def stored_optimizer(out: Path) -> str | None:
    """The optimizer of the run in `out` from its config.json ("ga", "map-elites"), None
    when there is none (read as plain JSON: nothing may import MuJoCo before the command
    has chosen its OpenGL backend)."""
    try:
        config = json.loads((out / "config.json").read_text())
    except (OSError, ValueError):
        return None
    return "map-elites" if isinstance(config, dict) and "map_elites" in config else "ga"


def optimizer(args: argparse.Namespace) -> str:
    """The search this command runs: --optimizer, else the resumed run's, else the GA.

    Raises:
      MjregenError: --optimizer names another search than the resumed run's.
    """
    stored = stored_optimizer(args.out) if args.resume else None
    if args.optimizer and stored and args.optimizer != stored:
        raise MjregenError(f"{args.out} holds a {stored} run; it cannot continue as "
                           f"--optimizer {args.optimizer}")
    return args.optimizer or stored or "ga"


def draws_gallery(args: argparse.Namespace) -> bool:
    """Whether the command renders (MAP-Elites' gallery.png)."""
    if args.no_gallery:
        return False
    try:
        return optimizer(args) == "map-elites"
    except MjregenError:
        return False  # the command reports it


def run_map_elites_command(args: argparse.Namespace) -> int:
    """`mjregen evolve --optimizer map-elites`: the search, then gallery.png."""
    from mjregen.experiments.locomotion import map_elites_locomotion
    from mjregen.search.backends import make_backend

    given = [f"--{name}" for name in GA_ONLY if getattr(args, name) is not None]
    if given:
        raise MjregenError(f"{', '.join(given)} set the GA; MAP-Elites takes --pop (genomes "
                           "per iteration), --gens (iterations) and --sigma")
    if args.resume:
        task, config, seed = _stored_run(args)
        nca, physics, duration = task.nca, task.physics, task.duration
        starts, start_seed = task.starts, task.start_seed
    else:
        nca, config, seed = _new_run(args)
        physics, duration = physics_from_args(args), args.duration
        starts = DEFAULT_STARTS if args.starts is None else args.starts
        start_seed = seed
    with make_backend(args.backend, workers=args.workers, address=args.address) as backend:
        summary = map_elites_locomotion(out=args.out, nca=nca, config=config, seed=seed,
                                        backend=backend, physics=physics, duration=duration,
                                        starts=starts, start_seed=start_seed,
                                        resume=args.resume, force=args.force,
                                        progress=not args.quiet)
    gallery = None
    if not args.no_gallery:
        from mjregen.figures import elite_gallery
        from mjregen.search.qd_runs import read_archive

        try:
            archive = read_archive(summary.out / "archive.npz")
            gallery = elite_gallery(archive.snapshot, archive.descriptors,
                                    summary.out / "gallery.png", physics=physics,
                                    overwrite=True)
        except ValueError as error:  # nothing with voxels in the archive
            print(f"mjregen: no gallery: {error}", file=sys.stderr)
    result = {"out": str(summary.out), "iterations": summary.iterations,
              "best_fitness": summary.best_fitness, "qd_score": summary.qd_score,
              "coverage": summary.coverage, "elites": summary.elites,
              "gallery": None if gallery is None else str(gallery)}
    if args.json:
        print_json(result)
    else:
        print(f"best fitness {summary.best_fitness:.4f}, QD score {summary.qd_score:.1f}, "
              f"{summary.elites} elites ({summary.coverage:.1%} of the cells); run folder "
              f"{summary.out}")
    return 0


def _new_run(args: argparse.Namespace) -> tuple:
    """NCA, MAP-Elites settings and seed of a new run from the command line."""
    from mjregen.growth.nca import NCAConfig
    from mjregen.search.map_elites import MapElitesConfig
    from mjregen.tasks.descriptors import default_cells

    dim = args.dim or 3
    nca = NCAConfig(dim=dim, kind=args.net or "ff")
    descriptors = args.descriptors or ("voxels", "muscle")
    cells = args.cells or default_cells(descriptors, (nca.grid_size,) * dim)
    if len(cells) == 1:
        cells = cells * len(descriptors)
    if args.line_sigma is not None and (args.emitter or "gaussian") != "iso-line":
        raise MjregenError("--line-sigma sets the iso+line emitter's line step; add "
                           "--emitter iso-line")
    try:
        config = MapElitesConfig(
            iterations=300 if args.gens is None else args.gens,
            batch=100 if args.pop is None else args.pop,
            emitters=4 if args.emitters is None else args.emitters,
            sigma=SIGMA[dim] if args.sigma is None else args.sigma,
            line_sigma=0.2 if args.line_sigma is None else args.line_sigma,
            emitter=args.emitter or "gaussian", descriptors=descriptors, cells=cells)
    except ValueError as error:
        raise MjregenError(str(error)) from None
    return nca, config, 0 if args.seed is None else args.seed


def _stored_run(args: argparse.Namespace) -> tuple:
    """Task, MAP-Elites settings and seed of the run in ``args.out``; flags given must
    agree."""
    from mjregen.experiments.locomotion import stored_map_elites_run

    task, config, seed = stored_map_elites_run(args.out)
    cells = args.cells
    if cells is not None and len(cells) == 1:
        cells = cells * len(config.descriptors)
    refuse_other_settings(args.out, {
        "pop": (args.pop, config.batch), "gens": (args.gens, config.iterations),
        "sigma": (args.sigma, config.sigma), "seed": (args.seed, seed),
        "emitters": (args.emitters, config.emitters), "emitter": (args.emitter, config.emitter),
        "line-sigma": (args.line_sigma, config.line_sigma),
        "descriptors": (args.descriptors, config.descriptors), "cells": (cells, config.cells),
        **task_settings(args, task)})
    return task, config, seed
