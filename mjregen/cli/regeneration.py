"""The regen command: evolve a regrowth NCA for a damaged robot, then measure recovery."""

from __future__ import annotations

import argparse
from pathlib import Path

from mjregen.cli.common import (
    add_ga_arguments,
    add_physics_arguments,
    add_run_folder_arguments,
    ga_config,
    physics_from_args,
    print_json,
    seed,
)
from mjregen.errors import MjregenError
from mjregen.resources import PAPER_ROBOTS


def add_regen(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "regen",
        help="evolve an NCA that regrows a damaged robot, and measure locomotion recovery",
        description="Damage a robot (default: the paper's cut of its left side), evolve a second "
        "NCA that regrows it from the damaged state (fitness: cells equal to the original, as "
        "in the paper), then walk the original, damaged and regrown robots and write "
        "recovery.md/.json (the paper's Table 1), robots.png, regrowth.png and videos into "
        "--out, beside the usual run files (config.json, metrics.csv, best/, checkpoint.npz).",
    )
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--robot", type=Path, help="the original robot (.npy grid)")
    source.add_argument("--checkpoint", type=Path, help="an NCA (.npz) that grows the original")
    source.add_argument("--paper", choices=PAPER_ROBOTS, help="a robot of the paper (the "
                        "biped from the CA state the paper's code saved; the tripod and the "
                        "multiped with alpha 1 on their voxels)")
    source.add_argument("--replay", type=Path, metavar="NCA",
                        help="instead of evolving: regrow the robot that a regrowth NCA "
                        "(regrowth.npz of a run, or a shipped one) records, from the damage it "
                        "records, and walk the three robots (no --out needed)")
    parser.add_argument("--damage", help="cells removed, e.g. 'x < 4' (default: the paper's cut, "
                        "x below the grid centre), or 'seed': every cell but the paper's seed, so "
                        "that the NCA grows the robot from the seed (its regrowth.npz, given to "
                        "--checkpoint, then grows the robot and regrows it from its grown state)")
    parser.add_argument("--net", choices=("ff", "lstm"), help="regrowth NCA (default ff)")
    add_ga_arguments(parser, preset_help="GA preset (default: regen, the paper's)")
    parser.add_argument("--seed", type=seed, default=0, help="seed of the GA (default 0)")
    add_physics_arguments(parser)
    add_run_folder_arguments(parser, resume_help="continue the run in --out (same arguments)",
                             out_required=False)
    parser.add_argument("--no-video", action="store_true", help="skip the three videos")
    parser.add_argument("--json", action="store_true", help="print the recovery report as JSON")
    parser.set_defaults(handler=_regen, renders=True)


def _regen(args: argparse.Namespace) -> int:
    from mjregen.experiments.regrowth import regrowth_source, run_regrowth
    from mjregen.figures import regrowth_figures
    from mjregen.video import walk_videos

    physics = physics_from_args(args)  # the walking settings, checked before the GA runs
    if args.replay is not None:
        given = [flag for flag, value in (
            ("--out", args.out), ("--damage", args.damage), ("--net", args.net),
            ("--preset", args.preset), ("--pop", args.pop), ("--gens", args.gens),
            ("--truncation", args.truncation), ("--elites", args.elites),
            ("--sigma", args.sigma), ("--resume", args.resume or None),
            ("--force", args.force or None))
            if value is not None]
        if given:
            raise MjregenError(f"--replay regrows and walks what the NCA file records, with no "
                               f"run folder or GA: {', '.join(given)} would be ignored")
        return _replay(args, physics)
    if args.out is None:
        raise MjregenError("--out is required (the run folder), except with --replay")
    source = regrowth_source(robot=args.robot, checkpoint=args.checkpoint, paper=args.paper)
    run = run_regrowth(source=source, out=args.out, damage=args.damage, net=args.net or "ff",
                       ga=ga_config(args, "regen"), seed=args.seed, physics=physics,
                       duration=args.duration, resume=args.resume, force=args.force,
                       progress=not args.quiet)
    regrowth_figures(run.robots, run.regrowth.states[0], args.out)
    if not args.no_video:
        walk_videos(run.robots, args.out, physics=physics, duration=args.duration,
                    progress=not args.quiet)
    if args.json:
        print_json(run.report.to_dict())
    else:
        print(run.report.to_markdown(Path(source.label).stem))
        print(f"run folder {args.out}")
    return 0


def _replay(args: argparse.Namespace, physics) -> int:
    from mjregen.experiments.regrowth import replay_regrowth

    replay = replay_regrowth(args.replay, physics=physics, duration=args.duration)
    distance = replay.report.distance
    if args.json:
        print_json({"nca": str(args.replay), "robot": replay.metadata.get("robot"),
                          "damage": replay.metadata.get("damage"),
                          "similarity": replay.similarity,
                          "recorded_similarity": replay.metadata.get("similarity"),
                          "distance": distance, "report": replay.report.to_dict()})
    else:
        print(replay.report.to_markdown(str(replay.metadata.get("robot", "robot"))))
    return 0
