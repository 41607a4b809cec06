"""Atomic file writes: a file is either its old self or completely new, never half-written."""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Iterator

from mjregen.errors import OutputExistsError


@contextmanager
def atomic_open(path: str | os.PathLike, mode: str = "wb", *, overwrite: bool = True) -> Iterator[IO]:
    """Open a temporary file beside `path`; on success it replaces `path`, on error it is
    removed and `path` is untouched.

    Raises:
      OutputExistsError: `path` exists and `overwrite` is False.
      OSError: `path` cannot be written (the message names `path`).
    """
    path = Path(path)
    if path.exists() and not overwrite:
        raise OutputExistsError(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle = tempfile.NamedTemporaryFile(mode, dir=path.parent, prefix=f".{path.name}.",
                                             delete=False)
    except OSError as error:
        raise type(error)(error.errno, f"cannot write it: {error.strerror}", str(path)) from None
    try:
        with handle:
            yield handle
        umask = os.umask(0)  # read the umask (there is no getter) and restore it
        os.umask(umask)
        os.chmod(handle.name, 0o666 & ~umask)  # temporary files are created 0600
        os.replace(handle.name, path)
    except BaseException:
        Path(handle.name).unlink(missing_ok=True)
        raise
