"""scripts/grow_and_walk.py end to end, in child processes without a display."""

import json
import os
import subprocess
import sys
from pathlib import Path

import imageio_ffmpeg
import mujoco
import numpy as np
import pytest

from mjregen.grid import Material, Robot
from mjregen.growth.checkpoint import load_nca
from mjregen.physics import Physics
from mjregen.physics.compile import compile_robot
from mjregen.physics.simulation import simulate
from mjregen.tasks.fitness import locomotion_fitness

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "grow_and_walk.py"
SHIPPED = ROOT / "assets" / "nca" / "walker_3d.npz"
P, M, S = Material.MUSCLE_PLUS, Material.MUSCLE_MINUS, Material.SOFT


def run_script(*args: str) -> subprocess.CompletedProcess:
    """The script in a fresh process with no display and no GL backend chosen."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("DISPLAY", "WAYLAND_DISPLAY", "MUJOCO_GL", "PYOPENGL_PLATFORM")}
    return subprocess.run([sys.executable, str(SCRIPT), *args], env=env, capture_output=True,
                          text=True, timeout=600)


def decode(path: Path) -> np.ndarray:
    """All frames ``(F, H, W, 3)`` uint8 of a video (imageio-ffmpeg's decoder)."""
    reader = imageio_ffmpeg.read_frames(str(path))
    width, height = next(reader)["size"]
    return np.stack([np.frombuffer(f, np.uint8).reshape(height, width, 3) for f in reader])


@pytest.fixture(scope="module")
def small_robot(tmp_path_factory) -> Path:
    body = np.zeros((3, 1, 2), dtype=np.int8)
    body[:, 0, 1] = [P, S, M]
    body[[0, 2], 0, 0] = S
    return Robot.from_body(body).save(tmp_path_factory.mktemp("robot") / "small.npy")


@pytest.fixture(scope="module")
def walked(small_robot, tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    out = tmp_path_factory.mktemp("walk") / "out"
    done = run_script("--robot", str(small_robot), "--duration", "0.02", "--out", str(out),
                      "--width", "160", "--height", "120", "--fps", "10", "--slowdown", "20")
    assert done.returncode == 0, done.stderr
    return out, done


def test_video_has_the_expected_frames_and_shows_motion(walked):
    out, done = walked
    frames = decode(out / "walk.mp4")
    # settle 0.05 s + 0.02 s walking, 20× slower, 10 fps, first and last state included
    assert frames.shape == (round(0.07 * 20 * 10) + 1, 120, 160, 3) == (15, 120, 160, 3)
    assert frames.std() > 10  # not blank
    assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).max() > 50
    assert "rendering with MUJOCO_GL=" in done.stdout


def test_outputs_match_the_robot_and_the_simulation(walked, small_robot):
    out, done = walked
    robot = Robot.load(small_robot)
    assert Robot.load(out / "robot.npy") == robot
    # MuJoCo loads it with the plugin library (loaded here by compiling)
    compiled = compile_robot(robot)
    model = mujoco.MjModel.from_xml_path(str(out / "robot.xml"))
    assert (model.nbody, model.nplugin, model.npluginstate, model.nq) == (
        compiled.model.nbody, 1, compiled.model.npluginstate, compiled.model.nq)
    summary = json.loads((out / "summary.json").read_text())
    expected = simulate(robot, duration=0.02)
    assert summary["distance"] == expected.distance
    assert summary["fitness"] == locomotion_fitness(expected)
    assert f"distance {expected.distance:.4f}" in done.stdout
    assert summary["video"]["frames"] == 15
    assert not (out / "growth.png").exists()  # a robot file has no growth


def test_existing_outputs_are_kept_unless_forced(walked, small_robot):
    out, _ = walked
    before = (out / "walk.mp4").stat().st_mtime_ns
    done = run_script("--robot", str(small_robot), "--out", str(out), "--no-video")
    assert done.returncode == 1
    assert "already holds robot.npy" in done.stderr and "--force" in done.stderr
    assert (out / "walk.mp4").stat().st_mtime_ns == before
    forced = run_script("--robot", str(small_robot), "--out", str(out), "--no-video",
                        "--duration", "0.01", "--force")
    assert forced.returncode == 0, forced.stderr
    assert json.loads((out / "summary.json").read_text())["duration"] == 0.01


def test_random_2d_nca_prints_and_draws_every_growth_step(tmp_path):
    done = run_script("--seed", "2", "--dim", "2", "--duration", "0.01", "--no-video",
                      "--out", str(tmp_path))
    assert done.returncode == 0, done.stderr
    steps = [line for line in done.stdout.splitlines() if line.startswith("--- growth step")]
    assert len(steps) == 11  # the seed and 10 growth steps
    assert "random 2D NCA, seed 2" in done.stdout
    assert (tmp_path / "growth.png").stat().st_size > 1000
    assert not (tmp_path / "walk.mp4").exists()
    assert Robot.load(tmp_path / "robot.npy").dim == 2


def test_default_is_the_shipped_nca(tmp_path):
    done = run_script("--duration", "0.01", "--no-video", "--out", str(tmp_path))
    assert done.returncode == 0, done.stderr
    assert f"NCA checkpoint {SHIPPED}" in done.stdout
    nca, _ = load_nca(SHIPPED)
    robot = nca.grow().robot()
    assert Robot.load(tmp_path / "robot.npy") == robot
    summary = json.loads((tmp_path / "summary.json").read_text())  # today's default physics
    assert summary["distance"] == simulate(robot, duration=0.01).distance
    # --recorded-physics: the physics it was evolved in (the manifest's)
    recorded = json.loads(SHIPPED.with_name("manifest.json").read_text())[SHIPPED.name]
    physics = Physics.from_dict(recorded["evaluation"]["physics"])
    done = run_script("--duration", "0.01", "--no-video", "--out", str(tmp_path / "recorded"),
                      "--recorded-physics")
    assert done.returncode == 0, done.stderr
    summary = json.loads((tmp_path / "recorded" / "summary.json").read_text())
    assert summary["bond_element"] == physics.pipeline.bond_element
    assert summary["distance"] == simulate(robot, physics=physics, duration=0.01).distance
    # the same walk as the default exactly when the NCA was evolved in today's default physics
    same = summary["distance"] == simulate(robot, duration=0.01).distance
    assert same == (physics == Physics())


@pytest.mark.parametrize("args, message", [
    (["--robot", "missing.npy"], "robot file not found: missing.npy"),
    (["--nca", "missing.npz"], "NCA checkpoint not found: missing.npz"),
    (["--nca", str(SHIPPED), "--dim", "2"], "does not match"),
    (["--seed", "1", "--recorded-physics"], "replays a shipped NCA"),
    (["--seed", "1", "--width", "161"], "width must be even"),
])
def test_bad_input_is_one_clear_error(tmp_path, args, message):
    done = run_script(*args, "--out", str(tmp_path / "out"))
    assert done.returncode == 1
    assert done.stderr.strip().splitlines()[-1].startswith("grow_and_walk: error: ")
    assert message in done.stderr
