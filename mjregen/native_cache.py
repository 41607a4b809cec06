"""Where the voxel plugin's compiled library lives, found without importing MuJoCo (so that
command-line help and start-up stay cheap).

The file name is keyed by the plugin's sources, the installed MuJoCo version and where it is
installed; the folder is ``$MJREGEN_CACHE``, else ``$XDG_CACHE_HOME/mjregen``, else
``~/.cache/mjregen``.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import importlib.util
import os
from pathlib import Path

PLUGIN_SOURCES = Path(__file__).with_name("physics") / "plugin"
PLUGIN_FILES = ("voxels.h", "voxels.c", "forces.c", "step.c")


def mujoco_location() -> tuple[str, Path]:
    """(version, path of the package's ``__init__.py``) of the installed ``mujoco``."""
    spec = importlib.util.find_spec("mujoco")
    if spec is None or spec.origin is None:
        raise ModuleNotFoundError("the mujoco package is not installed")
    return importlib.metadata.version("mujoco"), Path(spec.origin)


def library_path() -> Path:
    """The plugin library's path for these sources and this MuJoCo (built or not)."""
    version, origin = mujoco_location()
    key = hashlib.sha256(b"".join((PLUGIN_SOURCES / name).read_bytes() for name in PLUGIN_FILES)
                         + version.encode() + str(origin).encode()).hexdigest()[:16]
    root = Path(os.environ.get("MJREGEN_CACHE",
                               Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
                               / "mjregen"))
    return root / f"libmjregen_voxels-{key}.so"
