"""One writer per run folder: an OS file lock held for the life of a run.

`RunLock(folder)` takes an exclusive, non-blocking `fcntl.flock` on ``folder/.mjregen.lock``
(creating the folder and the file) and writes the holder's process id, host and start time
into it (trying again for a moment, `PROBE_GRACE_S`, while `holder_of` probes the lock). A
run in another process is refused with that holder's description. Within one
process the lock is re-entrant (a regrowth run holds its folder around the GA run it writes
there); it does not keep apart threads of one process. The lock goes with its process, so
the lock of a process that died (killed, crashed, a machine that rebooted) is taken over by
the next run without a word. The lock file is never deleted, not even by ``force``: a
folder's lock must outlive its contents (only a folder the lock itself created and nothing
else filled is removed again on release, so a refused run leaves nothing behind). POSIX only
(Linux, macOS), like the rest of mjregen's process handling.
"""

from __future__ import annotations

import fcntl
import json
import os
import socket
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import IO

from mjregen.errors import MjregenError

LOCK_FILE = ".mjregen.lock"
PROBE_GRACE_S = 0.2  # a run finding its folder locked tries again this long: a probe's moment
_HELD: dict[Path, int] = {}  # folders this process holds -> how many RunLocks hold each


class RunFolderBusyError(MjregenError, RuntimeError):
    """Another live process holds the run folder."""


class RunLock:
    """An exclusive lock on a run folder (module docstring); a context manager.

    Raises (on entering):
      RunFolderBusyError: another process holds the folder.
      MjregenError: the folder or its lock file cannot be created or opened.
    """

    def __init__(self, folder: str | os.PathLike) -> None:
        self.folder = Path(folder)
        self.path = self.folder / LOCK_FILE
        self._handle = None
        self._nested = False
        self._created = False

    def __enter__(self) -> RunLock:
        self.acquire()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.release()

    def acquire(self) -> None:
        """Take the lock and record this process as its holder."""
        try:
            self._created = not self.folder.exists()
            self.folder.mkdir(parents=True, exist_ok=True)
            key = self.folder.resolve()
            if key in _HELD:
                _HELD[key] += 1
                self._nested = True
                return
            handle = open(self.path, "a+")
        except OSError as error:
            raise MjregenError(f"cannot lock the run folder {self.folder}: {error.strerror} "
                               f"({error.filename or self.path})") from None
        if not _lock_within(handle, PROBE_GRACE_S):
            handle.seek(0)
            holder = handle.read().strip()
            handle.close()
            raise RunFolderBusyError(
                f"{self.folder} is in use by {describe_holder(holder)}: one run folder takes "
                "one run at a time; wait for it to finish, stop it, or choose another folder"
            ) from None
        handle.seek(0)
        handle.truncate()
        handle.write(json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                                 "started": datetime.now(timezone.utc).isoformat()}))
        handle.flush()
        self._handle = handle
        _HELD[key] = 1

    def release(self) -> None:
        """Give the lock up (the file stays)."""
        key = self.folder.resolve()
        if self._nested:
            _HELD[key] -= 1
            self._nested = False
        elif self._handle is not None:
            del _HELD[key]
            if self._created and [p.name for p in self.folder.iterdir()] == [LOCK_FILE]:
                self.path.unlink()  # while still held: no one can lock the file removed
                self.folder.rmdir()
            fcntl.flock(self._handle.fileno(), fcntl.LOCK_UN)
            self._handle.close()
            self._handle = None


def _lock_within(handle: IO[str], seconds: float) -> bool:
    """Take the exclusive lock on `handle`'s file, trying again for up to `seconds` (a
    `holder_of` probe holds it for microseconds); False when another process keeps it."""
    deadline = time.monotonic() + seconds
    while True:
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            return True
        except BlockingIOError:
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.01)


def holder_of(folder: str | os.PathLike) -> str | None:
    """The process that holds `folder`'s lock now, described for people; None when no live
    process does (or the folder has no lock file). Probes with a shared lock, released at
    once (a run starting meanwhile waits for it, `PROBE_GRACE_S`); creates nothing."""
    try:
        handle = open(Path(folder) / LOCK_FILE)
    except FileNotFoundError:
        return None
    with handle:
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return describe_holder(handle.read().strip())
        fcntl.flock(handle.fileno(), fcntl.LOCK_UN)
    return None


def describe_holder(text: str) -> str:
    """The holder a lock file records, for people."""
    try:
        holder = json.loads(text)
        return (f"process {holder['pid']} on {holder['host']}, started "
                f"{holder['started']}")
    except (ValueError, KeyError, TypeError):
        return "another process"
