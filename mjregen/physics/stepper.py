"""Fast path of ``mj_step`` for a voxel-plugin robot: MuJoCo's Euler step in one C loop.

In the voxel pipeline every force on a voxel comes from the ``mjregen.voxels`` plugin, and
MuJoCo's step has nothing left to do but integrate independent rigid bodies — through its
generic pipeline (kinematics, composite inertia, factorisation, recursive Newton–Euler),
about half the cost of a step. For the models `mjregen.physics.compile` builds (each voxel a child
of the world, centre of mass at its joint, isotropic inertia, no joint damping, tendons,
force-producing actuators, constraints or fluid) those equations reduce to a constant
diagonal mass matrix and a constant gravity force, which ``plugin/step.c`` integrates
exactly like ``mj_step`` with the Euler integrator (same order, same quaternion update,
the plugin's forces and state advance, the same bad-value warnings), to rounding
(tests/physics/test_stepping.py); a step with a bad value is not taken. During a call the state
lives in the plugin's arrays (rows per quantity, so that the per-voxel loops vectorise);
``qpos``, ``qvel``, ``qacc`` and ``qfrc_passive`` are written at its end.

`unsupported(model)` says why a model does not qualify, `unsupported_on(model, data,
instance)` also checks that every body is one of the plugin's voxels (then
``stepper="auto"`` steps with ``mj_step``). Each `NativeStepper.step` call reads the masses, inertias, gravity and
time step from the model (so changing them between calls acts as in MuJoCo); on creation
the stepper checks that these give MuJoCo's own mass matrix and gravity force. It does not
update derived quantities (``xpos``, ``subtree_com``, ...): call ``mj_kinematics`` after
stepping, as `Simulation.run` does. ``qfrc_applied`` is applied; ``xfrc_applied`` is not
(`NativeStepper.step` refuses a non-zero one).
"""

from __future__ import annotations

import mujoco
import numpy as np

from mjregen.physics import voxel_plugin

_FREE, _SLIDE, _HINGE = (int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_SLIDE),
                         int(mujoco.mjtJoint.mjJNT_HINGE))
_PLANAR_AXES = np.eye(3)[[0, 2, 1]]  # 2D voxels: slide x, slide z, hinge y


def _planar_or_free(model: mujoco.MjModel, body: int) -> bool:
    """The body is welded, or has one free joint, or slide x, slide z, hinge y."""
    first, count = model.body_jntadr[body], model.body_jntnum[body]
    if count == 0:
        return True
    types = model.jnt_type[first: first + count].tolist()
    if types == [_FREE]:
        return True
    axes = model.jnt_axis[first: first + count]
    return types == [_SLIDE, _SLIDE, _HINGE] and np.array_equal(axes, _PLANAR_AXES)


def _force_free_actuators(model: mujoco.MjModel) -> bool:
    """Every actuator is a control input only (zero gain and bias, no dynamics)."""
    return bool(np.all(model.actuator_gainprm == 0.0) and np.all(model.actuator_biasprm == 0.0)
                and np.all(model.actuator_dyntype == mujoco.mjtDyn.mjDYN_NONE))


def unsupported(model: mujoco.MjModel) -> str:
    """"" if the native stepper integrates `model` exactly as ``mj_step``, else why not."""
    disabled = model.opt.disableflags
    needs_off = mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    checks = [
        (model.nplugin != 1, "the model does not have exactly one plugin (the voxel plugin)"),
        (model.opt.integrator != mujoco.mjtIntegrator.mjINT_EULER, "the integrator is not Euler"),
        ((disabled & needs_off) != needs_off, "MuJoCo contacts or constraints are enabled"),
        (model.na or model.neq or model.ntendon or model.nsensor or model.nflex,
         "the model has activations, equalities, tendons, sensors or flexes"),
        (not _force_free_actuators(model), "an actuator produces force"),
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
    for body in range(1, model.nbody):
        if not _planar_or_free(model, body):
            return (f"body {body} has joints other than one free joint or slide x, slide z, "
                    "hinge y")
    moving = model.body_jntnum[1:] > 0
    if np.any(model.body_ipos[1:][moving] != 0.0) or np.any(model.jnt_pos != 0.0):
        return "a body's centre of mass or joint is off its origin"
    inertia = model.body_inertia[1:][moving]
    if inertia.size and np.any(np.ptp(inertia, axis=1) > 1e-12 * np.max(inertia, axis=1)):
        return "a body's inertia is not isotropic"
    return ""


class NativeStepper:
    """Steps one MjData of a supported model (`unsupported`) in C; see the module doc."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, *, instance: int = 0,
                 checked: bool = False) -> None:
        """`instance`: the voxel plugin's instance id; `checked`: the caller has just seen
        `unsupported_on(model, data, instance)` return ""."""
        reason = "" if checked else unsupported_on(model, data, instance)
        if reason:
            raise ValueError(f"the native stepper cannot step this model: {reason}")
        self._model, self._data, self._instance = model, data, instance
        self._library = voxel_plugin.library()
        _check_against_mujoco(model, data)

    def step(self, n_steps: int, com: np.ndarray | None = None) -> int:
        """Advance up to `n_steps` steps; returns the number done (fewer after a bad value,
        with MuJoCo's warning recorded in ``data.warning``).

        Args:
          com: optional C-contiguous float64 ``(n_steps, 3)`` array, filled with the centre
            of mass (m) at the start of each step.
        """
        if np.any(self._data.xfrc_applied):
            raise ValueError("the native stepper does not apply xfrc_applied (use "
                             "qfrc_applied, or stepper='mujoco')")
        pointer = None
        if com is not None:
            if com.shape != (n_steps, 3) or com.dtype != np.float64 \
                    or not com.flags.c_contiguous:
                raise ValueError(f"com must be a C-contiguous float64 ({n_steps}, 3) array")
            pointer = com.ctypes.data
        done = self._library.mjr_step(self._model._address, self._data._address,
                                      self._instance, int(n_steps), pointer)
        if done < 0:
            raise ValueError(_STEP_ERRORS[done])
        return done


_STEP_ERRORS = {-1: "the plugin instance is not the voxel plugin",
                -2: "the model has bodies or joints that are not the voxel plugin's voxels"}


def unsupported_on(model: mujoco.MjModel, data: mujoco.MjData, instance: int) -> str:
    """`unsupported(model)`, and also why not when a body is not one of the voxels of plugin
    `instance` (or their joints are not a voxel's): what ``plugin/step.c`` integrates."""
    reason = unsupported(model)
    if reason:
        return reason
    done = voxel_plugin.library().mjr_step(model._address, data._address, instance, 0, None)
    return _STEP_ERRORS.get(done, "")


def _check_against_mujoco(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Raise ValueError unless step.c's mass diagonal and gravity force ``(nv,)`` equal
    MuJoCo's M and −qfrc_bias at `data`'s configuration, at rest. M is tested as
    M·x = diag∘x for two vectors (any off-diagonal entry breaks one of them)."""
    inv_mass, gravity = np.zeros(model.nv), np.zeros(model.nv)
    voxel_plugin.library().mjr_step_masses(model._address, inv_mass.ctypes.data, gravity.ctypes.data)
    probe = mujoco.MjData(model)
    probe.qpos[:] = data.qpos
    mujoco.mj_forward(model, probe)
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
