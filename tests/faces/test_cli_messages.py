"""What the `mjregen` command says when a user misuses it: one line, naming the fix."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

import numpy as np
import pytest

from mjregen.cli import main
from mjregen.experiments.recovery import RecoveryReport
from mjregen.grid import Robot

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
    assert f"{tmp_path / 'file' / 'r.xml'}: cannot write it:" in err and "Errno" not in err


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


def test_a_parser_of_one_command_parses_that_command_as_the_whole_parser_does():
    from mjregen.cli import COMMANDS, build_parser

    def subcommands(parser):
        return next(a for a in parser._actions
                    if isinstance(a, argparse._SubParsersAction)).choices

    assert list(subcommands(build_parser())) == list(COMMANDS)
    for argv in (["walk", "r.npy", "--json", "--duration", "0.1"],
                 ["evolve", "--dim", "2", "--pop", "4", "--out", "o"],
                 ["regen", "--paper", "tripod", "--gens", "3"], ["evolve-stats", "--group", "ff", "a", "--out", "s"]):
        alone = build_parser(argv[0])
        assert list(subcommands(alone)) == [argv[0]]
        assert vars(alone.parse_args(argv)) == vars(build_parser().parse_args(argv))


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


def test_misused_numbers_and_backends_are_one_line_errors(tmp_path, capsys):
    for argv, message in ((["evolve", "--workers", "-2"], "--workers"),
                          (["evolve", "--workers", "0"], "all cores"),
                          (["evolve", "--seed", "-1"], "seed")):
        with pytest.raises(SystemExit) as exit_:
            main([*argv, "--out", str(tmp_path / "run")])
        assert exit_.value.code == 2 and message in capsys.readouterr().err
    assert not (tmp_path / "run").exists()  # nothing half-made blocks the corrected rerun


def test_unreachable_ray_cluster_fails_within_seconds(tmp_path):
    pytest.importorskip("ray")
    import time

    start = time.monotonic()
    done = subprocess.run([sys.executable, "-m", "mjregen", "evolve", "--dim", "2", "--pop", "4",
                           "--gens", "1", "--backend", "ray", "--address", "127.0.0.1:1",
                           "--out", str(tmp_path / "run")], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 1 and "cannot reach the Ray cluster" in done.stderr
    assert time.monotonic() - start < 60 and not (tmp_path / "run").exists()


def test_missing_opengl_library_stops_only_rendering(tmp_path, monkeypatch):
    """MUJOCO_GL naming a backend whose library is absent: walking works, rendering says
    what to install (one line)."""
    import ctypes.util

    Robot(BLOCK).save(tmp_path / "robot.npy")
    real = ctypes.util.find_library
    env = {**os.environ, "MUJOCO_GL": "osmesa"}
    if real("OSMesa") is not None:
        pytest.skip("libOSMesa is installed here")
    walk = subprocess.run([sys.executable, "-m", "mjregen", "walk", str(tmp_path / "robot.npy"),
                           "--duration", "0.01"], capture_output=True, text=True, env=env)
    assert walk.returncode == 0 and "distance" in walk.stdout
    render = subprocess.run([sys.executable, "-m", "mjregen", "render",
                             str(tmp_path / "robot.npy"), "--duration", "0.01", "--frames",
                             str(tmp_path / "frames")], capture_output=True, text=True, env=env)
    assert render.returncode == 1 and "libosmesa6" in render.stderr
    assert render.stderr.count("\n") == 1


def test_a_command_that_does_not_render_searches_for_no_opengl_library(tmp_path, monkeypatch,
                                                                       capsys):
    """Searching for a library (ctypes.util.find_library runs ldconfig) costs start-up time
    that walking does not need, whatever MUJOCO_GL names."""
    from mjregen import gl

    def search(backend: str) -> None:
        raise AssertionError(f"searched for the library of {backend!r}")

    monkeypatch.setattr(gl, "missing_library", search)
    monkeypatch.setenv("MUJOCO_GL", "egl")
    Robot(BLOCK).save(tmp_path / "robot.npy")
    assert main(["walk", str(tmp_path / "robot.npy"), "--duration", "0.01", "--json"]) == 0
    assert '"distance"' in capsys.readouterr().out


def test_broken_pipe_is_quiet(tmp_path):
    Robot(np.pad(np.ones((7, 7, 7), dtype=np.int8), 1)).save(tmp_path / "robot.npy")
    done = subprocess.run(f"'{sys.executable}' -m mjregen show '{tmp_path / 'robot.npy'}' "
                          "2>&1 | head -c 10",
                          shell=True, executable="/bin/bash", capture_output=True, text=True)
    assert "Traceback" not in done.stdout and "BrokenPipe" not in done.stdout


def test_random_bytes_are_not_a_robot_and_get_no_pickle_advice(tmp_path, capsys):
    (tmp_path / "r.npy").write_bytes(os.urandom(400))
    assert main(["show", str(tmp_path / "r.npy")]) == 1
    err = one_line_error(capsys)
    assert "allow_pickle" not in err and "not a valid .npy robot file" in err


def test_evolve_stats_refuses_mixed_tasks_says_when_it_cuts_and_keeps_its_output(tmp_path, capsys):
    import json

    for name, task, generations in (("a", "locomotion", 3), ("b", "locomotion", 5),
                                    ("c", "regrowth", 3)):
        run = tmp_path / name
        run.mkdir()
        (run / "config.json").write_text(json.dumps({"task": {"task": task}}))
        rows = "".join(f"{g},{g}\n" for g in range(generations))
        (run / "metrics.csv").write_text("generation,best\n" + rows)
    out = tmp_path / "curves.png"
    assert main(["evolve-stats", "--group", "x", str(tmp_path / "a"), str(tmp_path / "c"),
                 "--out", str(out)]) == 1
    assert "different tasks" in one_line_error(capsys)
    assert main(["evolve-stats", "--group", "x", str(tmp_path / "a"), str(tmp_path / "b"),
                 "--out", str(out)]) == 0
    assert "cut to its shortest run, 3 generations (runs have 3, 5)" in capsys.readouterr().err
    assert main(["evolve-stats", "--group", "x", str(tmp_path / "a"), "--out", str(out)]) == 1
    assert "pass --force" in one_line_error(capsys)


def test_the_environment_refuses_an_empty_robot_like_the_commands():
    from mjregen.env import load
    from mjregen.errors import CompileError

    with pytest.raises(CompileError, match="empty robot"):
        load(Robot(EMPTY_3D))


@pytest.mark.parametrize("flags, message", [
    (["--backend", "serial", "--workers", "2"], "--backend serial runs one evaluation"),
    (["--optimizer", "map-elites", "--line-sigma", "0.3"], "add --emitter iso-line"),
    (["--pop", "1"], "fewer than the population"),
    (["--pop", "4", "--elites", "4"], "no child is ever mutated"),
])
def test_evolve_refuses_settings_it_would_ignore_or_that_never_mutate(tmp_path, capsys, flags,
                                                                      message):
    out = tmp_path / "run"
    assert main(["evolve", "--dim", "2", "--gens", "1", "--quiet", "--out", str(out),
                 *flags]) == 1
    assert message in one_line_error(capsys)
    assert not out.exists()


def test_json_output_is_valid_json_without_finite_numbers(capsys):
    """NaN and infinities (an unstable walk, a best fitness before any) print as null."""
    import json

    from mjregen.cli.common import print_json

    print_json({"best": float("-inf"), "walks": [1.5, float("nan")], "pair": (float("inf"), 2)})
    assert json.loads(capsys.readouterr().out) == {"best": None, "walks": [1.5, None],
                                                   "pair": [None, 2]}


def test_an_os_error_names_the_path_and_the_reason_without_its_number(capsys):
    assert main(["grow", "--out", "/proc/mjregen/robot.npy"]) == 1
    err = one_line_error(capsys)
    assert "/proc/mjregen/robot.npy: cannot write it:" in err and "Errno" not in err
