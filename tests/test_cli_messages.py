"""What the `mjregen` command says when a user misuses it: one line, naming the fix."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from mjregen.cli import main
from mjregen.grid import Robot
from mjregen.recovery import RecoveryReport

EMPTY_3D = np.zeros((9, 9, 9), dtype=np.int8)
BLOCK = np.pad(np.ones((2, 2, 2), dtype=np.int8), 1)


def one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.startswith("mjregen: error:") and err.count("\n") == 1, err
    return err


@pytest.mark.parametrize("command", [["walk"], ["export", "--out", "{tmp}/x.xml"],
                                     ["render", "--frames", "{tmp}/frames"]])
def test_empty_robot_is_an_error_for_every_robot_command(tmp_path, capsys, command):
    Robot(EMPTY_3D).save(tmp_path / "empty.npy")
    argv = [command[0], str(tmp_path / "empty.npy"), *[a.format(tmp=tmp_path) for a in command[1:]]]
    assert main(argv) == 1
    assert "empty robot" in one_line_error(capsys)
    assert not (tmp_path / "x.xml").exists() and not (tmp_path / "frames").exists()


@pytest.mark.parametrize("command, name", [(["grow", "--dim", "3", "--out"], "taken.npy"),
                                           (["export", "{robot}", "--out"], "taken.xml")])
def test_existing_output_names_the_cli_flag(tmp_path, capsys, command, name):
    Robot(BLOCK).save(tmp_path / "robot.npy")
    target = tmp_path / name
    target.write_text("keep me")
    argv = [a.format(robot=tmp_path / "robot.npy") for a in command] + [str(target)]
    assert main(argv) == 1
    err = one_line_error(capsys)
    assert "pass --force" in err and "overwrite=True" not in err and str(target) in err
    assert target.read_text() == "keep me"


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_unwritable_output_names_the_target_not_a_temporary_file(tmp_path, capsys):
    Robot(BLOCK).save(tmp_path / "robot.npy")
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        assert main(["export", str(tmp_path / "robot.npy"), "--out", str(locked / "r.xml")]) == 1
    finally:
        locked.chmod(0o700)
    err = one_line_error(capsys)
    assert str(locked / "r.xml") in err and "r.xml." not in err


def test_output_under_a_file_names_the_target(tmp_path, capsys):
    Robot(BLOCK).save(tmp_path / "robot.npy")
    (tmp_path / "file").write_text("")
    assert main(["export", str(tmp_path / "robot.npy"), "--out", str(tmp_path / "file" / "r.xml")]) == 1
    err = one_line_error(capsys)
    assert f"cannot write {tmp_path / 'file' / 'r.xml'}" in err


def test_python_dash_m_mjregen_runs():
    done = subprocess.run([sys.executable, "-m", "mjregen", "--help"], capture_output=True,
                          text=True)
    assert done.returncode == 0 and "evolve-stats" in done.stdout


def test_help_texts_have_no_literal_percent_signs_and_every_option_is_explained():
    from mjregen.cli import build_parser

    parser = build_parser()
    subparsers = next(a for a in parser._actions if a.choices and "walk" in a.choices)
    for name, sub in subparsers.choices.items():
        text = sub.format_help()
        assert "%%" not in text, name
        for action in sub._actions:
            if action.option_strings and action.dest != "help":
                assert action.help, f"mjregen {name} {action.option_strings[0]} has no help"


def test_percent_of_a_distance_that_is_no_walk_is_not_applicable():
    report = RecoveryReport(
        similarity={"damaged": 10, "regrown": 20}, grid_cells=729,
        robot_similarity={"damaged": 0.5, "regrown": 0.9},
        voxels={"original": 10, "damaged": 0, "regrown": 9},
        distance={"original": 1e-12, "damaged": 0.0, "regrown": 3.0},
        stable={"original": True, "damaged": True, "regrown": True}, duration=0.5,
        fitness={"original": 0.0, "damaged": -20.0, "regrown": 2.0})
    assert np.isnan(report.percent_of_original("regrown"))
    table = report.to_markdown()
    assert "n/a" in table and "nan" not in table and "%)" not in table
    assert report.to_dict()["percent_of_original"]["regrown"] is None
