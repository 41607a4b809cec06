"""The `mjregen` command: grow and show, their JSON, and one-line errors."""

import json
import subprocess
import sys

import numpy as np
import pytest

from mjregen.checkpoint import save_nca
from mjregen.cli import main
from mjregen.grid import Robot
from mjregen.nca import NCA, NCAConfig


def test_grow_random_nca_json_matches_the_library(tmp_path, capsys):
    out = tmp_path / "robot.npy"
    assert main(["grow", "--dim", "2", "--net", "lstm", "--seed", "5", "--out", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    expected = NCA.random(NCAConfig(dim=2, kind="lstm"), seed=5).grow()
    assert len(report["steps"]) == 11
    assert [s["voxels"] for s in report["steps"]] == [int(np.count_nonzero(s)) for s in expected.states[0]]
    assert Robot.load(out) == expected.robot()
    assert report["robot"]["grid"] == expected.robot().grid.tolist()


def test_grow_from_checkpoint_prints_steps_and_robot(tmp_path, capsys):
    nca = NCA.random(NCAConfig(dim=3), seed=2)
    path = save_nca(tmp_path / "nca.npz", nca)
    assert main(["grow", "--checkpoint", str(path), "--steps", "3"]) == 0
    text = capsys.readouterr().out
    assert "step  3:" in text and "step  4:" not in text
    assert nca.grow(steps=3).robot().to_text() in text


def test_grow_never_overwrites_without_force(tmp_path, capsys):
    out = tmp_path / "robot.npy"
    Robot(np.zeros((7, 7))).save(out)
    assert main(["grow", "--dim", "2", "--out", str(out)]) == 1
    assert "exists" in capsys.readouterr().err
    assert Robot.load(out).is_empty
    assert main(["grow", "--dim", "2", "--out", str(out), "--force"]) == 0


def test_show_text_and_json(tmp_path, capsys):
    robot = Robot.from_body(np.array([[[1, 2], [3, 4]]]))
    path = robot.save(tmp_path / "r.npy")
    assert main(["show", str(path)]) == 0
    assert capsys.readouterr().out.strip() == robot.to_text()
    assert main(["show", str(path), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["voxels"] == 4 and report["materials"]["hard"] == 1 and report["shape"] == [3, 4, 4]


@pytest.mark.parametrize(
    "make, args, message",
    [
        (None, ["show", "{tmp}/missing.npy"], "not found"),
        (lambda p: np.save(p / "bad.npy", np.full((5, 5), 7)), ["show", "{tmp}/bad.npy"], "unknown material code 7"),
        (lambda p: np.save(p / "flat.npy", np.zeros(5)), ["show", "{tmp}/flat.npy"], "dimensions"),
        (lambda p: (p / "junk.npz").write_bytes(b"junk"), ["grow", "--checkpoint", "{tmp}/junk.npz"], "not a readable"),
        (None, ["grow", "--steps", "0"], "--steps"),
    ],
)
def test_bad_input_gives_one_line_error(tmp_path, capsys, make, args, message):
    if make is not None:
        make(tmp_path)
    assert main([a.format(tmp=tmp_path) for a in args]) == 1
    err = capsys.readouterr().err
    assert err.startswith("mjregen: error:") and message in err and err.count("\n") == 1


def test_console_entry_point_runs():
    result = subprocess.run([sys.executable, "-m", "mjregen.cli", "--help"], capture_output=True, text=True)
    assert result.returncode == 0 and "grow" in result.stdout and "show" in result.stdout
    result = subprocess.run([sys.executable, "-m", "mjregen.cli", "show"], capture_output=True, text=True)
    assert result.returncode == 2 and "Traceback" not in result.stderr
