"""The `mjregen` command. Every subcommand has --help; --json prints machine-readable output.

Errors a user can cause (missing file, bad grid, bad checkpoint) print one line
``mjregen: error: ...`` on stderr and exit with status 1; usage errors exit with 2.
"""

from __future__ import annotations

import argparse
import sys
from typing import Callable, Sequence

from mjregen import __version__
from mjregen.cli import evolution, regeneration, robots
from mjregen.errors import MjregenError, OutputExistsError

Handler = Callable[[argparse.Namespace], int]
COMMANDS = (robots.add_grow, robots.add_show, robots.add_walk, robots.add_export, robots.add_render,
            evolution.add_evolve, evolution.add_evolve_stats, regeneration.add_regen)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mjregen",
        description="Grow soft voxel robots with neural cellular automata, walk them in MuJoCo, "
        "evolve and regenerate them.",
    )
    parser.add_argument("--version", action="version", version=f"mjregen {__version__}")
    subparsers = parser.add_subparsers(title="commands", metavar="COMMAND", required=True)
    for add in COMMANDS:
        add(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    handler: Handler = args.handler
    try:
        return handler(args)
    except OutputExistsError as error:
        print(f"mjregen: error: {error.path} exists; pass --force to replace it",
              file=sys.stderr)
        return 1
    except (MjregenError, OSError) as error:
        print(f"mjregen: error: {error}", file=sys.stderr)
        return 1
