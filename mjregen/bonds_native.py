"""Native bond backend: all bond tendons of a robot as one C loop in MuJoCo's passive callback.

`mjregen.compile` describes every bond tendon in a `BondTable` (sites, stiffness, damping,
rest length, muscle drive). With the native backend the simulated model has the voxel bodies,
contacts and joints but no sites or tendons; `native/bonds.c` computes the tendons' spring,
damper and muscle-drive forces from ``qpos``/``qvel`` and adds them to ``qfrc_passive``, so
MuJoCo still integrates, collides and solves contacts. The tendon model stays the exported
MJCF (`CompiledRobot.to_xml`) and gives the same motion (tests/test_native.py).

The C files (`native/bonds.c`, and `native/step.c` for `mjregen.stepping`) are compiled on first use with the system C compiler (``$CC``, else ``cc``/``gcc``)
against the headers that ship in the installed ``mujoco`` wheel; the library is cached under
``$MJREGEN_CACHE`` (default ``~/.cache/mjregen``), keyed by the source and MuJoCo version.
It reads only struct fields (no MuJoCo calls), so it needs no link to ``libmujoco``.

The callback is process-global (``mujoco.set_mjcb_passive``); per-robot state is registered
per ``MjData`` (`attach`), so any number of simulations — in threads too — can run at once,
and models without registered bonds are untouched.
"""

from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
import threading
import weakref
from pathlib import Path

import mujoco
import numpy as np

from mjregen.compile import BeamTable
from mjregen.errors import MjregenError

SOURCES = (Path(__file__).with_name("native") / "bonds.c",
           Path(__file__).with_name("native") / "step.c")  # step.c: `mjregen.stepping`
_lock = threading.Lock()
_library: ctypes.CDLL | None = None
_callback = None  # the ctypes function pointer handed to MuJoCo (kept alive here)


class NativeBuildError(MjregenError, RuntimeError):
    """The native bond library could not be built or loaded (no C compiler, no headers)."""


class _Bonds(ctypes.Structure):
    _fields_ = [
        ("dim", ctypes.c_int), ("nvox", ctypes.c_int), ("nten", ctypes.c_int),
        ("nmus", ctypes.c_int), ("contract", ctypes.c_int), ("rate_drive", ctypes.c_int),
        ("voxel_size", ctypes.c_double), ("start", ctypes.c_double),
        ("omega", ctypes.c_double), ("dt", ctypes.c_double),
        ("qadr", ctypes.c_void_p), ("vadr", ctypes.c_void_p), ("pos0", ctypes.c_void_p),
        ("ends", ctypes.c_void_p), ("off", ctypes.c_void_p), ("k", ctypes.c_void_p),
        ("c", ctypes.c_void_p), ("rest", ctypes.c_void_p), ("plus", ctypes.c_void_p),
        ("minus", ctypes.c_void_p), ("lat2", ctypes.c_void_p), ("plus_c", ctypes.c_void_p),
        ("minus_c", ctypes.c_void_p), ("scratch", ctypes.c_void_p),
        ("floor", ctypes.c_int), ("waves", ctypes.c_int),
        ("fk", ctypes.c_void_p), ("fc", ctypes.c_void_p), ("mu_s", ctypes.c_void_p),
        ("mu_k", ctypes.c_void_p), ("mass", ctypes.c_void_p), ("half_p", ctypes.c_void_p),
        ("half_m", ctypes.c_void_p), ("strain_in", ctypes.c_void_p),
        ("drag_lin", ctypes.c_double), ("drag_rot", ctypes.c_double), ("collide", ctypes.c_int),
        ("coll_radius", ctypes.c_double), ("coll_skin", ctypes.c_double),
        ("coll_reach", ctypes.c_double), ("grid", ctypes.c_void_p), ("surface", ctypes.c_void_p),
        ("coll_ref", ctypes.c_void_p), ("coll_pairs", ctypes.c_void_p),
        ("coll_count", ctypes.c_void_p),
        ("nbeam", ctypes.c_int), ("beam_nmus", ctypes.c_int), ("beam_ends", ctypes.c_void_p),
        ("beam_axis", ctypes.c_void_p), ("beam_k", ctypes.c_void_p), ("beam_law", ctypes.c_void_p),
        ("beam_beta", ctypes.c_void_p), ("beam_plus", ctypes.c_void_p),
        ("beam_minus", ctypes.c_void_p),
    ]

SCRATCH_WIDTH = 28  # doubles per voxel in the C loop's scratch (bonds.c: SW)

COLLISION_SKIN = 0.5  # Verlet-list skin of the native self-collision, in voxel lengths


def _compiler() -> str | None:
    for name in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def library_path() -> Path:
    """Where the compiled library for this source and MuJoCo version lives (may not exist)."""
    key = hashlib.sha256(b"".join(source.read_bytes() for source in SOURCES)
                         + mujoco.__version__.encode()
                         + mujoco.__file__.encode()).hexdigest()[:16]
    root = Path(os.environ.get("MJREGEN_CACHE",
                               Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
                               / "mjregen"))
    return root / f"bonds-{key}.so"


def build(path: Path | None = None) -> Path:
    """Compile `native/bonds.c` to `path` (default `library_path()`); atomic, idempotent.

    Raises:
      NativeBuildError: no C compiler, no MuJoCo headers, or the compiler failed.
    """
    path = library_path() if path is None else path
    if path.exists():
        return path
    compiler = _compiler()
    if compiler is None:
        raise NativeBuildError(
            "the native bond backend needs a C compiler (set $CC or install gcc/clang), or "
            "use Scene(bond_backend='tendon')")
    include = Path(mujoco.__file__).parent / "include"
    if not (include / "mujoco" / "mujoco.h").exists():
        raise NativeBuildError(f"MuJoCo's C headers are missing under {include}; install a "
                               "mujoco wheel that ships them, or use bond_backend='tendon'")
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
        out = Path(tmp) / path.name
        command = [compiler, "-O3", "-std=c11", "-fPIC", "-shared", "-fno-fast-math",
                   f"-I{include}", *map(str, SOURCES), "-o", str(out), "-lm", "-lpthread"]
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            raise NativeBuildError(f"building the native bond library failed:\n{' '.join(command)}"
                                   f"\n{done.stderr.strip()}")
        os.replace(out, path)  # atomic: concurrent builders (worker processes) agree
    return path


_unavailable_logged = False


def available() -> bool:
    """True when the native library is built or can be built here (if not, says why once
    in the log: "auto" then uses MuJoCo tendons, the same forces, slower)."""
    global _unavailable_logged
    try:
        _load()
    except NativeBuildError as error:
        if not _unavailable_logged:
            logging.getLogger(__name__).warning(
                "native bond backend unavailable, using MuJoCo tendons: %s", error)
            _unavailable_logged = True
        return False
    return True


def _load() -> ctypes.CDLL:
    """The library, built and loaded on first use, with MuJoCo's passive callback set."""
    global _library, _callback
    with _lock:
        if _library is not None:
            return _library
        library = ctypes.CDLL(str(build()))
        library.mjr_register.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
        library.mjr_register.restype = ctypes.c_int
        library.mjr_unregister.argtypes = [ctypes.c_void_p]
        library.mjr_unregister.restype = None
        library.mjr_registered.restype = ctypes.c_int
        library.mjr_step.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
                                     ctypes.c_int, ctypes.c_void_p]
        library.mjr_step.restype = ctypes.c_int
        library.mjr_passive.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
        library.mjr_passive.restype = None
        library.mjr_step_refresh.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
        library.mjr_step_refresh.restype = None
        current = mujoco.get_mjcb_passive()
        if current is not None:
            raise NativeBuildError(
                "mujoco's passive-force callback (mjcb_passive) is already set by someone "
                "else; the native bond backend needs it (or use bond_backend='tendon')")
        callback = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)(
            ctypes.cast(library.mjr_passive, ctypes.c_void_p).value)
        mujoco.set_mjcb_passive(callback)
        _library, _callback = library, callback
        return library


def library() -> ctypes.CDLL:
    """The loaded native library (built on first use; raises NativeBuildError)."""
    return _load()


def registered() -> int:
    """Number of MjData with bonds attached (for tests)."""
    return _load().mjr_registered() if _library is not None else 0


class NativeBonds:
    """The C-side description of one robot's bonds for one MjData; see `attach`.

    `table` is a `BondTable` (the bonds' tendons) or a `BeamTable` (one beam per bond; then
    the muscle drive comes from the table itself and `muscles` only says whether there are
    muscles).
    """

    def __init__(self, model: mujoco.MjModel, table, *, voxel_bodies: np.ndarray,
                 dim: int, muscles=None, scene=None, actuation_start: float = 0.0,
                 engine_contacts=None, external_strains: bool = False) -> None:
        n_vox = len(voxel_bodies)
        qadr = np.full(n_vox, -1, dtype=np.int32)
        vadr = np.full(n_vox, -1, dtype=np.int32)
        pos0 = np.array(model.body_pos[voxel_bodies], dtype=np.float64)
        for v, body in enumerate(voxel_bodies):
            if model.body_jntnum[body] > 0:
                joint = model.body_jntadr[body]
                qadr[v] = model.jnt_qposadr[joint]
                vadr[v] = model.jnt_dofadr[joint]
        beams = isinstance(table, BeamTable)
        self.arrays = {"qadr": qadr, "vadr": vadr, "pos0": pos0,
                       "scratch": np.zeros((n_vox, SCRATCH_WIDTH))}
        struct = _Bonds(dim=dim, nvox=n_vox, nten=0, nmus=0, contract=1, rate_drive=0,
                        voxel_size=0.0, start=actuation_start, omega=0.0,
                        dt=float(model.opt.timestep))
        if scene is not None:
            struct.voxel_size = scene.voxel_size
            struct.contract = int(scene.waveform == "contract")
            struct.omega = 2.0 * np.pi * scene.frequency
        if beams:
            if scene is None:
                raise ValueError("beam bonds need the scene (voxel size, actuation)")
            length = scene.voxel_size
            self.arrays.update(
                beam_ends=np.ascontiguousarray(table.ends, dtype=np.int32),
                beam_axis=np.ascontiguousarray(table.axis, dtype=np.int32),
                beam_k=np.ascontiguousarray(table.stiffness, dtype=np.float64),
                beam_law=np.ascontiguousarray(table.axial_law, dtype=np.float64),
                beam_beta=np.ascontiguousarray(table.beta, dtype=np.float64),
                beam_plus=length * table.muscle_weights[:, 0],
                beam_minus=length * table.muscle_weights[:, 1])
            struct.nbeam = table.count
            struct.beam_nmus = len(table.muscle_weights)
            if struct.beam_nmus:
                struct.waves = 1
                struct.rate_drive = int(scene.damp_strain_rate)
        else:
            self.arrays.update(
                ends=np.ascontiguousarray(table.ends, dtype=np.int32),
                off=np.ascontiguousarray(table.offsets, dtype=np.float64),
                k=np.ascontiguousarray(table.stiffness, dtype=np.float64),
                c=np.ascontiguousarray(table.damping, dtype=np.float64),
                rest=np.ascontiguousarray(table.rest, dtype=np.float64))
            struct.nten = len(table.stiffness)
        contacts = engine_contacts
        if contacts is not None:
            if model.nuserdata < n_vox:
                raise ValueError(f"the engine floor keeps a stick flag per voxel in "
                                 f"MjData.userdata: the model needs nuserdata >= {n_vox}, "
                                 f"has {model.nuserdata}")
            self.arrays.update(fk=contacts.stiffness, fc=contacts.damping,
                               mu_s=contacts.static_friction, mu_k=contacts.kinetic_friction,
                               mass=contacts.mass, half_p=contacts.half_plus,
                               half_m=contacts.half_minus)
            struct.floor = int(contacts.floor)
            struct.waves = int(struct.waves or np.any(contacts.half_plus)
                               or np.any(contacts.half_minus))
            struct.drag_lin, struct.drag_rot = contacts.drag_linear, contacts.drag_rotational
            colliders = int(np.count_nonzero(contacts.surface))
            if contacts.collision_radius > 0.0 and colliders > 1:
                length = scene.voxel_size
                largest = 1.0 + 2.0 * max(float(np.max(contacts.half_plus)),
                                          float(np.max(contacts.half_minus))) / length
                self.arrays.update(
                    grid=np.ascontiguousarray(contacts.grid_index, dtype=np.int32),
                    surface=contacts.surface.astype(np.int32), coll_ref=np.zeros((n_vox, 3)),
                    coll_pairs=np.zeros((colliders * (colliders - 1) // 2, 2), dtype=np.int32),
                    coll_count=np.zeros(2, dtype=np.int32))
                struct.collide = 1
                struct.coll_radius = contacts.collision_radius
                struct.coll_reach = 2.0 * contacts.collision_radius * largest
                struct.coll_skin = COLLISION_SKIN * length
        if muscles is not None and muscles.count and not beams:
            length = muscles.voxel_size
            plus, minus = length * muscles.weights[:, 0], length * muscles.weights[:, 1]
            self.arrays.update(plus=plus, minus=minus, lat2=muscles.lateral ** 2)
            struct.nmus = muscles.count
            struct.waves = 1
            if scene.damp_strain_rate:
                damping = np.asarray(table.damping[: muscles.count])
                self.arrays.update(plus_c=damping * plus, minus_c=damping * minus)
                struct.rate_drive = 1
        if external_strains:
            # the caller writes (e+, e-) here before each step instead of the waveform
            self.arrays["strain_in"] = np.zeros(2)
        for name, array in self.arrays.items():
            self.arrays[name] = np.ascontiguousarray(array)
            setattr(struct, name, self.arrays[name].ctypes.data)
        self.struct = struct

    def attach(self, owner: object, data: mujoco.MjData) -> None:
        """Register these bonds for `data` until `owner` is garbage-collected."""
        library = _load()
        if not library.mjr_register(data._address, ctypes.addressof(self.struct)):
            raise MemoryError("could not register native bonds")
        # the finalizer holds self (the arrays) and data alive until it unregisters them
        weakref.finalize(owner, _release, library, data._address, self, data)


def _release(library: ctypes.CDLL, address: int, *keep: object) -> None:
    """Finalizer: unregister the bonds of the MjData at `address` (`keep` dies after)."""
    library.mjr_unregister(address)
