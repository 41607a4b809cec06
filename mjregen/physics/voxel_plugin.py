"""The voxel plugin's library: built on first use with the system C compiler, loaded into
MuJoCo with ``mujoco.mj_loadPluginLibrary``.

`plugin_library()` is the path of the shared library that registers the engine plugin
``mjregen.voxels`` (sources in ``plugin/``: voxels.c, forces.c, step.c, one header). It is
compiled against the headers and linked against the ``libmujoco`` of the installed
``mujoco`` wheel, and cached under ``$MJREGEN_CACHE`` (default ``~/.cache/mjregen``), keyed by
the sources and the MuJoCo version, so every process and every worker finds the same file.
Any MuJoCo program loads an exported robot after one call::

    mujoco.mj_loadPluginLibrary(path)   # path = mjregen.plugin_library()
    model = mujoco.MjModel.from_xml_path("robot.xml")

`library()` loads it in this process (registering the plugin) and returns it as a ctypes
library, whose two extra entry points (`mjr_step`, `mjr_network_forces`) the fast stepper
and the time-step rule call. On load the configuration attributes the plugin registers are
checked against `ATTRIBUTES`, the keys `mjregen.physics.mjcf` writes.
"""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
import tempfile
import threading
from pathlib import Path

import mujoco

from mjregen.errors import MjregenError
from mjregen.plugin_cache import FLAGS, PLUGIN_FILES, PLUGIN_SOURCES, library_path, mujoco_libraries

PLUGIN_NAME = "mjregen.voxels"
SOURCES = tuple(PLUGIN_SOURCES / name for name in PLUGIN_FILES if name.endswith(".c"))
ATTRIBUTES = (
    "dim", "voxel_size", "voxels", "frequency", "start", "waveform", "drive", "phase", "strain",
    "element", "bonds", "bond_axis", "bond_muscle", "bond_stiffness", "bond_axial_law",
    "bond_beta", "tendon_bond", "tendon_sites", "tendon_stiffness", "tendon_damping",
    "tendon_rest", "tendon_lateral2", "floor", "floor_stiffness", "floor_damping",
    "static_friction", "kinetic_friction", "friction_stop", "friction_stop_time",
    "collision_radius",
    "collision_skin", "collision_stiffness", "collision_damping", "collision_hops", "grid",
    "collides", "drag_linear", "drag_rotational",
)

_lock = threading.Lock()
_library: ctypes.CDLL | None = None


class NativeBuildError(MjregenError, RuntimeError):
    """The voxel plugin library could not be built or loaded (no C compiler, no headers)."""


def _compiler() -> str | None:
    for name in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def _mujoco_library() -> Path:
    """The wheel's libmujoco (the one the Python bindings use)."""
    candidates = mujoco_libraries()
    if not candidates:
        raise NativeBuildError("no libmujoco shared library next to the mujoco package in "
                               f"{Path(mujoco.__file__).parent}")
    return candidates[0]


def plugin_library() -> Path:
    """Path of the shared library that registers the ``mjregen.voxels`` MuJoCo plugin,
    compiled on first call (atomic: concurrent builders agree).

    Raises:
      NativeBuildError: no C compiler, no MuJoCo headers, or the compiler failed.
    """
    path = library_path()
    if path.exists():
        return path
    compiler = _compiler()
    if compiler is None:
        raise NativeBuildError(
            "the voxel plugin needs a C compiler (set $CC or install gcc or clang); without "
            "one, use the pure-MuJoCo pipeline (mjregen.physics.sphere_physics())")
    include = Path(mujoco.__file__).parent / "include"
    if not (include / "mujoco" / "mujoco.h").exists():
        raise NativeBuildError(f"MuJoCo's C headers are missing under {include}; install a "
                               "mujoco wheel that ships them")
    libmujoco = _mujoco_library()
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
        out = Path(tmp) / path.name
        command = [compiler, *FLAGS, f"-I{include}", *map(str, SOURCES), "-o", str(out),
                   str(libmujoco), f"-Wl,-rpath,{libmujoco.parent}", "-lm"]
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0 and "march" in done.stderr:
            # a compiler that does not know -march=native (Apple's clang on arm64): the
            # generic build computes the same numbers (strict IEEE either way), more slowly
            command = [word for word in command if not word.startswith("-march")]
            done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            raise NativeBuildError(f"building the voxel plugin failed:\n{' '.join(command)}"
                                   f"\n{done.stderr.strip()}")
        os.replace(out, path)
    return path


def library() -> ctypes.CDLL:
    """The plugin library, built, registered with MuJoCo and loaded in this process."""
    global _library
    with _lock:
        if _library is not None:
            return _library
        path = plugin_library()
        mujoco.mj_loadPluginLibrary(str(path))
        loaded = ctypes.CDLL(str(path))  # the same handle: dlopen counts references
        loaded.mjr_attribute.argtypes = [ctypes.c_int]
        loaded.mjr_attribute.restype = ctypes.c_char_p
        loaded.mjr_step.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int,
                                    ctypes.c_int, ctypes.c_void_p]
        loaded.mjr_step.restype = ctypes.c_int
        loaded.mjr_network_forces.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int]
        loaded.mjr_network_forces.restype = None
        loaded.mjr_step_masses.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
        loaded.mjr_step_masses.restype = None
        registered = []
        while (name := loaded.mjr_attribute(len(registered))) is not None:
            registered.append(name.decode())
        if tuple(registered) != ATTRIBUTES:
            raise NativeBuildError(
                f"the voxel plugin at {path} registers the attributes {registered}, this "
                f"package writes {list(ATTRIBUTES)}: the cached library is stale; delete it")
        _library = loaded
        return loaded


def available() -> bool:
    """True when the plugin library is built or can be built here."""
    try:
        library()
    except NativeBuildError:
        return False
    return True
