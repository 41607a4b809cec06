"""Evolution runs from the real `mjregen` command: nothing a user did by mistake loses work,
and a run that cannot produce results says so and stops."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

SMALL = ["evolve", "--dim", "3", "--pop", "4", "--settle", "0.005", "--duration", "0.01",
         "--quiet"]


def mjregen(*args: str, cwd: Path | None = None, env: dict | None = None,
            **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mjregen", *args], capture_output=True,
                          text=True, cwd=cwd, env=env, timeout=300, **kwargs)


def start(*args: str, env: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "mjregen", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)


def wait_for(path: Path, process: subprocess.Popen, seconds: float = 120.0) -> None:
    deadline = time.monotonic() + seconds
    while not path.exists():
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline, f"{path} never appeared"
        time.sleep(0.1)


def test_force_deletes_only_run_folders(tmp_path):
    keep = tmp_path / "s" / "keep.txt"
    keep.parent.mkdir()
    keep.write_text("mine")
    done = mjregen(*SMALL, "--gens", "1", "--out", str(keep.parent), "--force")
    assert done.returncode == 1 and "does not hold an mjregen run" in done.stderr
    assert keep.read_text() == "mine"
    run = tmp_path / "run"
    assert mjregen(*SMALL, "--gens", "1", "--backend", "serial", "--out", str(run)).returncode == 0
    done = mjregen(*SMALL, "--gens", "1", "--backend", "serial", "--out", ".", "--force", cwd=run)
    assert done.returncode == 1 and "working directory" in done.stderr
    assert (run / "checkpoint.npz").is_file()
    again = mjregen(*SMALL, "--gens", "1", "--backend", "serial", "--out", str(run), "--force")
    assert again.returncode == 0  # a run folder is replaced


def test_a_generation_that_only_fails_stops_the_run_and_keeps_the_traceback(tmp_path):
    """No C compiler and an empty library cache: every evaluation fails to build the plugin."""
    env = {**os.environ, "PATH": str(tmp_path / "nothing"), "MJREGEN_CACHE": str(tmp_path / "cache")}
    env.pop("CC", None)
    out = tmp_path / "run"
    done = mjregen(*SMALL, "--gens", "3", "--backend", "serial", "--out", str(out), env=env)
    assert done.returncode == 1
    assert "every evaluation of generation 0 failed" in done.stderr and "C compiler" in done.stderr
    log = (out / "errors.log").read_text()
    assert "generation 0: " in log and "Traceback" in log and "NativeBuildError" in log
    assert "Traceback" not in done.stderr


def test_bad_walking_settings_are_refused_before_any_work(tmp_path):
    for command in (SMALL + ["--gens", "1"], ["regen", "--paper", "tripod", "--pop", "4",
                                               "--gens", "1", "--quiet"]):
        out = tmp_path / command[0]
        done = mjregen(*command, "--out", str(out), "--duration", "-1")
        assert done.returncode == 1 and "--duration" in done.stderr
        assert not out.exists()


def test_resume_refuses_an_edited_or_corrupt_config(tmp_path):
    out = tmp_path / "run"
    assert mjregen(*SMALL, "--gens", "1", "--backend", "serial", "--out", str(out)).returncode == 0
    config = json.loads((out / "config.json").read_text())
    config["task"]["physics"]["scene"]["gravity"] = 9.81
    (out / "config.json").write_text(json.dumps(config, indent=2))
    done = mjregen("evolve", "--out", str(out), "--resume", "--quiet")
    assert done.returncode == 1 and "config.json changed" in done.stderr
    (out / "config.json").write_text("{ not json")
    done = mjregen("evolve", "--out", str(out), "--resume", "--quiet")
    assert done.returncode == 1 and "not a readable run configuration" in done.stderr
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr


# MUJOCO_GL=disable: the timing in which Python swallowed the interrupt in a finalizer
@pytest.mark.parametrize("gl", [None, "disable"], ids=["gl-default", "gl-disabled"])
def test_ctrl_c_says_the_checkpoint_is_intact_and_how_to_resume(tmp_path, gl):
    out = tmp_path / "run"
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}
    if gl is not None:
        env["MUJOCO_GL"] = gl
    process = start(*SMALL, "--gens", "500", "--backend", "serial", "--out", str(out), env=env)
    wait_for(out / "checkpoint.npz", process)
    process.send_signal(signal.SIGINT)
    try:
        _, err = process.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        process.kill()
        raise
    assert process.returncode == 130
    assert "Traceback" not in err and "checkpoint" in err and "--resume" in err
    assert f"--out {out}" in err and err.strip().count("\n") == 0


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads worker pids from /proc")
def test_killing_the_main_process_ends_its_workers(tmp_path):
    out = tmp_path / "run"
    process = start(*SMALL, "--gens", "500", "--backend", "process", "--workers", "2",
                    "--out", str(out))
    wait_for(out / "checkpoint.npz", process)
    children = Path(f"/proc/{process.pid}/task/{process.pid}/children").read_text().split()
    assert children, "the pool has no worker processes"
    process.kill()
    process.communicate(timeout=60)
    deadline = time.monotonic() + 30
    while any(Path(f"/proc/{pid}").exists() and "Z" not in _state(pid) for pid in children):
        assert time.monotonic() < deadline, "workers outlived their parent"
        time.sleep(0.2)


def _state(pid: str) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except OSError:
        return "Z"


def test_a_second_evolve_on_a_running_folder_is_refused_even_with_force(tmp_path):
    """The issue's case: a second `mjregen evolve --out R --force` while the first runs used
    to delete R under it; now it is refused, naming the first, and R is left alone."""
    out = tmp_path / "run"
    first = start(*SMALL, "--gens", "50", "--backend", "serial", "--out", str(out))
    try:
        wait_for(out / "checkpoint.npz", first)
        second = mjregen(*SMALL, "--gens", "1", "--seed", "5", "--backend", "serial", "--out",
                         str(out), "--force")
        assert second.returncode == 1
        assert f"is in use by process {first.pid}" in second.stderr
        assert second.stderr.count("\n") == 1
        assert json.loads((out / "config.json").read_text())["seed"] == 0  # the first's
    finally:
        first.send_signal(signal.SIGKILL)
        first.wait()
    assert (out / "checkpoint.npz").is_file()  # the first's files are all there
