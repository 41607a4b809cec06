"""The runs command: where the run folders under some paths stand."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import TYPE_CHECKING

from mjregen.cli.common import print_json
from mjregen.errors import MjregenError

if TYPE_CHECKING:  # imported where the command runs: the parser is built without it
    from mjregen.search.run_status import RunStatus


def add_runs(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "runs",
        help="list run folders: steps done, best fitness, hours, whether a process runs each "
             "now, hours left",
        description="List every run folder (of `evolve` or `regen`, GA or MAP-Elites) among "
        "PATH and under it: generations (iterations) done of those planned, the best fitness "
        "listed, the wall time of the steps done, and its state: finished, running (a process "
        "holds the folder now: which) or stopped (with --resume it continues from its "
        "checkpoint). Hours left: the steps not done at the pace of those done. A folder "
        "whose files cannot be read is named with the reason (exit status 1). Reads the "
        "folders only; safe beside running evolutions. Example: mjregen runs runs/",
    )
    parser.add_argument("paths", nargs="+", type=Path, metavar="PATH",
                        help="run folders, or folders holding them at any depth")
    parser.add_argument("--json", action="store_true", help="print the list as JSON")
    parser.set_defaults(handler=_runs)


def _runs(args: argparse.Namespace) -> int:
    from mjregen.search.run_folder import RunFolderError
    from mjregen.search.run_status import find_run_folders, run_status

    missing = [str(path) for path in args.paths if not path.exists()]
    if missing:
        raise MjregenError(f"no such folder: {', '.join(missing)}")
    folders = find_run_folders(args.paths)
    if not folders:
        raise MjregenError(f"no run folder (a config.json of mjregen) in or under "
                           f"{', '.join(map(str, args.paths))}")
    statuses, unreadable = [], {}
    for folder in folders:
        try:
            statuses.append(run_status(folder))
        except RunFolderError as error:  # listed below the others; the rest still shown
            unreadable[str(folder)] = str(error)
    if args.json:
        print_json([{"run": str(s.folder), "method": s.method, "state": s.state,
                     "done": s.progress.done, "planned": s.progress.planned,
                     "best": s.progress.best, "hours": s.progress.elapsed / 3600,
                     "hours_left": s.hours_left, "holder": s.holder,
                     "resumable": s.resumable} for s in statuses]
                   + [{"run": run, "state": "unreadable", "error": error}
                      for run, error in unreadable.items()])
    else:
        _print_table(statuses)
        for run, error in unreadable.items():
            print(f"{run}: unreadable: {error}")
    return 1 if unreadable else 0


def _print_table(statuses: list[RunStatus]) -> None:
    """One line per run under a header."""
    width = max([len("run")] + [len(str(s.folder)) for s in statuses])
    print(f"{'run':<{width}}  {'method':<10}  {'done':>11}  {'best':>10}  {'hours':>6}  "
          f"{'left':>6}  state")
    for s in statuses:
        done = f"{s.progress.done}/{s.progress.planned}"
        best = f"{s.progress.best:.4g}" if math.isfinite(s.progress.best) else "-"
        left = "" if s.state == "finished" else (
            "?" if math.isnan(s.hours_left) else f"{s.hours_left:.2f}")
        print(f"{str(s.folder):<{width}}  {s.method:<10}  {done:>11}  {best:>10}  "
              f"{s.progress.elapsed / 3600:>6.2f}  {left:>6}  {_state(s)}")


def _state(status: RunStatus) -> str:
    """The state column: running by whom, or what a stopped run can do."""
    if status.state == "running":
        return f"running ({status.holder})"
    if status.state == "stopped":
        return ("stopped: resumable (--resume)" if status.resumable
                else "stopped: no checkpoint.npz to resume from")
    return "finished"
