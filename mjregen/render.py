"""Headless rendering of robots: the OpenGL backend, a renderer of a robot's states, and the
sampled states of a walk.

Rendering uses MuJoCo's OpenGL renderer (``mjv_updateScene`` / ``mjr_render``) in an off-screen
context that this module creates itself, so it works in a process that imported `mujoco`
before (MuJoCo's own `mujoco.Renderer` fixes its backend when `mujoco` is imported).

Backend (`select_gl_backend`): the value of ``MUJOCO_GL`` when the user set one ("egl",
"osmesa", or "glfw" with a display); otherwise EGL if a probe in a child process can render,
else OSMesa. The choice is logged and written to ``os.environ["MUJOCO_GL"]`` so that child
processes and later calls use it without probing again. One process binds PyOpenGL to one
platform: once an EGL context exists, OSMesa cannot be used in the same process.

Look: voxels in the paper's colours (`MATERIAL_RGBA`: light blue soft, dark blue hard, red
muscle +, green muscle −) and drawn 10 % smaller than their cells so single voxels stay
visible; a grey floor whose checker squares are one voxel edge long; a light grey sky. The
camera looks at the robot's centre of mass in every frame. Shadows, reflections, tendons
and sites are off: on a CPU (Mesa) they cost ~40× the frame time.

Typical use (videos and frames: `mjregen.video`)::

    compiled = compile_robot(robot)
    walk = record_walk(compiled, fps=30, slowdown=10)
    write_video(compiled, walk.qpos, "walk.mp4", fps=30)
"""

from __future__ import annotations

import importlib
import logging
import os
import subprocess
import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mjregen.errors import MjregenError
from mjregen.gl import BACKENDS, HEADLESS_BACKENDS, INSTALL_HINT, missing_library
from mjregen.grid import Material
from mjregen.physics.mjcf import MATERIAL_RGBA

if TYPE_CHECKING:
    import mujoco

    from mjregen.physics.compile import CompiledRobot

_log = logging.getLogger(__name__)

VOXEL_DRAW_SCALE = 0.9  # voxels are drawn this much smaller than their cells
_PROBE = """
import importlib, sys
import mujoco
context = importlib.import_module("mujoco." + sys.argv[1]).GLContext(16, 16)
context.make_current()
mujoco.MjrContext(mujoco.MjModel.from_xml_string("<mujoco/>"), 100).free()
context.free()
"""


class GLBackendError(MjregenError, RuntimeError):
    """No OpenGL backend can render off-screen here (the message says what to install)."""


def select_gl_backend() -> str:
    """The OpenGL backend to render with: "egl", "osmesa" or "glfw".

    ``MUJOCO_GL`` set by the user wins. Otherwise EGL, then OSMesa, each tested by rendering
    in a child process (about a second each); the first that works is chosen, logged, and
    stored in ``os.environ["MUJOCO_GL"]``.

    Raises:
      GLBackendError: ``MUJOCO_GL`` holds a value that cannot render off-screen, or neither
        EGL nor OSMesa works (the message has each probe's error and what to install).
    """
    requested = os.environ.get("MUJOCO_GL", "").strip().lower()
    if requested:
        if requested not in BACKENDS:
            raise GLBackendError(
                f"MUJOCO_GL={requested!r} cannot render off-screen; use one of "
                f"{', '.join(BACKENDS)} or unset it to choose automatically (EGL, then OSMesa)")
        problem = missing_library(requested)
        if problem:
            raise GLBackendError(problem)
        _log.info("rendering with MUJOCO_GL=%s (from the environment)", requested)
        return requested
    failures = []
    for backend in HEADLESS_BACKENDS:
        error = _probe(backend)
        if error is None:
            os.environ["MUJOCO_GL"] = backend
            _log.info("rendering with MUJOCO_GL=%s (chosen automatically: EGL first, then "
                      "OSMesa)", backend)
            return backend
        failures.append(f"{backend}: {error}")
    raise GLBackendError(
        "no OpenGL backend can render off-screen (" + "; ".join(failures) + "). Install one: "
        + "; or ".join(INSTALL_HINT[b] for b in HEADLESS_BACKENDS))


def _probe(backend: str) -> str | None:
    """None if `backend` renders in a fresh child process, else the last line of its error."""
    env = dict(os.environ, MUJOCO_GL=backend)
    env.pop("PYOPENGL_PLATFORM", None)
    try:
        done = subprocess.run([sys.executable, "-c", _PROBE, backend], env=env,
                              capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        return "the probe did not finish within 120 s"
    if done.returncode == 0:
        return None
    lines = done.stderr.strip().splitlines()
    return lines[-1] if lines else f"exit status {done.returncode}"


def _gl_context(backend: str, model: mujoco.MjModel) -> tuple[object, mujoco.MjrContext]:
    """An off-screen OpenGL context of `backend` (made current) and MuJoCo's render context
    of `model` drawing into its off-screen buffer."""
    import mujoco

    try:
        module = importlib.import_module(f"mujoco.{backend}")
        context = module.GLContext(model.vis.global_.offwidth, model.vis.global_.offheight)
        context.make_current()
        mjr = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100)
    except Exception as error:  # any failure of the GL stack means: this backend is unusable
        raise GLBackendError(
            f"cannot create an OpenGL context with MUJOCO_GL={backend}: "
            f"{type(error).__name__}: {error}. {INSTALL_HINT[backend]}; or set MUJOCO_GL to "
            f"another of {', '.join(BACKENDS)} (in a new process)") from error
    mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, mjr)
    return context, mjr


@dataclass(frozen=True)
class View:
    """Image size and camera.

    Attributes:
      width, height: pixels; even (H.264 video needs even sizes), 16..4096.
      distance: camera distance from the centre of mass in voxel lengths; None = 2.5 × the
        robot's bounding-box diagonal, at least 12.
      azimuth, elevation: camera angles in degrees; azimuth None = 135 in 3D, 90 in 2D (the
        x–z plane seen face on).
    """

    width: int = 480
    height: int = 360
    distance: float | None = None
    azimuth: float | None = None
    elevation: float = -20.0

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 16 <= value <= 4096:
                raise ValueError(f"{name} must be an integer number of pixels in 16..4096, "
                                 f"got {value!r}")
            if value % 2:
                raise ValueError(f"{name} must be even (H.264 video needs even sizes), got {value}")
        if self.distance is not None and not (np.isfinite(self.distance) and self.distance > 0):
            raise ValueError(f"distance must be > 0 voxel lengths, got {self.distance!r}")


class RobotRenderer:
    """Draws states of a compiled robot into RGB images.

    Build it once per robot and size, call `render` per state, `close` at the end (or use it
    as a context manager). It owns a copy of the model with colours, floor grid, sky and
    lights added (the physics model is not changed).

    Args:
      compiled: the robot (`mjregen.physics.compile.compile_robot`).
      view: image size and camera.
      backend: "egl", "osmesa" or "glfw"; None = `select_gl_backend()`.
    Raises:
      GLBackendError: the backend cannot create a context.
    """

    def __init__(self, compiled: CompiledRobot, *, view: View = View(),
                 backend: str | None = None) -> None:
        import mujoco

        self._mujoco = mujoco
        self.view = view
        self.backend = select_gl_backend() if backend is None else backend
        self.model = _render_model(compiled, view)
        self.data = mujoco.MjData(self.model)
        self._camera = _camera(compiled, view)
        self._option = mujoco.MjvOption()
        self._option.flags[mujoco.mjtVisFlag.mjVIS_TENDON] = False
        self._option.sitegroup[:] = 0
        self._context, self._mjr = _gl_context(self.backend, self.model)
        self._scene = mujoco.MjvScene(self.model, maxgeom=self.model.ngeom + 100)
        for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION):
            self._scene.flags[flag] = False
        self._rect = mujoco.MjrRect(0, 0, view.width, view.height)
        self._pixels = np.empty((view.height, view.width, 3), dtype=np.uint8)

    def render(self, qpos: np.ndarray | None = None) -> np.ndarray:
        """Image ``(height, width, 3)`` uint8 of the robot in state `qpos`.

        Args:
          qpos: ``(model.nq,)`` joint positions (SI units); None = the initial pose.
        Raises:
          ValueError: `qpos` has the wrong shape or is not finite.
        """
        mujoco = self._mujoco
        if qpos is None:
            qpos = self.model.qpos0
        qpos = np.asarray(qpos, dtype=np.float64)
        if qpos.shape != (self.model.nq,):
            raise ValueError(f"qpos must have shape ({self.model.nq},), got {qpos.shape}")
        if not np.all(np.isfinite(qpos)):
            raise ValueError("qpos contains NaN or infinite values (an unstable simulation?)")
        self.data.qpos[:] = qpos
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)
        self._camera.lookat[:] = self.data.subtree_com[0]
        self._context.make_current()
        mujoco.mjv_updateScene(self.model, self.data, self._option, None, self._camera,
                               mujoco.mjtCatBit.mjCAT_ALL, self._scene)
        mujoco.mjr_render(self._rect, self._scene, self._mjr)
        mujoco.mjr_readPixels(self._pixels, None, self._rect, self._mjr)
        return np.flipud(self._pixels).copy()

    def close(self) -> None:
        """Free the OpenGL resources (idempotent)."""
        if self._context is not None:
            self._context.make_current()
            self._mjr.free()
            self._context.free()
            self._context = None

    def __enter__(self) -> RobotRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _render_model(compiled: CompiledRobot, view: View) -> mujoco.MjModel:
    """Copy of the robot's model with colours, floor grid, sky, lights and buffer size."""
    import mujoco

    voxel = compiled.physics.scene.voxel_size
    spec = compiled.spec.copy()
    spec.visual.global_.offwidth = view.width
    spec.visual.global_.offheight = view.height
    spec.visual.headlight.ambient = [0.45] * 3
    spec.visual.headlight.diffuse = [0.5] * 3
    spec.visual.headlight.specular = [0.05] * 3
    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, rgb1=[0.95] * 3,
                     rgb2=[0.65] * 3, width=64, height=64)
    spec.worldbody.add_light(name="sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
                             pos=[0.0, 0.0, 1.0], dir=[0.4, 0.2, -1.0], castshadow=False,
                             diffuse=[0.4] * 3)
    spec.add_material(name="voxel", specular=0.1, shininess=0.2)
    voxel_geoms = compiled.model.body_geomadr[compiled.body_ids]
    for geom in voxel_geoms:
        spec.geom(compiled.model.geom(geom).name).material = "voxel"
    floors = [g for g in spec.geoms if g.type == mujoco.mjtGeom.mjGEOM_PLANE]
    if floors:
        spec.add_texture(name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
                         builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, rgb1=[0.85] * 3,
                         rgb2=[0.75] * 3, mark=mujoco.mjtMark.mjMARK_EDGE, markrgb=[0.6] * 3,
                         width=64, height=64)
        grid = spec.add_material(name="grid", texrepeat=[0.5 / voxel] * 2, texuniform=True)
        grid.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"
        for floor in floors:  # a plane's sizes only matter for drawing (it is infinite)
            floor.material = "grid"
            floor.size = [500 * voxel, 500 * voxel, 20 * voxel]
    model = spec.compile()
    materials = compiled.robot.grid[tuple(compiled.voxel_index.T)]
    model.geom_rgba[voxel_geoms] = [MATERIAL_RGBA[Material(int(m))] for m in materials]
    model.geom_size[voxel_geoms] *= VOXEL_DRAW_SCALE
    return model


def _camera(compiled: CompiledRobot, view: View) -> mujoco.MjvCamera:
    """Free camera at the view's angles and distance (lookat is set per frame)."""
    import mujoco

    voxel = compiled.physics.scene.voxel_size
    index = compiled.voxel_index
    span = index.max(axis=0) - index.min(axis=0) + 1
    distance = view.distance
    if distance is None:
        distance = max(12.0, 2.5 * float(np.linalg.norm(span)))
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.distance = distance * voxel
    camera.azimuth = view.azimuth if view.azimuth is not None else (
        135.0 if compiled.robot.dim == 3 else 90.0)
    camera.elevation = view.elevation
    return camera


@dataclass(frozen=True)
class Walk:
    """Sampled states of a simulated walk, for rendering.

    Attributes:
      times: ``(F,)`` s of simulated time of each frame, from 0 (start of the settle) to the
        end of the walk.
      qpos: ``(F, nq)`` joint positions at `times`.
      com: ``(F, 3)`` m, centre of mass at `times`.
      stable: False when the simulation became unstable (the frames stop there).
      reason: why it became unstable ("" when stable).
    """

    times: np.ndarray
    qpos: np.ndarray
    com: np.ndarray
    stable: bool
    reason: str


def walk_frame_count(sim_time: float, *, fps: int, slowdown: float) -> int:
    """Number of frames of a video of `sim_time` s shown `slowdown` times slower at `fps`."""
    return round(sim_time * slowdown * fps) + 1


def record_walk(compiled: CompiledRobot, *, duration: float | None = None, fps: int = 30,
                slowdown: float = 10.0, start: int = 0) -> Walk:
    """Simulate the robot as `mjregen.physics.simulation.simulate` does and sample states for a video.

    The run is the settle time plus `duration` of actuation (the same steps as `simulate`),
    sampled at `walk_frame_count(...)` evenly spaced instants, first and last step included.
    It runs the very `Simulation` that `simulate` runs (`simulation_of`, either bond backend).

    Args:
      compiled: the robot.
      duration: s of actuation; None = the scene's measured time.
      fps: frames per second of the video.
      slowdown: how many times slower than real time the video plays (10 = slow motion).
      start: which of the model's starts the walk begins from (`CompiledRobot.starts`).
    Raises:
      ValueError: non-positive `fps`, `slowdown` or negative `duration`.
    """
    from mjregen.physics.simulation import simulation_of

    if isinstance(fps, bool) or not isinstance(fps, int) or fps < 1:
        raise ValueError(f"fps must be a positive integer, got {fps!r}")
    if not (np.isfinite(slowdown) and slowdown > 0):
        raise ValueError(f"slowdown must be > 0, got {slowdown!r}")
    scene = compiled.physics.scene
    settle, measured = scene.timing(compiled.robot.dim)
    measured = measured if duration is None else duration
    if not (np.isfinite(measured) and measured >= 0):
        raise ValueError(f"duration must be a finite time >= 0 s, got {duration!r}")
    dt = compiled.timestep
    n_steps = round(settle / dt) + round(measured / dt)
    n_frames = walk_frame_count(n_steps * dt, fps=fps, slowdown=slowdown)
    frame_steps = np.round(np.linspace(0, n_steps, n_frames)).astype(int)
    sim = simulation_of(compiled, start)
    qpos, com, reason = [], [], ""
    for step in frame_steps:
        reason = sim.run(int(step) - sim.steps) if step > sim.steps else ""
        if reason:
            break
        qpos.append(sim.data.qpos.copy())
        com.append(sim.com())
    times = frame_steps[: len(qpos)] * dt
    return Walk(times=times, qpos=np.array(qpos), com=np.array(com), stable=not reason,
                reason=reason)
