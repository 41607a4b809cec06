"""MuJoCo's OpenGL backend (``MUJOCO_GL``), checked before MuJoCo is imported: importing
MuJoCo with a backend whose library is missing fails inside PyOpenGL with no useful
message, even for work that never renders."""

from __future__ import annotations

import os

HEADLESS_BACKENDS = ("egl", "osmesa")  # tried in this order when MUJOCO_GL is not set
BACKENDS = HEADLESS_BACKENDS + ("glfw",)
LIBRARIES = {"egl": "EGL", "osmesa": "OSMesa"}  # what each backend loads
INSTALL_HINT = {
    "egl": "EGL: apt-get install libegl1 libgl1-mesa-dri (Mesa, renders on the CPU) or a GPU "
           "driver with EGL",
    "osmesa": "OSMesa: apt-get install libosmesa6",
    "glfw": "GLFW: needs a display (DISPLAY set) and pip install glfw",
}


def requested_backend() -> str:
    """``MUJOCO_GL`` as the user set it, lower case ("" when unset)."""
    return os.environ.get("MUJOCO_GL", "").strip().lower()


def missing_library(backend: str) -> str | None:
    """Why `backend` cannot load (its system library is not installed), or None."""
    library = LIBRARIES.get(backend)
    if library is None:
        return None
    import ctypes.util  # only when a backend is named: its import and search cost time

    if ctypes.util.find_library(library) is None:
        return (f"MUJOCO_GL={backend}, but lib{library} is not installed "
                f"({INSTALL_HINT[backend]}; or unset MUJOCO_GL to choose automatically)")
    return None


def disable_for_work_without_rendering() -> None:
    """Tell MuJoCo (not yet imported) to load no OpenGL at all: for work that never renders,
    so that a ``MUJOCO_GL`` naming a missing library cannot stop it."""
    os.environ["MUJOCO_GL"] = "disable"
