"""Where the voxel plugin's compiled library lives, found without importing MuJoCo (so that
command-line help and start-up stay cheap).

The library is compiled for the machine it is built on (``-march=native``: the vector
instructions of this CPU), with the IEEE arithmetic of the source as written (no fused
multiply-add, no reassociation: the same numbers as any other build). Its file name is keyed
by the plugin's sources, the compiler flags, this CPU's instruction set, the installed MuJoCo
version and where it is installed, so that a cache folder shared by different machines (a
cluster's home directory) holds one library per kind of CPU; the folder is ``$MJREGEN_CACHE``, else ``$XDG_CACHE_HOME/mjregen``, else
``~/.cache/mjregen``.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import importlib.util
import os
import platform
from pathlib import Path

PLUGIN_SOURCES = Path(__file__).with_name("physics") / "plugin"
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
                         + " ".join(FLAGS).encode() + cpu_features().encode()
                         + version.encode() + str(origin).encode()).hexdigest()[:16]
    root = Path(os.environ.get("MJREGEN_CACHE",
                               Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
                               / "mjregen"))
    return root / f"libmjregen_voxels-{key}.so"
