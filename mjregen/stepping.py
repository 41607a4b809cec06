"""Native stepper: MuJoCo's Euler step for a robot of free voxel bodies, in one C loop.

With native bonds and the engine's contacts every force on a voxel comes from the native
passive callback (`mjregen.bonds_native`), and MuJoCo's step has nothing left to do but
integrate independent rigid bodies — through its generic pipeline (kinematics, composite
inertia, factorisation, recursive Newton–Euler), about half the cost of a step. For the
models `mjregen.compile` builds (each voxel a child of the world, centre of mass at its
joint, isotropic inertia, no joint damping, actuators, constraints or fluid) those equations
reduce to a constant diagonal mass matrix and a constant gravity force, which
`native/step.c` integrates exactly like ``mj_step`` with the Euler integrator (same order,
same quaternion update, same bad-value warnings), to rounding (tests/test_stepping.py).

`unsupported(model)` says why a model does not qualify (then `Scene.stepper` "auto" steps
with ``mj_step``). Each `NativeStepper.step` call reads the masses, inertias, gravity and
time step from the model (so changing them between calls acts as in MuJoCo); on creation
the stepper checks that these give MuJoCo's own mass matrix and gravity force. It does not
update derived quantities (``xpos``, ``subtree_com``, ...): call ``mj_kinematics`` after
stepping, as `Simulation.run` does. ``qfrc_applied`` is applied; ``xfrc_applied`` is not
(`NativeStepper.step` refuses a non-zero one).
"""

from __future__ import annotations

import ctypes

import mujoco
import numpy as np

from mjregen import bonds_native

_FREE, _SLIDE, _HINGE = (int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_SLIDE),
                         int(mujoco.mjtJoint.mjJNT_HINGE))
_FIXED_BODY, _FREE_BODY, _PLANAR_BODY = 0, 1, 2  # step.c: com_kind
_PLANAR_AXES = np.eye(3)[[0, 2, 1]]  # 2D voxels: slide x, slide z, hinge y


class _Stepper(ctypes.Structure):
    _fields_ = [
        ("nv", ctypes.c_int), ("inv_mass", ctypes.c_void_p),
        ("gravity", ctypes.c_void_p), ("ncom", ctypes.c_int), ("com_kind", ctypes.c_void_p),
        ("com_qadr", ctypes.c_void_p), ("com_pos0", ctypes.c_void_p),
        ("com_mass", ctypes.c_void_p),
    ]


def _body_kind(model: mujoco.MjModel, body: int) -> int | None:
    """How step.c finds the body's position: fixed, free joint, or planar (slide x, slide z,
    hinge y); None for any other joint set."""
    first, count = model.body_jntadr[body], model.body_jntnum[body]
    if count == 0:
        return _FIXED_BODY
    types = model.jnt_type[first: first + count].tolist()
    if types == [_FREE]:
        return _FREE_BODY
    axes = model.jnt_axis[first: first + count]
    if types == [_SLIDE, _SLIDE, _HINGE] and np.array_equal(axes, _PLANAR_AXES):
        return _PLANAR_BODY
    return None


def unsupported(model: mujoco.MjModel) -> str:
    """"" if the native stepper integrates `model` exactly as ``mj_step``, else why not."""
    disabled = model.opt.disableflags
    needs_off = mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    checks = [
        (model.opt.integrator != mujoco.mjtIntegrator.mjINT_EULER, "the integrator is not Euler"),
        ((disabled & needs_off) != needs_off, "MuJoCo contacts or constraints are enabled"),
        (model.nu or model.na or model.neq or model.ntendon or model.nsensor or model.nflex,
         "the model has actuators, equalities, tendons, sensors or flexes"),
        (model.opt.viscosity != 0.0 or model.opt.density != 0.0, "fluid forces are on"),
        (model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_ENERGY, "energy is computed"),
        (np.any(model.body_parentid[1:] != 0), "a body has a parent other than the world"),
        (np.any(model.body_gravcomp != 0.0), "a body has gravity compensation"),
        (np.any(model.dof_damping != 0.0) or np.any(model.dof_armature != 0.0)
         or np.any(model.dof_frictionloss != 0.0) or np.any(model.jnt_stiffness != 0.0)
         or np.any(model.jnt_limited),
         "a joint has damping, armature, friction, a spring or a limit"),
    ]
    for failed, reason in checks:
        if failed:
            return reason
    kinds = [_body_kind(model, body) for body in range(1, model.nbody)]
    if None in kinds:
        return (f"body {kinds.index(None) + 1} has joints other than one free joint or "
                "slide x, slide z, hinge y")
    moving = model.body_jntnum[1:] > 0
    if np.any(model.body_ipos[1:][moving] != 0.0) or np.any(model.jnt_pos != 0.0):
        return "a body's centre of mass or joint is off its origin"
    inertia = model.body_inertia[1:][moving]
    if inertia.size and np.any(np.ptp(inertia, axis=1) > 1e-12 * np.max(inertia, axis=1)):
        return "a body's inertia is not isotropic"
    return ""


class NativeStepper:
    """Steps one MjData of a supported model (`unsupported`) in C; see the module doc."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, *,
                 checked: bool = False) -> None:
        """`checked`: the caller has just seen `unsupported(model)` return ""."""
        reason = "" if checked else unsupported(model)
        if reason:
            raise ValueError(f"the native stepper cannot step this model: {reason}")
        kinds = np.array([_body_kind(model, b) for b in range(1, model.nbody)], dtype=np.int32)
        qadr = np.array([model.jnt_qposadr[model.body_jntadr[b]] if model.body_jntnum[b] else 0
                         for b in range(1, model.nbody)], dtype=np.int32)
        mass = model.body_mass[1:] / max(float(np.sum(model.body_mass[1:])), 1e-300)
        self._arrays = {"inv_mass": np.zeros(model.nv), "gravity": np.zeros(model.nv),
                        "com_kind": kinds,
                        "com_qadr": qadr,
                        "com_pos0": np.ascontiguousarray(model.body_pos[1:], dtype=np.float64),
                        "com_mass": np.ascontiguousarray(mass, dtype=np.float64)}
        struct = _Stepper(nv=model.nv, ncom=model.nbody - 1)
        for name, array in self._arrays.items():
            setattr(struct, name, array.ctypes.data)
        self._struct = struct
        self._model, self._data = model, data
        self._library = bonds_native.library()
        self._library.mjr_step_refresh(model._address, ctypes.addressof(struct))
        _check_against_mujoco(model, data, self._arrays["inv_mass"], self._arrays["gravity"])

    def step(self, n_steps: int, com: np.ndarray | None = None) -> int:
        """Advance up to `n_steps` steps; returns the number done (fewer after a bad value,
        with MuJoCo's warning recorded in ``data.warning``).

        Args:
          com: optional C-contiguous float64 ``(n_steps, 3)`` array, filled with the centre
            of mass (m) at the start of each step.
        """
        if np.any(self._data.xfrc_applied):
            raise ValueError("the native stepper does not apply xfrc_applied (use "
                             "qfrc_applied, or Scene(stepper='mujoco'))")
        pointer = None
        if com is not None:
            if com.shape != (n_steps, 3) or com.dtype != np.float64 \
                    or not com.flags.c_contiguous:
                raise ValueError(f"com must be a C-contiguous float64 ({n_steps}, 3) array")
            pointer = com.ctypes.data
        return self._library.mjr_step(self._model._address, self._data._address,
                                      ctypes.addressof(self._struct), int(n_steps), pointer)


def _check_against_mujoco(model: mujoco.MjModel, data: mujoco.MjData, inv_mass: np.ndarray,
                          gravity: np.ndarray) -> None:
    """Raise ValueError unless step.c's mass diagonal and gravity force ``(nv,)`` equal
    MuJoCo's M and −qfrc_bias at `data`'s configuration, at rest. M is tested as
    M·x = diag∘x for two vectors (any off-diagonal entry breaks one of them)."""
    probe = mujoco.MjData(model)
    probe.qpos[:] = data.qpos
    mujoco.mj_forward(model, probe)  # an unregistered MjData: no native forces
    diagonal = 1.0 / inv_mass
    for vector in (np.ones(model.nv), np.random.default_rng(0).uniform(0.5, 2.0, model.nv)):
        product = np.zeros(model.nv)
        mujoco.mj_mulM(model, probe, product, vector)
        if not np.allclose(product, diagonal * vector, rtol=1e-12, atol=0.0):
            raise ValueError("the native stepper needs a diagonal mass matrix of the bodies' "
                             "masses and inertias; MuJoCo's differs")
    scale = max(float(np.max(np.abs(gravity), initial=0.0)), 1e-300)
    if not np.allclose(-probe.qfrc_bias, gravity, rtol=1e-12, atol=1e-12 * scale):
        raise ValueError("the native stepper's gravity force differs from MuJoCo's")
