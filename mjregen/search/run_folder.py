"""What every search's run folder shares, whatever its optimiser: config.json written once
and compared on resume, refusal to overwrite, metrics.csv rows, errors.log.

A folder holds a run when its config.json has ``"format": RUN_FORMAT``. It is never
overwritten without ``resume`` or ``force``, and ``force`` only ever deletes a folder that
holds a run (never the working directory, the home folder or a parent of one). Callers hold
the folder's `mjregen.search.run_lock.RunLock` while they prepare and write it; ``force``
empties the folder but keeps its lock file.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import re
import shutil
import sys
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from mjregen.errors import CheckpointError, MjregenError
from mjregen.fileio import atomic_open
from mjregen.search.run_lock import LOCK_FILE
from mjregen.tasks.evaluation import PopulationEvaluation

RUN_FORMAT = "mjregen-run-1"
# the temporary file of an atomic write (`mjregen.fileio.atomic_open`) that a kill left behind
WRITE_DEBRIS = re.compile(r"^\..+\.(json|csv|npz|npy|png|log)\.[a-z0-9_]{8}$")


class RunFolderError(MjregenError, ValueError):
    """The output folder holds another run, or cannot be resumed or replaced."""


class RunFailedError(MjregenError, RuntimeError):
    """Every evaluation of a generation failed (the first error is in the message)."""


def config_hash(path: Path) -> str:
    """sha256 of a run's config.json, stored in its checkpoints."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def save_checkpoint(path: Path, *, state: dict, arrays: dict[str, np.ndarray],
                    config_sha256: str) -> None:
    """Write a run's checkpoint atomically: `state` as JSON with the hash of the config.json
    the run started with (an edit made during the run is refused on resume), and `arrays`."""
    state = {**state, "config_sha256": config_sha256}
    with atomic_open(path) as handle:
        np.savez(handle, format=np.array(RUN_FORMAT), state=np.array(json.dumps(state)),
                 **arrays)


def load_checkpoint(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    """(state, arrays) of the checkpoint `save_checkpoint` wrote (the state without its
    config hash).

    Raises:
      CheckpointError: the file is missing, unreadable or not a run checkpoint.
      RunFolderError: the run's config.json changed since the checkpoint was written (a
        checkpoint from before the hash was stored is not checked).
    """
    try:
        with np.load(path, allow_pickle=False) as archive:
            if "format" not in archive.files or str(archive["format"]) != RUN_FORMAT:
                raise CheckpointError(f"{path} is not an mjregen run checkpoint")
            state = json.loads(str(archive["state"]))
            arrays = {name: archive[name] for name in archive.files
                      if name not in ("format", "state")}
    except (KeyError, ValueError, OSError, EOFError, zipfile.BadZipFile) as error:
        raise CheckpointError(f"cannot read run checkpoint {path}: {error}") from None
    if not isinstance(state, dict):
        raise CheckpointError(f"cannot read run checkpoint {path}: its state is not a record")
    stored_hash = state.pop("config_sha256", None)
    config_path = path.with_name("config.json")
    if stored_hash is not None and stored_hash != config_hash(config_path):
        raise RunFolderError(f"{config_path} changed since the run wrote {path.name} (its hash "
                             "differs): restore the file, or start a new run")
    return state, arrays


def read_config(path: Path) -> dict:
    """A run's config.json, or RunFolderError naming it."""
    try:
        config = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise RunFolderError(f"{path} is not a readable run configuration: {error}") from None
    if not isinstance(config, dict):
        raise RunFolderError(f"{path} is not a run configuration (not a JSON object)")
    return config


def read_task(task_class: type, description: object) -> object:
    """`description` (a config.json "task" entry) as ``task_class`` writes it today: through
    its ``from_config`` and ``to_config``; unchanged when the class has no ``from_config`` or
    cannot read it (the comparison then reports the difference)."""
    reader = getattr(task_class, "from_config", None)
    if reader is None or not isinstance(description, dict):
        return description
    try:
        return reader(description).to_config()
    except (KeyError, TypeError, ValueError, MjregenError):
        return description


def is_run_folder(path: Path) -> bool:
    """`path` holds an mjregen run: a config.json of this run format."""
    try:
        return json.loads((path / "config.json").read_text()).get("format") == RUN_FORMAT
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, AttributeError):
        return False


def _check_deletable(out: Path) -> None:
    """Raise RunFolderError unless `force` may delete `out`: an mjregen run folder that is
    not the working directory, the home folder or one of their parents."""
    resolved = out.resolve()
    protected = {Path.cwd().resolve(), Path.home().resolve()}
    if any(resolved == p or resolved in p.parents for p in protected):
        raise RunFolderError(f"force never deletes {out} (the working directory, the home "
                             "folder or a parent of one): choose another --out")
    if not is_run_folder(out):
        raise RunFolderError(f"{out} is not empty and does not hold an mjregen run (no "
                             f"config.json of format {RUN_FORMAT}): force only replaces run "
                             "folders; choose another --out")


def _clear_write_debris(out: Path) -> None:
    """Remove the temporary files of writes a killed run left in `out` and `out/best` (the
    caller holds the folder's lock: no write is under way)."""
    for folder in (out, out / "best"):
        if folder.is_dir():
            for path in folder.iterdir():
                if path.is_file() and WRITE_DEBRIS.match(path.name):
                    path.unlink()


def _contents(folder: Path) -> list[Path]:
    """Everything in `folder` but its lock file and what a run killed while it wrote its
    first config.json left (the atomic write's temporary file): such a folder holds nothing."""
    return [path for path in folder.iterdir()
            if path.name != LOCK_FILE and not path.name.startswith(".config.json.")]


def prepare_folder(out: Path, config: dict, *, resume: bool, force: bool,
                   checkpoint: str = "checkpoint.npz", task_class: type | None = None) -> bool:
    """Create or check the run folder; returns True when an earlier run is resumed (its
    `checkpoint` file exists). `task_class`: the task's class; with a ``from_config``, a
    stored "task" entry is compared as that class reads it today (a description an older
    mjregen wrote migrates: `read_task`).

    Raises:
      RunFolderError: both `resume` and `force`; nothing to resume; the folder holds a run
        with other settings; or it is not empty and `force` may not delete it.
    """
    config_path = out / "config.json"
    if resume and force:
        raise RunFolderError("choose either resume or force, not both")
    if resume:
        if not config_path.is_file():
            raise RunFolderError(f"nothing to resume: {config_path} does not exist")
        stored = read_config(config_path)
        if task_class is not None and "task" in stored:
            stored = {**stored, "task": read_task(task_class, stored["task"])}
        differences = sorted(k for k in set(stored) | set(config)
                             if k not in ("created", "mjregen_version") and stored.get(k) != config.get(k))
        if differences:
            raise RunFolderError(
                f"{out} holds a run with different settings ({', '.join(differences)}); "
                "resume it with its own settings or use another folder")
        _clear_write_debris(out)
        return (out / checkpoint).is_file()
    if out.exists() and _contents(out):
        if not force:
            raise RunFolderError(f"{out} is not empty; continue the run in it (resume=True; "
                                 "mjregen: --resume) or delete it and start again (force=True; "
                                 "--force)")
        _check_deletable(out)
        for path in _contents(out):
            shutil.rmtree(path) if path.is_dir() and not path.is_symlink() else path.unlink()
    out.mkdir(parents=True, exist_ok=True)
    _clear_write_debris(out)  # a first config.json write that a killed run left
    with atomic_open(config_path, "w") as handle:
        json.dump(config, handle, indent=2)
    return False


def log_failures(path: Path, step: int, result: PopulationEvaluation, *, progress: bool,
                 label: str = "generation") -> None:
    """Append the failed evaluations of `label` `step` (one line each, the first traceback)
    to `path`, and say so on screen."""
    with path.open("a") as handle:
        handle.write(f"{label} {step}: {len(result.errors)} failed\n")
        handle.writelines(f"  {line}\n" for line in result.errors)
        if result.tracebacks and result.tracebacks[0]:
            handle.write(result.tracebacks[0] + "\n")
    message = (f"{label} {step}: {len(result.errors)} evaluation(s) failed, e.g. "
               f"{result.errors[0]} (see {path})")
    if progress:
        tqdm.write(message)
    else:
        print(message, file=sys.stderr)


EVALUATION_COLUMNS = ("unstable", "failed", "distinct", "evaluations", "evals_per_s",
                      "wall_time", "elapsed")


def evaluation_columns(result: PopulationEvaluation, *, wall: float, elapsed: float) -> dict:
    """The metrics.csv columns every optimiser's step has (`EVALUATION_COLUMNS`): unstable,
    failed and distinct robots, evaluations, their rate (per s of `wall`, the step's), the
    step's wall time and `elapsed` (s, the run's so far)."""
    evaluations = len(result.fitness)
    return {
        "unstable": int(np.count_nonzero(~result.stable & ~result.failed)),
        "failed": int(np.count_nonzero(result.failed)), "distinct": result.n_distinct,
        "evaluations": evaluations, "evals_per_s": f"{evaluations / wall:.4g}",
        "wall_time": f"{wall:.4g}", "elapsed": f"{elapsed:.6g}",
    }


def read_metrics(path: Path, counter: str, done: int) -> list[dict]:
    """metrics.csv rows whose `counter` column (e.g. "generation") is below `done` (a
    killed run may have written one more)."""
    if not path.is_file():
        return []
    try:
        with path.open() as handle:
            return [row for row in csv.DictReader(handle) if int(row[counter]) < done]
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError, csv.Error) as error:
        raise RunFolderError(f"{path} is not a readable metrics file ({type(error).__name__}: "
                             f"{error}); restore it from a copy, or start again with force"
                             ) from None


# a run's optimiser (its config.json section) -> (the section's count of steps, metrics.csv's
# step column)
STEP_NAMES = {"ga": ("generations", "generation"), "map_elites": ("iterations", "iteration")}


@dataclass(frozen=True)
class RunProgress:
    """How far the run in a folder has come, whatever its optimiser.

    Attributes:
      counter: metrics.csv's step column ("generation" of a GA, "iteration" of MAP-Elites).
      done: steps listed in metrics.csv, at most `planned`.
      planned: steps the run's config.json asks for.
      elapsed: wall time of the listed steps, s (the last row's ``elapsed``; 0 when none).
      best: the highest fitness listed (column ``best``; -inf when none).
    """

    counter: str
    done: int
    planned: int
    elapsed: float
    best: float

    @property
    def complete(self) -> bool:
        return self.done >= self.planned


def read_progress(folder: Path) -> RunProgress:
    """`RunProgress` of the run in `folder`, from its config.json and metrics.csv (none: no
    step done).

    Raises:
      RunFolderError: config.json is missing or unreadable, names no optimiser, or
        metrics.csv cannot be read.
    """
    config = read_config(folder / "config.json")
    section = next((name for name in STEP_NAMES if isinstance(config.get(name), dict)), None)
    if section is None:
        raise RunFolderError(f"{folder / 'config.json'} names no optimiser (no "
                             f"{' or '.join(map(repr, STEP_NAMES))} entry): not a run's "
                             "configuration")
    steps, counter = STEP_NAMES[section]
    planned = int(config[section][steps])
    rows = read_metrics(folder / "metrics.csv", counter, planned)
    try:
        elapsed = float(rows[-1]["elapsed"]) if rows else 0.0
        best = max((float(row["best"]) for row in rows), default=-math.inf)
    except (KeyError, TypeError, ValueError) as error:
        raise RunFolderError(f"{folder / 'metrics.csv'} is not a readable metrics file (its "
                             f"'elapsed' or 'best' column: {type(error).__name__}: {error})"
                             ) from None
    return RunProgress(counter=counter, done=len(rows), planned=planned, elapsed=elapsed,
                       best=best)


def check_agreement(out: Path, rows: list[dict], done: int, counter: str) -> None:
    """A resumed state at `done` steps (generations, iterations) and metrics.csv's `rows`
    below it must list every step 0 .. `done` - 1 once, in order.

    Raises:
      RunFolderError: they disagree (what was found, and what to do; nothing is changed).
    """
    listed = [int(row[counter]) for row in rows]
    if listed != list(range(done)):
        shown = (f"{counter}s {listed[0]}-{listed[-1]} ({len(listed)} rows)" if listed
                 else f"no {counter}")
        raise RunFolderError(
            f"{out}: metrics.csv lists {shown} but checkpoint.npz is at {counter} {done}: "
            "the run folder disagrees with itself and nothing was changed; restore "
            "metrics.csv from a copy, or start the run again with force")


def check_restartable(out: Path, checkpoint: str, counter: str) -> None:
    """A resume without `checkpoint` may only start again from nothing: allowed when
    metrics.csv lists at most the first step (a run killed between that step's metrics and
    its first checkpoint; the step is deterministic and is done again).

    Raises:
      RunFolderError: metrics.csv lists later steps, which the run cannot continue from.
    """
    rows = read_metrics(out / "metrics.csv", counter, 1 << 62)
    if len(rows) > 1:
        raise RunFolderError(
            f"{out}: {checkpoint} is missing but metrics.csv lists {len(rows)} finished "
            f"{counter}s: the run cannot continue exactly from there and nothing was changed; "
            f"restore {checkpoint}, or start the run again with force")


def write_metrics(path: Path, columns: tuple[str, ...], rows: list[dict]) -> None:
    """metrics.csv with `columns`, written atomically."""
    with atomic_open(path, "w") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
