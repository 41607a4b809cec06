"""A plain install (a built wheel, not the source tree) has its assets and its plugin."""

from __future__ import annotations

import subprocess
import sys
import sysconfig
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHECK = """
import json, sys
import mjregen
from mjregen.resources import asset
from mjregen.grid import Robot
from mjregen.physics import simulate
assert "site-packages" in mjregen.__file__ and "{root}" not in mjregen.__file__, mjregen.__file__
robot = Robot.load(asset("robots", "paper", "tripod.npy"))
shipped = json.loads(asset("nca", "manifest.json").read_text())
assert asset("nca", "walker_3d.npz").is_file() and asset("regen", "tripod_ff.npz").is_file()
result = simulate(robot, physics=None, duration=0.002)
print(json.dumps({{"voxels": robot.n_voxels, "stable": result.stable, "entries": len(shipped),
                  "library": str(mjregen.plugin_library())}}))
"""


def test_wheel_in_a_fresh_environment_has_assets_and_builds_its_plugin(tmp_path):
    wheels = tmp_path / "wheels"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                    "-q", "-w", str(wheels), str(ROOT)], check=True, capture_output=True)
    (wheel,) = wheels.glob("mjregen-*.whl")
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "-q",
                    "--no-deps", str(wheel)], check=True, capture_output=True)
    # the dependencies from this environment (its site-packages holds no mjregen package)
    env = {"PYTHONPATH": sysconfig.get_paths()["purelib"], "MJREGEN_CACHE": str(tmp_path / "cache"),
           "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    done = subprocess.run([str(python), "-c", CHECK.format(root=ROOT)], capture_output=True,
                          text=True, cwd=tmp_path, env=env)
    assert done.returncode == 0, done.stderr
    assert '"voxels": 68' in done.stdout and '"stable": true' in done.stdout
    assert str(tmp_path / "cache") in done.stdout  # built here, from the wheel's sources
    walk = subprocess.run([str(python), "-m", "mjregen", "walk", "--duration", "0.002",
                           str(venv / "lib" / f"python{sys.version_info.major}."
                               f"{sys.version_info.minor}" / "site-packages" / "mjregen" /
                               "assets" / "robots" / "paper" / "biped.npy")],
                          capture_output=True, text=True, cwd=tmp_path, env=env)
    assert walk.returncode == 0 and "233 voxels" in walk.stdout, walk.stderr
