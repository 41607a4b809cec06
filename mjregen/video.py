"""Videos and image files of a robot's states: ``.mp4`` through mediapy with an ffmpeg
(the system's or imageio-ffmpeg's), PNG frames, and the walks of several robots at once.
Frames come from `mjregen.render.RobotRenderer`."""

from __future__ import annotations

import logging
import os
import shutil
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from tqdm import tqdm

from mjregen.errors import MjregenError, OutputExistsError
from mjregen.fileio import atomic_open
from mjregen.grid import Robot
from mjregen.render import RobotRenderer, View, record_walk

if TYPE_CHECKING:
    from mjregen.physics import Physics
    from mjregen.physics.compile import CompiledRobot

_log = logging.getLogger(__name__)


class VideoError(MjregenError, RuntimeError):
    """A video cannot be written (no ffmpeg found, or bad video settings)."""


def find_ffmpeg() -> str:
    """Path of an ffmpeg executable: ``ffmpeg`` on PATH, else imageio-ffmpeg's own binary.

    Raises:
      VideoError: neither exists (says what to install).
    """
    found = shutil.which("ffmpeg")
    if found:
        return found
    try:
        import imageio_ffmpeg
    except ImportError:
        raise VideoError("no ffmpeg found: install it (apt-get install ffmpeg) or "
                         "pip install imageio-ffmpeg") from None
    return imageio_ffmpeg.get_ffmpeg_exe()


def write_video(compiled: CompiledRobot, qpos: np.ndarray, path: str | os.PathLike, *,
                fps: int = 30, view: View = View(), overwrite: bool = False,
                progress: bool = True, backend: str | None = None) -> Path:
    """Render states to an H.264 ``.mp4`` (through mediapy and ffmpeg), atomically.

    Args:
      compiled: the robot.
      qpos: ``(F, nq)`` states, one per frame (e.g. `record_walk(...).qpos`), F >= 1.
      path: ``.mp4`` file to write.
      fps: frames per second.
      view: size and camera.
      overwrite: replace an existing file.
      progress: show a tqdm bar.
      backend: OpenGL backend; None = `select_gl_backend()`.
    Raises:
      OutputExistsError: `path` exists and not `overwrite`.
      VideoError: `path` is not ``.mp4``, no frames, or no ffmpeg.
    """
    import mediapy

    path = Path(path)
    if path.suffix != ".mp4":
        raise VideoError(f"videos are written as .mp4; got {str(path)!r}")
    qpos = np.asarray(qpos)
    if qpos.ndim != 2 or len(qpos) == 0:
        raise VideoError(f"qpos must be (frames, nq) with at least one frame, got {qpos.shape}")
    if path.exists() and not overwrite:
        raise OutputExistsError(path)
    ffmpeg = find_ffmpeg()
    _log.info("writing %s with %s", path, ffmpeg)
    mediapy.set_ffmpeg(ffmpeg)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(f".{path.stem}.partial.mp4")
    try:
        with RobotRenderer(compiled, view=view, backend=backend) as renderer, \
                mediapy.VideoWriter(partial, (view.height, view.width), fps=fps) as writer:
            for state in tqdm(qpos, desc="rendering", unit="frame", disable=not progress):
                writer.add_image(renderer.render(state))
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)
    return path


def read_video(path: str | os.PathLike) -> np.ndarray:
    """The frames of a video file, ``(frames, height, width, 3)`` uint8 RGB, decoded by
    imageio-ffmpeg's own ffmpeg (mediapy's reader needs a system ffmpeg that accepts its
    flags).

    Raises:
      VideoError: the file is missing or ffmpeg cannot decode it.
    """
    import imageio_ffmpeg

    path = Path(path)
    if not path.is_file():
        raise VideoError(f"{path}: no such video file")
    try:
        reader = imageio_ffmpeg.read_frames(str(path), pix_fmt="rgb24")
        width, height = next(reader)["size"]
        frames = [np.frombuffer(frame, dtype=np.uint8).reshape(height, width, 3)
                  for frame in reader]
    except (RuntimeError, OSError, StopIteration, ValueError) as error:
        last = str(error).strip().splitlines()[-1] if str(error).strip() else type(error).__name__
        raise VideoError(f"{path}: cannot decode the video ({last})") from None
    return np.stack(frames) if frames else np.zeros((0, height, width, 3), dtype=np.uint8)


def write_frames(compiled: CompiledRobot, qpos: np.ndarray, folder: str | os.PathLike, *,
                 view: View = View(), overwrite: bool = False, progress: bool = True,
                 backend: str | None = None) -> list[Path]:
    """Render states to PNG files ``frame_00000.png ...`` in `folder`.

    Args:
      qpos: ``(F, nq)`` states or ``(nq,)`` for one image.
    With `overwrite`, frames of an earlier, longer render beyond these are removed.

    Raises:
      OutputExistsError: a frame file exists and not `overwrite` (nothing is written then).
    """
    from PIL import Image

    qpos = np.atleast_2d(np.asarray(qpos))
    folder = Path(folder)
    paths = [folder / f"frame_{i:05d}.png" for i in range(len(qpos))]
    existing = [p for p in paths if p.exists()]
    if existing and not overwrite:
        raise OutputExistsError(existing[0], "replace frames")
    with RobotRenderer(compiled, view=view, backend=backend) as renderer:
        for state, frame in tqdm(list(zip(qpos, paths)), desc="rendering", unit="frame",
                                 disable=not progress):
            with atomic_open(frame) as handle:
                Image.fromarray(renderer.render(state)).save(handle, format="PNG")
    for stale in set(folder.glob("frame_*.png")) - set(paths):  # an earlier, longer render
        stale.unlink()
    return paths


def walk_videos(robots: dict[str, Robot], folder: str | os.PathLike, *,
                physics: Physics | None = None, duration: float | None = None,
                progress: bool = True) -> list[Path]:
    """``<role>.mp4`` in `folder` (replaced if present) of each non-empty robot's walk.

    Args:
      robots: {role: robot}, e.g. the original, damaged and regrown robots of a regrowth.
      physics: None = the default; duration: s of walking (None = the scene's).
    """
    from mjregen.physics.compile import compile_robot

    written = []
    for role, robot in robots.items():
        if robot.is_empty:
            continue
        compiled = compile_robot(robot, physics=physics)
        walk = record_walk(compiled, duration=duration)
        written.append(write_video(compiled, walk.qpos, Path(folder) / f"{role}.mp4",
                                   overwrite=True, progress=progress))
    return written
