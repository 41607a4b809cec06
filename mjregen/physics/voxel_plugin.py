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
checked against `ATTRIBUTES`, the keys `mjregen.physics.mjcf` writes, which are read from the
one table that declares them, ``MJR_ATTRIBUTES`` in ``plugin/voxels.h``.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import re
import shutil
import subprocess
import tempfile
import threading
import time
from pathlib import Path

import mujoco

from mjregen.errors import MjregenError
from mjregen.physics.plugin_cache import (
    FLAGS,
    PLUGIN_FILES,
    PLUGIN_SOURCES,
    library_path,
    mujoco_libraries,
)

PLUGIN_NAME = "mjregen.voxels"
STALE_BUILD_S = 3600.0  # a build folder left this long ago was a build killed halfway
SOURCES = tuple(PLUGIN_SOURCES / name for name in PLUGIN_FILES if name.endswith(".c"))


_lock = threading.Lock()
_library: ctypes.CDLL | None = None


class NativeBuildError(MjregenError, RuntimeError):
    """The voxel plugin library could not be built or loaded (no C compiler, no headers)."""


def declared_attributes(header: Path = PLUGIN_SOURCES / "voxels.h") -> tuple[str, ...]:
    """The configuration attributes the plugin's header declares, in order: the ``X(name)``
    entries of its ``MJR_ATTRIBUTES`` table (the C code registers and parses the same list).

    Raises:
      NativeBuildError: the header has no such table.
    """
    lines = header.read_text().splitlines()
    start = next((i for i, line in enumerate(lines)
                  if line.startswith("#define MJR_ATTRIBUTES(X)")), None)
    if start is None:
        raise NativeBuildError(f"{header} declares no MJR_ATTRIBUTES table")
    table = [lines[start]]
    while table[-1].rstrip().endswith("\\"):
        table.append(lines[start + len(table)])
    return tuple(re.findall(r"\bX\((\w+)\)", "\n".join(table)))


ATTRIBUTES = declared_attributes()


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


def _digest_file(path: Path) -> Path:
    """The file beside a built library that holds its sha256."""
    return path.with_name(path.name + ".sha256")


def _intact(path: Path) -> bool:
    """`path` is a library this package built, whole: its bytes match the digest written
    beside it when it was built (a truncated or damaged file, or one without a digest, is
    built again rather than loaded: loading it could crash the process)."""
    try:
        recorded = _digest_file(path).read_text().strip()
        return recorded == hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return False


def plugin_library() -> Path:
    """Path of the shared library that registers the ``mjregen.voxels`` MuJoCo plugin,
    compiled on first call, and again when the cached file is not whole (atomic: concurrent
    builders agree).

    Raises:
      NativeBuildError: no C compiler, no MuJoCo headers, the compiler failed, or the cache
        folder cannot be written.
    """
    path = library_path()
    if _intact(path):
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
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return _build(compiler, include, libmujoco, path)
    except OSError as error:
        raise NativeBuildError(
            f"the voxel plugin's cache folder {path.parent} cannot be written "
            f"({error.strerror or error}); set $MJREGEN_CACHE to a writable folder") from None


def _build(compiler: str, include: Path, libmujoco: Path, path: Path) -> Path:
    """Compile the plugin into `path`, with its digest beside it (each replaced atomically;
    a build killed halfway leaves only its temporary folder, removed on the next build)."""
    for debris in path.parent.glob("tmp*"):
        if debris.is_dir() and time.time() - debris.stat().st_mtime > STALE_BUILD_S:
            shutil.rmtree(debris, ignore_errors=True)
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
        digest = Path(tmp) / _digest_file(path).name
        digest.write_text(hashlib.sha256(out.read_bytes()).hexdigest())
        os.replace(out, path)
        os.replace(digest, _digest_file(path))
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
