"""The repository's scripts and benchmarks, loaded as modules for the tests that check them
(they are command-line files, not part of the installed package)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parent.parent


def load_module(relative: str) -> ModuleType:
    """The file ``ROOT/relative`` (e.g. ``"benchmarks/speed.py"``) as a fresh module named
    after its stem, registered in ``sys.modules`` (its dataclasses and pickled objects look
    their module up there)."""
    path = ROOT / relative
    if not path.is_file():
        raise FileNotFoundError(f"no such script or benchmark: {path}")
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module
