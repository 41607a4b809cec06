"""Helpers shared by the command modules."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

from mjregen.errors import MjregenError
from mjregen.grid import Material, Robot

if TYPE_CHECKING:
    from mjregen.search.ga import GAConfig


def starts_count(text: str) -> int:
    """argparse type of --starts: a whole number from 1 to `MAX_STARTS`."""
    from mjregen.physics.start_state import MAX_STARTS

    value = _whole(text, "starts")
    if not 1 <= value <= MAX_STARTS:
        raise argparse.ArgumentTypeError(f"starts is a whole number from 1 to {MAX_STARTS}, "
                                         f"got {text}")
    return value


def start_index(text: str) -> int:
    """argparse type of --start: a start's index, a whole number >= 0."""
    return _whole_at_least(text, "start", 0, "a start is a whole number >= 0")


def seed(text: str) -> int:
    """argparse type of --seed: a whole number >= 0 (numpy's seeds)."""
    return _whole_at_least(text, "seed", 0, "a seed is a whole number >= 0")


def workers(text: str) -> int:
    """argparse type of --workers: a whole number >= 1 (omit the flag for all cores)."""
    return _whole_at_least(text, "workers", 1,
                           "--workers needs at least 1 (omit it to use all cores)")


def positive(text: str) -> int:
    """argparse type of a count: a whole number >= 1."""
    return _whole_at_least(text, "the count", 1, "a count is a whole number >= 1")


def _whole_at_least(text: str, name: str, low: int, problem: str) -> int:
    """`text` as a whole number >= `low`, else argparse's error "`problem`, got `text`"."""
    value = _whole(text, name)
    if value < low:
        raise argparse.ArgumentTypeError(f"{problem}, got {text}")
    return value


def _whole(text: str, name: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{name} must be a whole number, got {text!r}") from None


def add_engine_robot_arguments(parser: argparse.ArgumentParser, *, nargs: str = "+",
                               robots_help: str = "robot files (.npy) or NAME=PATH") -> None:
    """``--voxelyze DIR`` (the paper's engine) and the positional ROBOT arguments of the
    commands that walk robots in both simulators (read them with `named_paths`)."""
    parser.add_argument("--voxelyze", type=Path, required=True,
                        help="folder of the paper's engine and its vxa.py")
    parser.add_argument("robots", nargs=nargs, help=robots_help)


def named_paths(items: list[str]) -> list[tuple[str, Path]]:
    """(name, path) of each ``NAME=PATH`` (split at the last "=") or ``PATH`` (named by
    its file's stem).

    Raises:
      ValueError: an item names no file (``NAME=``).
    """
    pairs = []
    for item in items:
        name, _, path = item.rpartition("=")
        if not path:
            raise ValueError(f"{item!r} names no robot file (give NAME=PATH or PATH)")
        pairs.append((name or Path(path).stem, Path(path)))
    return pairs


def material_counts(robot: Robot) -> dict[str, int]:
    """Voxels per material, by lower-case name, empty left out."""
    return {m.name.lower(): n for m, n in robot.material_counts().items() if m != Material.EMPTY}


def add_ga_arguments(parser: argparse.ArgumentParser, *, preset_help: str) -> None:
    """--preset and the GA numbers that override it."""
    from mjregen.search.ga import PRESETS  # only for the commands that run a GA

    values = "; ".join(f"{name}: {config.summary()}" for name, config in sorted(PRESETS.items()))
    parser.add_argument("--preset", choices=sorted(PRESETS), help=f"{preset_help} ({values})")
    parser.add_argument("--pop", type=int,
                        help="population size (the preset's truncation and elites keep their "
                             "share of it unless given)")
    parser.add_argument("--gens", type=int, help="generations")
    parser.add_argument("--truncation", type=int, help="parents are drawn from the top T")
    parser.add_argument("--elites", type=int, help="individuals kept unchanged")
    parser.add_argument("--sigma", type=float, help="mutation standard deviation")


def ga_config(args: argparse.Namespace, default_preset: str) -> GAConfig:
    """The preset named by --preset (else `default_preset`) with the given numbers replaced."""
    from mjregen.search.ga import PRESETS

    try:
        preset = PRESETS[args.preset or default_preset]
        if args.pop is not None:
            preset = preset.scaled(args.pop)
        return preset.with_overrides(generations=args.gens, truncation=args.truncation,
                                     elites=args.elites, sigma=args.sigma)
    except ValueError as error:
        raise MjregenError(str(error)) from None


def add_run_folder_arguments(parser: argparse.ArgumentParser, *, resume_help: str,
                             out_required: bool = True) -> None:
    """--out, --resume | --force and --quiet, as every run-folder command has them."""
    parser.add_argument("--out", type=Path, required=out_required, help="run folder")
    folder = parser.add_mutually_exclusive_group()
    folder.add_argument("--resume", action="store_true", help=resume_help)
    folder.add_argument("--force", action="store_true", help="delete --out first")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.set_defaults(resumable=True)


PHYSICS = ("default", "paper", "sphere", "box")


def add_physics_choice(parser: argparse.ArgumentParser) -> None:
    """--physics (a preset), --bonds and --timestep-rule."""
    parser.add_argument("--physics", choices=PHYSICS,
                        help="'default' (the default) = 'paper': the paper engine's physics in "
                             "the voxel plugin (docs/fidelity.md); 'sphere' or 'box': the "
                             "pure-MuJoCo pipeline (MuJoCo tendons and contacts, no C "
                             "compiler needed; mjregen.physics.presets)")
    parser.add_argument("--bonds", choices=("tendons", "beam"),
                        help="voxel pipeline's bond element: 'beam' (the default: one beam "
                             "element per bond) or 'tendons' (8 tendons per bond, the same "
                             "linear stiffness at about 4x the CPU time; docs/performance.md)")
    parser.add_argument("--timestep-rule", choices=("network", "stiffest_bond"),
                        help="time step: 0.75 of Euler's stability limit of the robot's own "
                             "bond network ('network', the voxel pipeline's default) or of a "
                             "block of its stiffest bond ('stiffest_bond': smaller "
                             "integration errors at 1.1-2.2x the CPU time; docs/accuracy.md)")
    parser.set_defaults(settle=None)


def add_physics_arguments(parser: argparse.ArgumentParser) -> None:
    """--physics (the default model or the paper-engine preset), --settle, --duration,
    --start-shift and --settle-rest."""
    add_physics_choice(parser)
    parser.add_argument("--settle", type=float,
                        help="s without actuation before measuring (default: the paper's, 3D 0.05, 2D 1.0)")
    parser.add_argument("--duration", type=float,
                        help="s of walking measured (default: the paper's, 3D 0.5, 2D 0.25)")
    parser.add_argument("--start-shift", type=float, metavar="S",
                        help="voxel lengths: every voxel starts moved by a seeded random "
                             "offset of this standard deviation, so that no body balances on "
                             "an exact symmetry (default 1e-4; 0 starts it exactly on the grid; "
                             "else at least 1e-5, what the model's keyframe keeps)")
    parser.add_argument("--settle-rest", type=float, metavar="R",
                        help="1/s: the settle ends once every voxel has moved slower than R "
                             "voxel lengths/s and turned slower than R rad/s for 5 ms, and the "
                             "robot is held still until the muscles start (default: 1e-6 for "
                             "sheets, else the full settle; 0: the full settle)")


def add_body_argument(parser: argparse.ArgumentParser) -> None:
    """--body of the commands on one robot file."""
    parser.add_argument("--body", choices=("grid", "sheet"),
                        help="'sheet': a 2D pattern (or a 2D run's sheet) as the paper's 2D "
                             "robot, laid flat on the floor as one layer, with the 2D times "
                             "(settle 1 s, walk 0.25 s) unless --settle/--duration and the 2D "
                             "fitness, its distance (default 'grid': the file's grid as it is)")


def physics_from_args(args: argparse.Namespace):
    """The `Physics` that --physics, --bonds, --timestep-rule, --settle, --start-shift and
    --settle-rest describe, with --duration checked too (before any work starts)."""
    from mjregen.physics import (
        Physics,
        VoxelPipeline,
        box_physics,
        paper_physics,
        sphere_physics,
    )

    presets = {"paper": paper_physics, "sphere": sphere_physics, "box": box_physics}
    physics = presets.get(args.physics, Physics)()
    if args.bonds is not None:
        if not isinstance(physics.pipeline, VoxelPipeline):
            raise MjregenError(f"--bonds sets the voxel pipeline's bond element; --physics "
                               f"{args.physics} is the pure-MuJoCo pipeline (8 tendons per bond)")
        physics = physics.replace(bond_element=args.bonds)
    if args.timestep_rule is not None:
        physics = physics.replace(timestep_rule=args.timestep_rule)
    duration = getattr(args, "duration", None)
    if duration is not None and not (math.isfinite(duration) and duration >= 0.0):
        raise MjregenError(f"--duration must be a finite time >= 0 s, got {duration!r}")
    for flag, field, value in (("--settle", "settle_time", args.settle),
                               ("--start-shift", "start_shift", getattr(args, "start_shift", None)),
                               ("--settle-rest", "settle_rest", getattr(args, "settle_rest", None))):
        if value is not None:
            try:
                physics = physics.replace(**{field: value})
            except ValueError as error:
                raise MjregenError(f"{flag}: {error}") from None
    return physics


def print_json(value: object) -> None:
    """Print `value` as valid JSON: NaN and infinities (an unstable run's numbers, a best
    fitness before any) become null, in lists and dicts too."""
    print(json.dumps(_finite_or_none(value), allow_nan=False))


def _finite_or_none(value: object) -> object:
    if isinstance(value, dict):
        return {k: _finite_or_none(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_or_none(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def task_settings(args: argparse.Namespace, task) -> dict[str, tuple]:
    """The task and physics flags of a command resuming the run of `task` (a
    `LocomotionTask`), each paired with what the run has: {flag: (given, run's)}."""
    physics = task.physics
    given = {"dim": (args.dim, task.nca.dim), "net": (args.net, task.nca.kind),
             "duration": (args.duration, task.duration), "starts": (args.starts, task.starts),
             "body": (getattr(args, "body", None), getattr(task, "body", "grid")),
             "start-shift": (args.start_shift, physics.scene.start_shift),
             "settle": (args.settle, physics.scene.settle_time),
             "bonds": (args.bonds, getattr(physics.pipeline, "bond_element", None)),
             "timestep-rule": (args.timestep_rule, physics.pipeline.timestep_rule)}
    if args.physics is not None and physics_from_args(args) != physics:
        given["physics"] = (args.physics, "other physics")
    return given


def refuse_other_settings(out: Path, given: dict[str, tuple]) -> None:
    """MjregenError naming every flag of `given` ({flag: (given, run's)}) that was given
    and differs from the run's in `out`."""
    conflicts = [f"--{flag} {value} (run has {stored})" for flag, (value, stored) in given.items()
                 if value is not None and value != stored]
    if conflicts:
        raise MjregenError(f"{out} was started with other settings: {', '.join(conflicts)}")
