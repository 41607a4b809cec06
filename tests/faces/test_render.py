"""Rendering: backend selection and its errors, material colours, the following camera,
walk recording, video and PNG output, growth figures."""

import os
import subprocess
import sys
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest

from mjregen.errors import InvalidGridError
from mjregen.figures import MATERIAL_RGBA, growth_figure
from mjregen.grid import Material, Robot
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import simulate
from mjregen.render import (
    GLBackendError,
    RobotRenderer,
    View,
    record_walk,
    select_gl_backend,
    walk_frame_count,
)
from mjregen.video import VideoError, find_ffmpeg, read_video, write_frames, write_video

SMALL = View(width=160, height=120)


@pytest.fixture(scope="module")
def backend():
    """The automatically chosen backend, without leaving MUJOCO_GL set for other tests."""
    with pytest.MonkeyPatch.context() as patch:
        patch.delenv("MUJOCO_GL", raising=False)
        yield select_gl_backend()


def material_of_pixels(image: np.ndarray) -> dict[Material, int]:
    """Coloured pixels (HSV saturation >= 0.3, i.e. not floor or sky) by nearest material
    chromaticity (r, g, b)/(r + g + b), which does not depend on how a face is lit."""
    pixels = image.reshape(-1, 3).astype(np.float64)
    high, low = pixels.max(axis=1), pixels.min(axis=1)
    coloured = pixels[(high - low) >= 0.3 * np.maximum(high, 1.0)]
    materials = list(MATERIAL_RGBA)
    reference = np.array([MATERIAL_RGBA[m][:3] for m in materials])
    reference /= reference.sum(axis=1, keepdims=True)
    chroma = coloured / np.maximum(coloured.sum(axis=1, keepdims=True), 1e-9)
    nearest = np.argmin(((chroma[:, None] - reference[None]) ** 2).sum(axis=2), axis=1)
    return dict(zip(materials, np.bincount(nearest, minlength=len(materials)).tolist()))


def robot_pixels(image: np.ndarray) -> np.ndarray:
    """(row, column) of the coloured pixels."""
    rgb = image.astype(np.int16)
    saturated = (rgb.max(axis=2) - rgb.min(axis=2)) >= 0.3 * np.maximum(rgb.max(axis=2), 1)
    return np.argwhere(saturated)


def test_backend_is_a_headless_one_and_is_remembered(backend, monkeypatch):
    assert backend in ("egl", "osmesa")
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    assert select_gl_backend() == backend
    assert os.environ["MUJOCO_GL"] == backend  # children and later calls reuse it


def test_unknown_backend_value_names_the_valid_ones(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "vulkan")
    with pytest.raises(GLBackendError, match="MUJOCO_GL='vulkan'.*egl, osmesa, glfw"):
        select_gl_backend()


def test_no_working_backend_says_what_to_install(tmp_path):
    """Broken EGL and OSMesa libraries first on the library path: neither backend can render."""
    for name in ("libEGL.so.1", "libEGL.so", "libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so",
                 "libGL.so.1", "libOpenGL.so.0"):
        (tmp_path / name).write_text("not a shared library")
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    env["LD_LIBRARY_PATH"] = str(tmp_path)
    done = subprocess.run(
        [sys.executable, "-c", "from mjregen.render import select_gl_backend; select_gl_backend()"],
        env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode != 0
    assert "GLBackendError: no OpenGL backend can render off-screen" in done.stderr
    assert "egl:" in done.stderr and "osmesa:" in done.stderr
    assert "apt-get install libosmesa6" in done.stderr and "libegl1" in done.stderr


def test_unusable_backend_is_a_clear_error():
    """glfw needs a display; without one creating a renderer fails with an error naming the
    backend (in a child process: a failed GL platform must not stay loaded in this one)."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MUJOCO_GL"] = "glfw"
    code = ("import numpy as np; from mjregen.physics.compile import compile_robot; "
            "from mjregen.grid import Robot; from mjregen.render import RobotRenderer; "
            "RobotRenderer(compile_robot(Robot.from_body(np.ones((1, 1, 1)))))")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode != 0
    assert "GLBackendError: cannot create an OpenGL context with MUJOCO_GL=glfw" in done.stderr
    assert "needs a display" in done.stderr


@pytest.mark.parametrize("material", list(MATERIAL_RGBA))
def test_each_material_renders_in_its_colour(backend, material):
    compiled = compile_robot(Robot.box((2, 2, 2), material))
    with RobotRenderer(compiled, view=SMALL, backend=backend) as renderer:
        image = renderer.render()
    assert image.shape == (120, 160, 3) and image.dtype == np.uint8
    counts = material_of_pixels(image)
    assert counts[material] > 300  # the robot fills a visible part of the image
    # dominant by far; the rest are edge pixels blended with the grey floor (a blend of dark
    # blue and grey has the chromaticity of light blue)
    assert counts[material] > 0.9 * sum(counts.values())


def test_mixed_robot_shows_every_material(backend):
    body = np.array([[[Material.SOFT]], [[Material.HARD]], [[Material.MUSCLE_PLUS]],
                     [[Material.MUSCLE_MINUS]]], dtype=np.int8)
    compiled = compile_robot(Robot.from_body(body))
    with RobotRenderer(compiled, view=View(width=240, height=160), backend=backend) as renderer:
        counts = material_of_pixels(renderer.render())
    assert all(counts[m] > 50 for m in MATERIAL_RGBA), counts


def test_camera_follows_the_robot(backend):
    """Moved 40 voxel lengths away, the robot is still in the middle of the frame."""
    compiled = compile_robot(Robot.box((2, 2, 2), Material.HARD))
    moved = compiled.model.qpos0.copy()
    for adr in compiled.model.jnt_qposadr:  # free joints: x, y, z, quaternion
        moved[adr: adr + 2] += [0.04, -0.03]
    with RobotRenderer(compiled, view=SMALL, backend=backend) as renderer:
        at_start, far = robot_pixels(renderer.render()), robot_pixels(renderer.render(moved))
        fixed = renderer.render(moved)
    assert len(far) > 0.8 * len(at_start) > 0
    centre = np.array([60, 80])
    assert np.abs(far.mean(axis=0) - centre).max() < 20
    assert np.abs(at_start.mean(axis=0) - far.mean(axis=0)).max() < 5
    np.testing.assert_array_equal(fixed, renderer_image_again(compiled, moved, backend))


def renderer_image_again(compiled, qpos, backend) -> np.ndarray:
    """The same state rendered by a fresh renderer (rendering is deterministic)."""
    with RobotRenderer(compiled, view=SMALL, backend=backend) as renderer:
        return renderer.render(qpos)


def test_bad_states_are_rejected(backend):
    compiled = compile_robot(Robot.box((2, 2, 2), Material.SOFT))
    with RobotRenderer(compiled, view=SMALL, backend=backend) as renderer:
        with pytest.raises(ValueError, match="shape"):
            renderer.render(np.zeros(3))
        with pytest.raises(ValueError, match="NaN"):
            renderer.render(np.full(compiled.model.nq, np.nan))


@pytest.mark.parametrize("kwargs, problem", [({"width": 161}, "even"), ({"height": 8}, "16..4096"),
                                             ({"distance": -1.0}, "distance")])
def test_bad_views_are_rejected(kwargs, problem):
    with pytest.raises(ValueError, match=problem):
        View(**kwargs)


def test_recorded_walk_is_the_simulated_walk():
    robot = Robot.load(Path(__file__).parents[2] / "assets/robots/bimorph_walker_3d.npy")
    compiled = compile_robot(robot)
    walk = record_walk(compiled, duration=0.02, fps=20, slowdown=10)
    result = simulate(robot, duration=0.02, record=True)
    assert walk.stable
    assert len(walk.qpos) == walk_frame_count(0.07, fps=20, slowdown=10) == 15
    assert walk.times[0] == 0.0
    assert walk.times[-1] == pytest.approx(result.sim_time)
    np.testing.assert_array_equal(walk.com[-1], result.com[-1])
    assert np.all(np.diff(walk.times) > 0)


def test_a_recorded_walk_from_another_start_is_that_start_s_walk():
    """`record_walk(start=k)` (what `mjregen render --start-seed S --start k` renders) begins
    at start k's keyframe and ends where `simulate(start_seed=S, start=k)` does."""
    robot = Robot.load(Path(__file__).parents[2] / "assets/robots/bimorph_walker_3d.npy")
    compiled = compile_robot(robot, starts=(2,), start_seed=3)
    walk = record_walk(compiled, duration=0.02, fps=20, slowdown=10, start=2)
    result = simulate(robot, duration=0.02, record=True, start_seed=3, start=2)
    np.testing.assert_array_equal(walk.qpos[0], compiled.model.key_qpos[0])
    np.testing.assert_array_equal(walk.com[-1], result.com[-1])
    other = simulate(robot, duration=0.02, record=True)  # start 0 of seed 0 differs
    assert not np.array_equal(walk.com[-1], other.com[-1])


def test_video_has_the_frames_and_is_not_overwritten(backend, tmp_path):
    compiled = compile_robot(Robot.load(
        Path(__file__).parents[2] / "assets/robots/bimorph_walker_3d.npy"))
    walk = record_walk(compiled, duration=0.05, fps=10, slowdown=5)
    path = write_video(compiled, walk.qpos, tmp_path / "walk.mp4", fps=10, view=SMALL,
                       progress=False, backend=backend)
    frames = read_video(path)  # the reader a user gets (mediapy's fails on ffmpeg 9)
    assert frames.shape == (len(walk.qpos), 120, 160, 3)
    assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).mean() > 0.5
    assert [p.name for p in tmp_path.iterdir()] == ["walk.mp4"]  # no partial file left
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"x" * 99)
    with pytest.raises(VideoError, match="cannot decode"):
        read_video(junk)
    junk.unlink()
    with pytest.raises(VideoError, match="no such video"):
        read_video(junk)
    with pytest.raises(FileExistsError, match="walk.mp4 exists"):
        write_video(compiled, walk.qpos, path, view=SMALL, backend=backend)
    with pytest.raises(VideoError, match=".mp4"):
        write_video(compiled, walk.qpos, tmp_path / "walk.avi", view=SMALL, backend=backend)


def test_ffmpeg_is_found_or_named(monkeypatch):
    import shutil

    monkeypatch.setattr(shutil, "which", lambda name: None)  # no system ffmpeg
    assert find_ffmpeg() == imageio_ffmpeg.get_ffmpeg_exe()
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # and no imageio-ffmpeg
    with pytest.raises(VideoError, match="apt-get install ffmpeg.*imageio-ffmpeg"):
        find_ffmpeg()


@pytest.mark.parametrize("kwargs, problem", [({"fps": 0}, "fps"), ({"slowdown": 0.0}, "slowdown"),
                                             ({"duration": -1.0}, "duration")])
def test_bad_walk_settings_are_rejected(kwargs, problem):
    with pytest.raises(ValueError, match=problem):
        record_walk(compile_robot(Robot.box((2, 2, 2), Material.SOFT)), **kwargs)


def test_png_frames(backend, tmp_path):
    from PIL import Image

    compiled = compile_robot(Robot.box((2, 2, 2), Material.MUSCLE_PLUS))
    states = np.stack([compiled.model.qpos0] * 2)
    paths = write_frames(compiled, states, tmp_path, view=SMALL, progress=False, backend=backend)
    assert [p.name for p in paths] == ["frame_00000.png", "frame_00001.png"]
    assert np.asarray(Image.open(paths[0])).shape == (120, 160, 3)
    with pytest.raises(FileExistsError):
        write_frames(compiled, states, tmp_path, view=SMALL, backend=backend)


@pytest.mark.parametrize("shape", [(3, 5, 5, 5), (2, 7, 7)])
def test_growth_figure(tmp_path, shape):
    from PIL import Image

    states = np.zeros(shape, dtype=np.int8)
    centre = tuple(s // 2 for s in shape[1:])
    states[(slice(1, None),) + centre] = Material.MUSCLE_MINUS
    path = growth_figure(states, tmp_path / "growth.png")
    image = np.asarray(Image.open(path).convert("RGB"))
    assert image.shape[1] > image.shape[0] > 100  # one row of panels
    assert material_of_pixels(image)[Material.MUSCLE_MINUS] > 0
    with pytest.raises(FileExistsError):
        growth_figure(states, path)


def test_growth_figure_rejects_bad_input(tmp_path):
    with pytest.raises(InvalidGridError, match="unknown material code 9"):
        growth_figure(np.full((1, 5, 5), 9), tmp_path / "g.png")
    with pytest.raises(ValueError, match="states must be"):
        growth_figure(np.zeros((5, 5)), tmp_path / "g.png")
    with pytest.raises(ValueError, match=".png"):
        growth_figure(np.zeros((1, 5, 5)), tmp_path / "g.jpg")
    with pytest.raises(ValueError, match="2 titles for 1 states"):
        growth_figure(np.zeros((1, 5, 5)), tmp_path / "g.png", titles=["a", "b"])


def test_frames_replaced_with_force_leave_no_stale_frames(backend, tmp_path):
    compiled = compile_robot(Robot.box((2, 2, 2)))
    states = np.repeat(compiled.model.qpos0[None], 4, axis=0)
    write_frames(compiled, states, tmp_path, view=SMALL, progress=False, backend=backend)
    write_frames(compiled, states[:2], tmp_path, view=SMALL, overwrite=True, progress=False,
                 backend=backend)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["frame_00000.png", "frame_00001.png"]
