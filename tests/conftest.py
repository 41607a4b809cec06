"""What every test shares: ``MUJOCO_GL`` as the test found it. A command run in-process
(`mjregen.cli.main`) that renders nothing sets it to "disable" before MuJoCo's first import,
and a later test's subprocess that renders must not inherit that."""

import os

import pytest


@pytest.fixture(autouse=True)
def _restore_mujoco_gl():
    before = os.environ.get("MUJOCO_GL")
    yield
    if before is None:
        os.environ.pop("MUJOCO_GL", None)
    else:
        os.environ["MUJOCO_GL"] = before
