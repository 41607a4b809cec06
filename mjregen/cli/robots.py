"""Commands on single robots: grow, show."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

import numpy as np

from mjregen.cli.common import (
    add_body_argument,
    add_physics_arguments,
    add_physics_choice,
    material_counts,
    physics_from_args,
    positive,
    print_json,
    seed,
    start_index,
    starts_count,
    workers,
)
from mjregen.errors import InvalidGridError, MjregenError, OutputExistsError
from mjregen.grid import Robot


def add_grow(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "grow",
        help="grow a robot with an NCA and print it",
        description="Grow a robot with an NCA (a checkpoint, or a random NCA with the paper's "
        "initial genes N(0, 0.1^2) from --seed), print each step's voxel counts and the robot.",
    )
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--checkpoint", type=Path, help="NCA checkpoint (.npz)")
    source.add_argument("--seed", type=seed, default=0, help="seed of a random NCA (default 0)")
    parser.add_argument("--dim", type=int, choices=(2, 3),
                        help="random NCA: 2D or 3D (default 3; a checkpoint has its own)")
    parser.add_argument("--net", choices=("ff", "lstm"),
                        help="random NCA: network (default ff; a checkpoint has its own)")
    parser.add_argument("--steps", type=int, help="growth steps (default: the NCA's, 10)")
    parser.add_argument("--show-steps", action="store_true", help="print the grid after every step")
    parser.add_argument("--out", type=Path, help="save the grown robot to this .npy file")
    parser.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    parser.add_argument("--json", action="store_true", help="print JSON instead of text")
    parser.set_defaults(handler=_grow)


def _grow(args: argparse.Namespace) -> int:
    from mjregen.growth.checkpoint import load_nca
    from mjregen.growth.nca import NCA, NCAConfig

    if args.steps is not None and args.steps < 1:
        raise MjregenError(f"--steps must be at least 1, got {args.steps}")
    if args.checkpoint is not None:
        nca, _ = load_nca(args.checkpoint)
        source = str(args.checkpoint)
        given = {"--dim": (args.dim, nca.config.dim), "--net": (args.net, nca.config.kind)}
        clash = [f"{flag} {mine} (the checkpoint's: {its})"
                 for flag, (mine, its) in given.items() if mine is not None and mine != its]
        if clash:
            raise MjregenError(f"{args.checkpoint} is its own network: {', '.join(clash)}")
    else:
        dim, net = args.dim or 3, args.net or "ff"
        nca = NCA.random(NCAConfig(dim=dim, kind=net), seed=args.seed)
        source = f"random {dim}D {net} NCA, seed {args.seed}"
    growth = nca.grow(steps=args.steps)
    robot = growth.robot()
    steps = [Robot(state) for state in growth.states[0]]
    if args.out is not None:
        robot.save(args.out, overwrite=args.force)
    if args.json:
        print_json({
            "source": source,
            "config": nca.config.to_dict(),
            "steps": [{"step": i, "voxels": s.n_voxels, "materials": material_counts(s)} for i, s in enumerate(steps)],
            "robot": {"voxels": robot.n_voxels, "materials": material_counts(robot), "grid": robot.grid.tolist()},
            "out": None if args.out is None else str(args.out),
        })
        return 0
    print(f"growing: {source}")
    for i, state in enumerate(steps):
        print(f"step {i:2d}: {state.n_voxels:4d} voxels  " + "  ".join(f"{k} {v}" for k, v in material_counts(state).items()))
        if args.show_steps:
            print(state.to_text())
    print("after cleaning:")
    print(robot.to_text())
    if args.out is not None:
        print(f"saved {args.out}")
    return 0


def add_show(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "show",
        help="print a robot file as text",
        description="Print a robot (.npy grid) layer by layer, top layer first.",
    )
    parser.add_argument("robot", type=Path, help="robot file (.npy)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of text")
    parser.set_defaults(handler=_show)


def _show(args: argparse.Namespace) -> int:
    robot = Robot.load(args.robot)
    if args.json:
        print_json({
            "shape": list(robot.shape),
            "voxels": robot.n_voxels,
            "materials": material_counts(robot),
            "grid": np.asarray(robot.grid).tolist(),
        })
    else:
        print(robot.to_text())
    return 0


def add_walk(subparsers: argparse._SubParsersAction) -> None:
    from mjregen.tasks.starts import CHECK_STARTS

    parser = subparsers.add_parser(
        "walk",
        help="simulate a robot walking and print distance and fitness",
        description="Simulate a robot file (.npy): settle, actuate, measure (the paper's times "
        "unless --settle/--duration), and print the distance in voxel lengths, the paper's "
        "fitness and the stability verdict. The walk starts with every voxel moved by a "
        "seeded random offset (--start-shift, seed --start-seed and the robot), as in an "
        "evolution; --starts K walks it from K such starts and scores it as an evolution "
        "with --starts K does (the mean).",
    )
    parser.add_argument("robot", type=Path, help="robot file (.npy)")
    add_physics_arguments(parser)
    add_body_argument(parser)
    parser.add_argument("--starts", type=starts_count, metavar="K",
                        help="walk from K starts (0 .. K-1) and report their mean, min and "
                             "each distance (default 1)")
    parser.add_argument("--start-seed", type=seed,
                        help="seed of the starts (default 0; an evolution uses its seed)")
    parser.add_argument("--trajectory", type=Path, help="also write the COM trajectory (CSV: t, x, y, z in m) of the first start")
    parser.add_argument("--force", action="store_true", help="overwrite --trajectory if it exists")
    starts = parser.add_argument_group(
        "shifted starts", "Also walk the robot from the exact start (every voxel on its grid "
        "position) and compare it with N shifted starts (--shift voxel lengths, seed "
        "--start-seed), reporting the distance they keep: a robot whose shifted starts keep "
        "less than 90 % of the exact start's distance on average walks partly by that start "
        "(a body that is its own mirror image keeps its symmetry from it).")
    starts.add_argument("--shifted-starts", type=positive, metavar="N",
                        help=f"number of shifted starts (e.g. {CHECK_STARTS})")
    starts.add_argument("--shift", type=float,
                        help="voxel lengths, standard deviation of each voxel's shift "
                             "(default: --start-shift's)")
    starts.add_argument("--workers", type=workers,
                        help="threads walking the starts (default: all cores)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of text")
    parser.set_defaults(handler=_walk)


def _check_walk_request(args: argparse.Namespace, robot: Robot) -> None:
    """MjregenError for a walk that cannot or should not start: an empty robot, a trajectory
    file in the way, or flags that do not go together."""
    if robot.is_empty:
        raise MjregenError(f"{args.robot} holds an empty robot: nothing to walk")
    if args.trajectory is not None and args.trajectory.exists() and not args.force:
        raise OutputExistsError(args.trajectory)
    if args.shifted_starts is None and (args.shift, args.workers) != (None,) * 2:
        raise MjregenError("--shift and --workers are for --shifted-starts N")
    if args.shifted_starts is not None and args.starts is not None:
        raise MjregenError("choose --starts K (the score from K starts) or --shifted-starts N "
                           "(the exact start against N shifted ones), not both")
    if args.shift is not None and not (math.isfinite(args.shift) and args.shift > 0.0):
        raise MjregenError(f"--shift must be a finite number of voxel lengths > 0, "
                           f"got {args.shift!r}")


def _walk(args: argparse.Namespace) -> int:
    from mjregen.fileio import atomic_open
    from mjregen.physics.simulation import simulate_starts
    from mjregen.tasks.fitness import locomotion_fitness

    robot = Robot.load(args.robot)
    _check_walk_request(args, robot)
    robot, physics, rule = with_body(args, robot, physics_from_args(args))
    record = args.trajectory is not None
    start_seed = args.start_seed or 0
    checked = None
    if args.shifted_starts is None:
        results = simulate_starts(robot, physics=physics, duration=args.duration, record=record,
                                  start_seed=start_seed, starts=range(args.starts or 1))
        result = results[0]
    else:
        checked = _shifted_starts(robot, physics, args, record)
        result, results = checked.default, [checked.default]
    if args.trajectory is not None and result.com is not None:
        with atomic_open(args.trajectory, "w") as handle:
            handle.write("t,x,y,z\n")
            np.savetxt(handle, np.column_stack([result.times, result.com]), delimiter=",", fmt="%.9g")
    report = _walk_report(args, result, results, rule)
    if checked is not None:
        report["shifted_starts"] = {
            "starts": len(checked.indices), "shift": checked.shift, "seed": checked.seed,
            "distances": checked.distances.tolist(), "reasons": list(checked.reasons),
            "mean": checked.mean, "min": checked.low, "max": checked.high, "kept": checked.kept,
            "depends_on_start": checked.depends_on_start,
            "mirror_axes": list(checked.mirror_axes)}
    if args.json:
        print_json(report)
        return 0
    verdict = "stable" if result.stable else f"UNSTABLE ({result.reason})"
    dx, dy = result.displacement
    start = "the exact start" if checked is not None else f"start 0 (seed {start_seed})"
    print(f"{args.robot}: {result.n_voxels} voxels, from {start}: distance {result.distance:.4f} "
          f"voxel lengths (dx {dx:.4f}, dy {dy:.4f}, heading {result.heading:.1f} deg), "
          f"fitness {locomotion_fitness(result, rule=rule):.4f}, {verdict}")
    print(f"{result.steps} steps of {result.timestep:.3g} s ({result.sim_time:.3f} s simulated) "
          f"in {result.wall_time:.2f} s wall, {result.cpu_time:.2f} s CPU")
    if len(results) > 1:
        many = report["starts"]
        print(f"{len(results)} starts (seed {start_seed}): distance mean {many['mean']:.4f}, "
              f"min {many['min']:.4f}, max {many['max']:.4f} voxel lengths; fitness (their "
              f"mean, as an evolution with --starts {len(results)} scores it) "
              f"{many['fitness']:.4f}; {many['unstable']} unstable")
    if checked is not None:
        print(_starts_text(checked))
    return 0


def with_body(args: argparse.Namespace, robot: Robot, physics) -> tuple:
    """(robot, physics, fitness rule) of ``args.body``: unchanged with the grid's own rule
    (None), or the paper's 2D robot: a 2D pattern laid flat (a sheet as it is), walked for
    the 2D times, scored by rule 2.

    Raises:
      MjregenError: a 3D grid that is not one layer at z = 1 of three.
    """
    if args.body != "sheet":
        return robot, physics, None
    from mjregen.tasks.bodies import body_physics, body_robot

    try:
        robot = body_robot(robot, "sheet")
    except InvalidGridError as error:
        raise MjregenError(f"{args.robot} is {error}") from None
    return robot, body_physics(physics, "sheet"), 2


def _walk_report(args: argparse.Namespace, result, results: list, rule: int | None) -> dict:
    """The walk's JSON report: the first start's walk and, for several, all of them; fitness
    by the `locomotion_fitness` rule `rule`."""
    from mjregen.tasks.fitness import locomotion_fitness, starts_fitness

    report = {"robot": str(args.robot), "voxels": result.n_voxels, "distance": result.distance,
              "displacement": list(result.displacement), "heading": result.heading,
              "fitness": locomotion_fitness(result, rule=rule), "stable": result.stable,
              "reason": result.reason, "steps": result.steps, "sim_time": result.sim_time,
              "timestep": result.timestep, "wall_time": result.wall_time,
              "cpu_time": result.cpu_time}
    if len(results) > 1:
        distances = np.array([r.distance for r in results])
        unstable = [r for r in results if not r.stable]
        stable = distances[np.isfinite(distances)]
        report["starts"] = {
            "seed": args.start_seed or 0, "distances": distances.tolist(),
            "mean": float(distances.mean()), "min": float(stable.min()) if stable.size else math.nan,
            "max": float(stable.max()) if stable.size else math.nan, "unstable": len(unstable),
            "fitness": starts_fitness(results, rule=rule)}
    return report


def _shifted_starts(robot: Robot, physics, args: argparse.Namespace, record: bool):
    """The walks from the exact start and from --shifted-starts shifted ones."""
    from mjregen.search.backends import ThreadBackend
    from mjregen.tasks.starts import shifted_starts

    with ThreadBackend(args.workers or os.cpu_count() or 1) as backend:
        return shifted_starts(robot, physics=physics, duration=args.duration,
                              starts=args.shifted_starts, shift=args.shift,
                              start_seed=args.start_seed or 0, backend=backend,
                              record_default=record)


def _starts_text(starts) -> str:
    """The shifted starts' distances and what they say of the robot, for people."""
    from mjregen.tasks.starts import KEPT

    n, unstable = len(starts.indices), int(np.count_nonzero(~starts.stable))
    mirror = (f"its body is its own mirror image across {' and '.join(starts.mirror_axes)}"
              if starts.mirror_axes else "its body has no mirror plane")
    share = ("" if math.isnan(starts.kept)
             else f", {starts.kept:.0%} of the exact start's")
    distances = (f"distance mean {starts.mean:.4f}, min {starts.low:.4f}, max "
                 f"{starts.high:.4f} voxel lengths{share}" if unstable < n
                 else "no shifted walk stayed stable")
    lines = [f"{n} shifted starts (each voxel moved by {starts.shift:g} voxel lengths, standard "
             f"deviation; seed {starts.seed}): {distances}; {mirror}"]
    if unstable:
        lines.append(f"{unstable} of the {n} shifted walks became unstable: "
                     + "; ".join(sorted({r for r in starts.reasons if r})))
    if starts.kept < KEPT:
        lines.append(f"the shifted starts keep less than {KEPT:.0%} of the distance: this robot "
                     "walks partly by its exact start")
    return "\n".join(lines)


def add_export(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "export",
        help="write a robot's MuJoCo model as MJCF XML",
        description="Compile a robot file (.npy) and write its MuJoCo model as MJCF: exactly "
        "the model `mjregen walk` simulates. With the default physics the voxel plugin "
        "'mjregen.voxels' computes every force and drives the muscles from the end of the "
        "settle, so plain MuJoCo walks the robot with mj_step alone, after loading the "
        "plugin library once: mujoco.mj_loadPluginLibrary(mjregen.plugin_library()) (built "
        "on first use; export prints its path). With --physics sphere or "
        "box (pure MuJoCo) the muscles' tendons are the first ones in the file and their "
        "rest lengths are rewritten every step by mjregen.physics.simulation.Simulation. "
        "The walk's starts are keyframes 'start_0' .. (mujoco.mj_resetDataKeyframe): "
        "`walk --start-seed S --starts K` walks from the keyframes of `export --start-seed S "
        "--starts K`.",
    )
    parser.add_argument("robot", type=Path, help="robot file (.npy)")
    add_physics_choice(parser)
    add_body_argument(parser)
    parser.add_argument("--settle", type=float,
                        help="s without actuation before the muscles start (default: the "
                             "paper's, 3D 0.05, 2D 1.0)")
    parser.add_argument("--start-shift", type=float, metavar="S",
                        help="voxel lengths, as for walk (default 1e-4; 0: no keyframes, the "
                             "model starts exactly on the grid)")
    parser.add_argument("--starts", type=starts_count, metavar="K",
                        help="keyframes of starts 0 .. K-1 (default 1)")
    parser.add_argument("--start-seed", type=seed,
                        help="seed of the starts (default 0; an evolution uses its seed)")
    parser.add_argument("--out", type=Path, required=True, help="XML file to write")
    parser.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    parser.set_defaults(handler=_export)


def _export(args: argparse.Namespace) -> int:
    from mjregen.fileio import atomic_open
    from mjregen.physics.compile import compile_robot

    robot = Robot.load(args.robot)
    if robot.is_empty:
        raise MjregenError(f"{args.robot} holds an empty robot: nothing to export")
    robot, physics, _ = with_body(args, robot, physics_from_args(args))
    compiled = compile_robot(robot, physics=physics,
                             starts=range(args.starts or 1), start_seed=args.start_seed or 0)
    with atomic_open(args.out, "w", overwrite=args.force) as handle:
        handle.write(compiled.to_xml())
    print(f"wrote {args.out} ({robot.n_voxels} voxels, {compiled.pipeline} pipeline)")
    if compiled.plugin_instance is not None:
        from mjregen.physics import plugin_library

        print(f"load it in MuJoCo after mujoco.mj_loadPluginLibrary('{plugin_library()}')")
    return 0


def add_render(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "render",
        help="render a robot's walk to an .mp4 video or PNG frames",
        description="Simulate a robot file (.npy) as `walk` does and render it headless "
        "(EGL, else OSMesa, or MUJOCO_GL when set) to a video (--out walk.mp4) or PNG frames "
        "(--frames DIR); --start-seed and --start choose the start, as `walk --start-seed S "
        "--starts K` numbers them.",
    )
    parser.add_argument("robot", type=Path, help="robot file (.npy)")
    add_body_argument(parser)
    target = parser.add_mutually_exclusive_group(required=True)
    target.add_argument("--out", type=Path, help=".mp4 file to write")
    target.add_argument("--frames", type=Path, help="folder for PNG frames")
    add_physics_arguments(parser)
    parser.add_argument("--width", type=int, default=480, help="image width in pixels (default 480)")
    parser.add_argument("--height", type=int, default=360,
                        help="image height in pixels (default 360)")
    parser.add_argument("--fps", type=int, default=30, help="video frames per second (default 30)")
    parser.add_argument("--slowdown", type=float, default=10.0, help="times slower than real time (default 10)")
    parser.add_argument("--start", type=start_index, metavar="K",
                        help="render the walk from start K (default 0), as `walk --starts` "
                             "numbers them")
    parser.add_argument("--start-seed", type=seed,
                        help="seed of the starts (default 0; an evolution uses its seed)")
    parser.add_argument("--force", action="store_true", help="overwrite existing files")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(handler=_render, renders=True)


def _render(args: argparse.Namespace) -> int:
    from mjregen.physics.compile import compile_robot
    from mjregen.render import View, record_walk
    from mjregen.video import write_frames, write_video

    robot = Robot.load(args.robot)
    if robot.is_empty:
        raise MjregenError(f"{args.robot} holds an empty robot: nothing to render")
    try:
        view = View(width=args.width, height=args.height)
    except ValueError as error:
        raise MjregenError(str(error)) from None
    start = args.start or 0
    robot, physics, _ = with_body(args, robot, physics_from_args(args))
    compiled = compile_robot(robot, physics=physics, starts=(start,),
                             start_seed=args.start_seed or 0)
    try:
        walk = record_walk(compiled, duration=args.duration, fps=args.fps, slowdown=args.slowdown,
                           start=start)
    except ValueError as error:
        raise MjregenError(str(error)) from None
    if args.out is not None:
        write_video(compiled, walk.qpos, args.out, fps=args.fps, view=view, overwrite=args.force,
                    progress=not args.quiet)
        print(f"wrote {args.out} ({len(walk.qpos)} frames)")
    else:
        paths = write_frames(compiled, walk.qpos, args.frames, view=view, overwrite=args.force,
                             progress=not args.quiet)
        print(f"wrote {len(paths)} frames to {args.frames}")
    if not walk.stable:
        print(f"warning: the simulation became unstable ({walk.reason}); the frames stop there")
    return 0
