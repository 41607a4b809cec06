"""The shared arguments of the commands that walk robots in both simulators."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from mjregen.cli.common import add_engine_robot_arguments, named_paths


def test_robots_are_named_by_their_stem_or_by_name_equals_path():
    assert named_paths(["runs/a/best.npy", "biped=robots/b.npy", "x=y=z.npy"]) == [
        ("best", Path("runs/a/best.npy")), ("biped", Path("robots/b.npy")),
        ("x=y", Path("z.npy"))]


def test_a_name_without_a_file_is_refused():
    with pytest.raises(ValueError, match="'biped=' names no robot file"):
        named_paths(["biped="])


def test_the_engine_folder_is_required_and_robots_may_be_optional():
    parser = argparse.ArgumentParser()
    add_engine_robot_arguments(parser, nargs="*")
    args = parser.parse_args(["--voxelyze", "engine"])
    assert args.voxelyze == Path("engine") and args.robots == []
    with pytest.raises(SystemExit):
        parser.parse_args(["a.npy"])  # no --voxelyze
    strict = argparse.ArgumentParser()
    add_engine_robot_arguments(strict)
    with pytest.raises(SystemExit):
        strict.parse_args(["--voxelyze", "engine"])  # no robot
