"""The `mjregen` command. Every subcommand has --help; --json prints machine-readable output.

Errors a user can cause (missing file, bad grid, bad checkpoint) print one line
``mjregen: error: ...`` on stderr and exit with status 1; usage errors exit with 2.
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
import threading
from typing import Callable, Sequence

# Before numpy is imported: numpy's BLAS does no work in a command worth a thread pool
# (the physics is C, the networks torch), and OpenBLAS starting one costs each process
# (the command and its workers, which inherit this) about 0.1 CPU s. A user's own
# setting stands.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from mjregen import __version__, gl, interrupt  # noqa: E402
from mjregen.cli import evolution, regeneration, robots, run_folders  # noqa: E402
from mjregen.errors import MjregenError, OutputExistsError  # noqa: E402

Handler = Callable[[argparse.Namespace], int]
COMMANDS = {"grow": robots.add_grow, "show": robots.add_show, "walk": robots.add_walk,
            "export": robots.add_export, "render": robots.add_render,
            "evolve": evolution.add_evolve, "evolve-stats": evolution.add_evolve_stats,
            "regen": regeneration.add_regen, "runs": run_folders.add_runs}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser: every subcommand, or only `command` (a name of
    `COMMANDS`: what `main` builds when the first word names one, since building the
    others' arguments costs start-up time a command does not use)."""
    parser = argparse.ArgumentParser(
        prog="mjregen",
        description="Grow soft voxel robots with neural cellular automata, walk them in MuJoCo, "
        "evolve and regenerate them.",
    )
    parser.add_argument("--version", action="version", version=f"mjregen {__version__}")
    subparsers = parser.add_subparsers(title="commands", metavar="COMMAND", required=True)
    for name, add in COMMANDS.items():
        if command is None or name == command:
            add(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    words = list(sys.argv[1:] if argv is None else argv)
    command = words[0] if words and words[0] in COMMANDS else None
    args = build_parser(command).parse_args(words)
    handler: Handler = args.handler
    main_thread = threading.current_thread() is threading.main_thread()
    restore = interrupt.install() if main_thread else (lambda: None)
    try:
        return _run(handler, args, words)
    finally:
        restore()


def _run(handler: Handler, args: argparse.Namespace, words: list[str]) -> int:
    """The command, with its errors as one-line messages and exit codes."""
    try:
        _prepare_gl(args)
        return handler(args)
    except KeyboardInterrupt:
        print(_interrupted(args, words), file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader stopped (``mjregen show x.npy | head``): not an error of ours; point
        # stdout at nothing so that Python's final flush does not complain
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except OutputExistsError as error:
        print(f"mjregen: error: {error.path} exists; pass --force to replace it",
              file=sys.stderr)
        return 1
    except OSError as error:
        print(f"mjregen: error: {os_message(error)}", file=sys.stderr)
        return 1
    except MjregenError as error:
        print(f"mjregen: error: {error}", file=sys.stderr)
        return 1


def os_message(error: OSError) -> str:
    """An operating-system error for people: the path(s) and the reason, without the errno
    number ("x.npy: Permission denied"); errors without a path as Python words them."""
    if error.filename is None or error.strerror is None:
        return str(error)
    paths = " -> ".join(str(p) for p in (error.filename, error.filename2) if p is not None)
    return f"{paths}: {error.strerror}"


def _prepare_gl(args: argparse.Namespace) -> None:
    """Before anything imports MuJoCo: a ``MUJOCO_GL`` whose library is missing is a
    one-line error for commands that render; the others load no OpenGL at all (neither
    a missing library nor the start-up time of one can then stop or slow them)."""
    renders = getattr(args, "renders", False)
    if callable(renders):  # the command decides from its arguments
        renders = renders(args)
    renders = renders and not getattr(args, "no_video", False)
    if renders:
        problem = gl.missing_library(gl.requested_backend())
        if problem:
            raise MjregenError(problem)
    elif "mujoco" not in sys.modules:
        gl.disable_for_work_without_rendering()


def _interrupted(args: argparse.Namespace, words: list[str]) -> str:
    """What to say after Ctrl-C: for a run folder, that its checkpoint is intact (it is
    written atomically after each generation) and the command that continues it."""
    if not getattr(args, "resumable", False):
        return "mjregen: interrupted"
    resume = [w for w in words if w != "--force"] + ([] if "--resume" in words else ["--resume"])
    state = ("the checkpoint in {} is intact" if (args.out / "checkpoint.npz").is_file()
             else "no generation of the run in {} had finished").format(args.out)
    return f"mjregen: interrupted; {state}. Continue with: mjregen {shlex.join(resume)}"
