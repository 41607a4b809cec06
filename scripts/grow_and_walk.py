#!/usr/bin/env python3
"""Grow a soft voxel robot with a neural cellular automaton, compile it to MuJoCo, walk it.

With no arguments it grows the robot of the NCA shipped in assets/nca/ (see its README),
prints every growth step, simulates the walk (the paper's settle and measured time, today's
default physics, from a symmetry-broken start; --recorded-physics walks a shipped NCA with the
physics its evolution recorded in assets/nca/manifest.json instead) and writes into the
output folder (default ./grow_and_walk_out):

  robot.npy     the grown robot (mjregen robot file)
  robot.xml     its MuJoCo model (loads in plain MuJoCo)
  growth.png    the grid at every growth step and after cleaning (not with --robot)
  walk.mp4      the walk, in slow motion (not with --no-video)
  summary.json  source, distance, fitness, voxels, settings

Examples:
  python scripts/grow_and_walk.py
  python scripts/grow_and_walk.py --seed 3 --dim 2 --out runs/random2d
  python scripts/grow_and_walk.py --robot assets/robots/paper/tripod.npy --duration 0.25

Headless: rendering picks EGL, then OSMesa (or MUJOCO_GL when set). Existing output files
are never replaced unless --force. Exit status 1 with one error line for problems a user
can cause (missing or bad files, existing outputs, no renderer).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mjregen.errors import MjregenError
from mjregen.fileio import atomic_open
from mjregen.grid import Robot
from mjregen.physics import Physics
from mjregen.resources import asset

if TYPE_CHECKING:
    from mjregen.render import View

DEFAULT_NCA = asset("nca", "walker_3d.npz")
OUTPUTS = ("robot.npy", "robot.xml", "growth.png", "walk.mp4", "summary.json")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description="Grow a robot with an NCA, walk it in MuJoCo, save robot, model, growth "
        "figure and video. Without arguments: the NCA shipped in assets/nca.",
        epilog="example: python scripts/grow_and_walk.py --seed 3 --dim 2 --out runs/random2d")
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--nca", type=Path, help=f"NCA checkpoint (.npz); default {DEFAULT_NCA.name}"
                        " from assets/nca")
    source.add_argument("--robot", type=Path, help="walk this robot file (.npy) instead of growing one")
    source.add_argument("--seed", type=int, help="grow with a random NCA (the paper's initial "
                        "genes) from this seed")
    parser.add_argument("--dim", type=int, choices=(2, 3),
                        help="dimension of a random NCA (default 3); with a file it must match")
    parser.add_argument("--duration", type=float,
                        help="s of walking measured (default: the paper's, 3D 0.5, 2D 0.25)")
    parser.add_argument("--recorded-physics", action="store_true",
                        help="walk a shipped NCA with the physics its evolution scored it with "
                             "(assets/nca/manifest.json; older entries: the exact start) "
                             "instead of today's default")
    parser.add_argument("--out", type=Path, default=Path("grow_and_walk_out"),
                        help="output folder (default ./grow_and_walk_out)")
    parser.add_argument("--force", action="store_true", help="replace existing output files")
    video = parser.add_argument_group("video")
    video.add_argument("--no-video", action="store_true", help="do not render walk.mp4")
    video.add_argument("--width", type=int, default=480, help="pixels (even, default 480)")
    video.add_argument("--height", type=int, default=360, help="pixels (even, default 360)")
    video.add_argument("--fps", type=int, default=30, help="frames per second (default 30)")
    video.add_argument("--slowdown", type=float, default=10.0,
                       help="times slower than real time (default 10)")
    return parser


def _load_source(args: argparse.Namespace) -> tuple[Robot, np.ndarray | None, str, Physics]:
    """(robot, growth states ``(T, *grid)`` or None, description of the source, `Physics`):
    the physics is the default, or with --recorded-physics, for a shipped NCA, the one it was
    evolved and recorded with (its entry in the folder's manifest.json)."""
    if args.recorded_physics and (args.robot is not None or args.seed is not None):
        raise MjregenError("--recorded-physics replays a shipped NCA (--nca or the default), "
                           "not --robot or --seed")
    if args.robot is not None:
        robot = Robot.load(args.robot)
        _check_dim(args.dim, robot.dim, args.robot)
        return robot, None, f"robot file {args.robot}", Physics()
    from mjregen.growth.checkpoint import load_nca  # torch: only when growing
    from mjregen.growth.nca import NCA, NCAConfig

    physics = Physics()
    if args.seed is not None:
        dim = args.dim or 3
        nca = NCA.random(NCAConfig(dim=dim), seed=args.seed)
        source = f"random {dim}D NCA, seed {args.seed}"
    else:
        path = args.nca or DEFAULT_NCA
        nca, _ = load_nca(path)
        _check_dim(args.dim, nca.config.dim, path)
        source = f"NCA checkpoint {path}"
        recorded = _recorded_physics(path) if args.recorded_physics else None
        if args.recorded_physics and recorded is None:
            raise MjregenError(f"--recorded-physics: {path} has no entry in a manifest.json "
                               "beside it")
        if recorded is not None:
            physics = recorded
            source += (f" (walked with its recorded physics: {physics.pipeline.name} "
                       f"pipeline, {getattr(physics.pipeline, 'bond_element', 'tendons')} bonds)")
    growth = nca.grow()
    return growth.robot(), np.asarray(growth.states[0]), source, physics


def _recorded_physics(path: Path) -> Physics | None:
    """The physics a shipped NCA was evaluated with (assets manifest), or None."""
    manifest = path.with_name("manifest.json")
    if not manifest.is_file():
        return None
    entry = json.loads(manifest.read_text()).get(path.name, {})
    recorded = entry.get("evaluation", {}).get("physics")
    return Physics.from_dict(recorded) if recorded is not None else None


def _check_dim(wanted: int | None, actual: int, path: Path) -> None:
    if wanted is not None and wanted != actual:
        raise MjregenError(f"--dim {wanted} does not match {path}, which is {actual}D")


def _print_growth(states: np.ndarray) -> None:
    for step, state in enumerate(states):
        print(f"--- growth step {step} ---")
        print(Robot(state).to_text())


def _checked_view(args: argparse.Namespace) -> View | None:
    """The video's `View` (None with --no-video), once --out holds none of the outputs (or
    --force) and the video's numbers are valid: bad input fails before any work."""
    from mjregen.render import View

    wanted = [name for name in OUTPUTS if not (args.no_video and name == "walk.mp4")]
    existing = [name for name in wanted if (args.out / name).exists()]
    if existing and not args.force:
        raise MjregenError(f"{args.out} already holds {', '.join(existing)}; pass --force to "
                           "replace them or choose another --out")
    if args.no_video:
        return None
    view = View(width=args.width, height=args.height)
    if args.fps < 1 or not args.slowdown > 0:
        raise MjregenError("--fps must be >= 1 and --slowdown > 0")
    return view


def _write_robot(out: Path, robot: Robot, states: np.ndarray | None, *, overwrite: bool) -> None:
    """robot.npy, and growth.png from the growth's `states` (steps, *grid) when it grew."""
    from mjregen.figures import growth_figure

    out.mkdir(parents=True, exist_ok=True)
    robot.save(out / "robot.npy", overwrite=overwrite)
    if states is not None:
        titles = [f"step {k}" for k in range(len(states))] + ["cleaned"]
        growth_figure(np.concatenate([states, robot.grid[None]]), out / "growth.png",
                      overwrite=overwrite, titles=titles)


def run(args: argparse.Namespace) -> dict:
    """Grow, compile, walk and write the outputs; returns the summary."""
    from mjregen.render import select_gl_backend

    out: Path = args.out
    view = _checked_view(args)
    robot, states, source, physics = _load_source(args)
    if view is not None:  # a missing renderer fails before the simulation
        print(f"rendering with MUJOCO_GL={select_gl_backend()}")

    from mjregen.physics.compile import compile_robot
    from mjregen.physics.simulation import simulate
    from mjregen.render import record_walk
    from mjregen.tasks.fitness import locomotion_fitness
    from mjregen.video import write_video

    print(f"source: {source}")
    if states is not None:
        _print_growth(states)
        print("--- after cleaning ---")
        print(robot.to_text())
    _write_robot(out, robot, states, overwrite=args.force)
    if robot.is_empty:
        raise MjregenError(f"{source} grew an empty robot: nothing to walk (robot.npy and "
                           "growth.png are written)")
    compiled = compile_robot(robot, physics=physics)
    with atomic_open(out / "robot.xml", "w", overwrite=args.force) as handle:
        handle.write(compiled.to_xml())
    result = simulate(robot, physics=physics, duration=args.duration)
    print(f"walked: distance {result.distance:.4f} voxel lengths, fitness {locomotion_fitness(result):.4f}, "
          f"{result.n_voxels} voxels" + ("" if result.stable else f", UNSTABLE ({result.reason})"))
    summary = {"source": source, "voxels": result.n_voxels, "distance": result.distance,
               "fitness": locomotion_fitness(result), "stable": result.stable, "reason": result.reason,
               "sim_time": result.sim_time, "timestep": result.timestep,
               "duration": args.duration, "bond_element": getattr(physics.pipeline, "bond_element", "tendons"),
               "files": ["robot.npy", "robot.xml"]}
    if states is not None:
        summary["files"].append("growth.png")
    if view is not None:
        walk = record_walk(compiled, duration=args.duration, fps=args.fps, slowdown=args.slowdown)
        write_video(compiled, walk.qpos, out / "walk.mp4", fps=args.fps, view=view,
                    overwrite=args.force)
        summary.update(video={"frames": len(walk.qpos), "width": args.width,
                              "height": args.height, "fps": args.fps,
                              "slowdown": args.slowdown})
        summary["files"].append("walk.mp4")
    summary["files"].append("summary.json")
    with atomic_open(out / "summary.json", "w", overwrite=args.force) as handle:
        json.dump(summary, handle, indent=2)
    print(f"wrote {', '.join(summary['files'])} to {out}")
    return summary


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        run(args)
    except (MjregenError, OSError, ValueError) as error:
        print(f"grow_and_walk: error: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
