"""The regen command: evolve a regrowth NCA for a damaged robot, then measure recovery."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from mjregen.cli.common import (
    add_ga_arguments,
    add_physics_arguments,
    add_run_folder_arguments,
    ga_config,
    physics_from_args,
    seed,
)
from mjregen.errors import MjregenError
from mjregen.resources import asset

PAPER_ROBOTS = asset("robots", "paper")


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
    source.add_argument("--paper", choices=("biped", "tripod", "multiped"), help="a robot of the paper")
    parser.add_argument("--damage", help="cells removed, e.g. 'x < 4' (default: the paper's cut, "
                        "x below the grid centre)")
    parser.add_argument("--net", choices=("ff", "lstm"), help="regrowth NCA (default ff)")
    add_ga_arguments(parser, preset_help="GA preset (default: regen, the paper's)")
    parser.add_argument("--seed", type=seed, default=0, help="seed of the GA (default 0)")
    add_physics_arguments(parser)
    add_run_folder_arguments(parser, resume_help="continue the run in --out (same arguments)")
    parser.add_argument("--no-video", action="store_true", help="skip the three videos")
    parser.add_argument("--json", action="store_true", help="print the recovery report as JSON")
    parser.set_defaults(handler=_regen, renders=True)


def _original(args: argparse.Namespace):
    """(original robot, its cleaned CA state, where it came from)."""
    from mjregen.checkpoint import load_nca
    from mjregen.grid import Robot
    from mjregen.nca import NCAConfig
    from mjregen.regen import state_of_growth, state_of_robot

    if args.checkpoint is not None:
        nca, _ = load_nca(args.checkpoint)
        growth = nca.grow()
        return growth.robot(), state_of_growth(growth), str(args.checkpoint)
    path = args.robot if args.robot is not None else PAPER_ROBOTS / f"{args.paper}.npy"
    robot = Robot.load(path)
    config = NCAConfig(dim=robot.dim, kind="ff")
    if robot.shape != config.grid_shape:
        raise MjregenError(f"{path}: regrowth needs the NCA grid {config.grid_shape}, got {robot.shape}")
    return robot, state_of_robot(robot, config), str(path)


def _regen(args: argparse.Namespace) -> int:
    from mjregen.figures import growth_figure
    from mjregen.grid import Robot
    from mjregen.nca import CAState, NCAConfig
    from mjregen.parallel import SerialBackend
    from mjregen.recovery import measure_recovery, write_report
    from mjregen.regen import RegrowthTask, cut_half_space, paper_cut
    from mjregen.runs import run_evolution

    physics = physics_from_args(args)  # the walking settings, checked before the GA runs
    original, state, source = _original(args)
    damaged_state = paper_cut(state) if args.damage is None else cut_half_space(state, args.damage)
    config = NCAConfig(dim=original.dim, kind=args.net or "ff")
    ga = ga_config(args, "regen")
    task = RegrowthTask(nca=config, original=np.asarray(original.grid),
                        damaged=CAState(damaged_state.state, damaged_state.alpha, None))
    task_config = {
        "task": "regrowth", "nca": config.to_dict(), "source": source,
        "damage": args.damage or "paper cut",
        "original": original.grid.tolist(),
        "damaged_state": damaged_state.state[0].tolist(),
        "damaged_alpha": damaged_state.alpha[0].tolist(),
    }
    summary = run_evolution(task, ga, seed=args.seed, out=args.out, backend=SerialBackend(),
                            task_config=task_config, resume=args.resume, force=args.force,
                            progress=not args.quiet)
    regrowth = task.regrow(summary.best_genome)
    robots = {
        "original": original,
        "damaged": Robot(damaged_state.state[0].numpy().astype(np.int8)).cleaned(),
        "regrown": regrowth.robot(),
    }
    for role, robot in robots.items():
        robot.save(args.out / f"{role}.npy", overwrite=True)
    growth_figure(regrowth.states[0], args.out / "regrowth.png", overwrite=True,
                  titles=[f"regrowth step {i}" for i in range(len(regrowth.states[0]))])
    growth_figure(np.stack([robots[r].grid for r in robots]), args.out / "robots.png", overwrite=True,
                  titles=[f"{role}: {robot.n_voxels} voxels" for role, robot in robots.items()])
    report = measure_recovery(robots, physics=physics, duration=args.duration)
    name = args.paper or Path(source).stem
    write_report(report, args.out, name=name)
    if not args.no_video:
        _videos(robots, physics, args)
    if args.json:
        print(json.dumps(report.to_dict()))
    else:
        print(report.to_markdown(name))
        print(f"run folder {args.out}")
    return 0


def _videos(robots: dict, physics, args: argparse.Namespace) -> None:
    from mjregen.physics.compile import compile_robot
    from mjregen.render import record_walk, write_video

    for role, robot in robots.items():
        if robot.is_empty:
            continue
        compiled = compile_robot(robot, physics=physics)
        walk = record_walk(compiled, duration=args.duration)
        write_video(compiled, walk.qpos, args.out / f"{role}.mp4", overwrite=True, progress=not args.quiet)
