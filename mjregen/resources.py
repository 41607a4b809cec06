"""Files shipped with the package (`mjregen.assets`): found with importlib.resources, so they
are there after any install (wheel, ``pip install .``, editable)."""

from __future__ import annotations

import importlib.resources
from pathlib import Path

from mjregen.errors import MjregenError

PAPER_ROBOTS = ("biped", "tripod", "multiped")  # the paper's evolved robots, assets/robots/paper


def asset(*parts: str) -> Path:
    """Path of a shipped file, e.g. ``asset("robots", "paper", "tripod.npy")``.

    Raises:
      MjregenError: no such asset (the message lists the folder's contents).
    """
    root = importlib.resources.files("mjregen.assets")
    path = Path(str(root.joinpath(*parts)))
    if not path.exists():
        folder = path.parent
        there = sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []
        raise MjregenError(f"no shipped asset {'/'.join(parts)} (in {folder}: "
                           f"{', '.join(there) or 'nothing'})")
    return path
