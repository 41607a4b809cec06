"""Where run folders stand: finished, stopped (resumable) or running in a live process."""

import fcntl
import json
import os
import threading

import pytest
from test_run_lock import holder  # a second process holding a folder's lock
from test_runs import Killed, metrics, run  # the same tiny run

from mjregen.cli import main
from mjregen.search.run_lock import LOCK_FILE, PROBE_GRACE_S, RunLock, holder_of
from mjregen.search.run_status import find_run_folders, run_status


def kill_after_generation_2(row):
    if row["generation"] == 2:
        raise Killed


@pytest.fixture
def runs(tmp_path):
    """A finished run and one stopped after 3 of 6 generations, in two folders, beside a
    folder whose config.json is not a run's."""
    finished, stopped = tmp_path / "a" / "finished", tmp_path / "b" / "stopped"
    run(finished)
    with pytest.raises(Killed):
        run(stopped, on_generation=kill_after_generation_2)
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "config.json").write_text(json.dumps({"name": "not a run"}))
    return finished, stopped


def test_finished_stopped_and_running_runs_are_told_apart(tmp_path, runs):
    finished, stopped = runs
    assert find_run_folders([tmp_path]) == [finished, stopped]
    assert find_run_folders([stopped, tmp_path / "b"]) == [stopped]  # each once
    status = run_status(finished)
    assert (status.state, status.method, status.hours_left) == ("finished", "GA", 0.0)
    assert status.progress.best == max(float(row["best"]) for row in metrics(finished))
    status = run_status(stopped)
    assert (status.state, status.resumable, status.holder) == ("stopped", True, None)
    elapsed = float(metrics(stopped)[-1]["elapsed"])
    assert status.hours_left == pytest.approx(elapsed / 3 * (6 - 3) / 3600)  # the pace so far
    process = holder(stopped)
    try:
        status = run_status(stopped)
        assert status.state == "running" and f"process {process.pid} " in status.holder
    finally:
        process.kill()
        process.wait()
    assert run_status(stopped).state == "stopped"  # the lock went with its process
    (stopped / "checkpoint.npz").unlink()
    assert not run_status(stopped).resumable
    assert holder_of(tmp_path / "other") is None
    assert not (tmp_path / "other" / LOCK_FILE).exists()  # the probe creates nothing


def test_runs_command_lists_them_and_names_bad_paths(tmp_path, runs, capsys):
    finished, stopped = runs
    assert main(["runs", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3 and lines[0].split() == ["run", "method", "done", "best", "hours",
                                                    "left", "state"]
    assert lines[1].startswith(str(finished)) and lines[1].split()[2:3] == ["6/6"]
    assert lines[1].endswith("finished")
    assert lines[2].split()[2] == "3/6" and lines[2].endswith("stopped: resumable (--resume)")
    assert main(["runs", str(stopped), "--json"]) == 0
    listed, = json.loads(capsys.readouterr().out)
    assert (listed["run"], listed["state"], listed["done"], listed["planned"]) == (
        str(stopped), "stopped", 3, 6)
    (finished / "metrics.csv").write_text("generation,best\n0,x\n")  # damaged
    assert main(["runs", str(tmp_path)]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].startswith(str(stopped))  # the others still listed
    assert lines[-1].startswith(f"{finished}: unreadable: {finished / 'metrics.csv'} is not")
    assert main(["runs", str(tmp_path / "missing")]) == 1
    assert "no such folder" in capsys.readouterr().err
    assert main(["runs", str(tmp_path / "other")]) == 1
    assert "no run folder" in capsys.readouterr().err


def test_a_run_starting_during_a_probe_waits_for_it(tmp_path):
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "config.json").write_text("{}")
    with RunLock(folder):
        assert holder_of(folder).startswith(f"process {os.getpid()} ")
    probe = open(folder / LOCK_FILE)  # a probe's shared lock, released within the grace
    fcntl.flock(probe.fileno(), fcntl.LOCK_SH)
    threading.Timer(PROBE_GRACE_S / 4, probe.close).start()
    with RunLock(folder):
        assert holder_of(folder).startswith(f"process {os.getpid()} ")
