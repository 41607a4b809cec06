"""Where the voxel plugin's compiled library lives, and the flags it is compiled with.

The library is compiled for the machine it is built on (``-march=native``: the vector
instructions of this CPU), with the IEEE arithmetic of the source as written (no fused
multiply-add, no reassociation: every CPU computes the same numbers, given the same C
library). Its file name is keyed by the plugin's sources, the compiler flags, this CPU's
instruction set and the installed MuJoCo library (path, size and modification time: a new
MuJoCo is a new library), so that a cache folder shared by different machines (a cluster's
home directory) holds one library per kind of CPU. The folder is ``$MJREGEN_CACHE``, else
``$XDG_CACHE_HOME/mjregen``, else ``~/.cache/mjregen`` (empty variables count as unset).
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import os
import platform
from pathlib import Path

PLUGIN_SOURCES = Path(__file__).with_name("plugin")
PLUGIN_FILES = ("voxels.h", "voxels.c", "forces.c", "step.c")
FLAGS = ("-O3", "-march=native", "-std=c11", "-fPIC", "-shared", "-fno-fast-math",
         "-ffp-contract=off", "-fno-math-errno", "-fno-trapping-math")


def cpu_features() -> str:
    """This CPU's model and instruction-set flags (Linux: /proc/cpuinfo), else the platform's
    description: what ``-march=native`` compiles for."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return f"{platform.machine()} {platform.processor()}"
    wanted = ("model name", "flags", "Features", "CPU part")
    seen = {line.split(":", 1)[0].strip(): line for line in lines
            if line.split(":", 1)[0].strip() in wanted}
    return "\n".join(sorted(seen.values()))


def mujoco_libraries() -> list[Path]:
    """The installed ``mujoco`` package's shared libraries (``libmujoco*``), found without
    importing it: what the plugin links against."""
    spec = importlib.util.find_spec("mujoco")
    if spec is None or spec.origin is None:
        raise ModuleNotFoundError("the mujoco package is not installed")
    root = Path(spec.origin).parent
    return sorted(root.glob("libmujoco.so*")) + sorted(root.glob("libmujoco*.dylib"))


@functools.lru_cache(maxsize=None)
def _key(sources: bytes, libraries: tuple[tuple[str, int, int], ...]) -> str:
    digest = hashlib.sha256(sources + " ".join(FLAGS).encode() + cpu_features().encode()
                            + repr(libraries).encode())
    return digest.hexdigest()[:16]


def library_path() -> Path:
    """The plugin library's path for these sources and this MuJoCo (built or not)."""
    sources = b"".join((PLUGIN_SOURCES / name).read_bytes() for name in PLUGIN_FILES)
    libraries = tuple((str(path), path.stat().st_size, path.stat().st_mtime_ns)
                      for path in mujoco_libraries())
    # an empty variable counts as unset; a relative folder is taken from the working
    # directory (the loader is handed an absolute path)
    root = Path(os.environ.get("MJREGEN_CACHE")
                or Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "mjregen")
    return root.absolute() / f"libmjregen_voxels-{_key(sources, libraries)}.so"
