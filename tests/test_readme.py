"""Every shell command in README.md's code blocks runs, at a reduced scale, in a scratch
folder (so the README cannot show a command that fails)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# commands that are not run, and why
NOT_RUN = {
    "pip install": "the install itself (CI runs it before these tests)",
    "scripts/paper_experiments.py --scale quick": "runs for an hour (--dry-run of it is run)",
    "scripts/ship_assets.py": "replaces the project's shipped assets",
    "scripts/ship_regrowth.py": "replaces the project's shipped regrowth NCAs",
    "scripts/results_report.py": "rewrites the project's docs/results.md",
    "scripts/snapshot_runs.py": "replaces the project's record of a run in records/",
}
# the scale: populations, generations, walks and videos made small
SMALLER = [(r"--pop \d+", "--pop 4"), (r"--gens \d+", "--gens 1"),
           (r"--scale quick", "--scale smoke")]
FAST_WALK = "--settle 0.005 --duration 0.01"


def readme_commands() -> list[str]:
    """The README's bash blocks as commands (multi-line quoted strings kept whole)."""
    commands = []
    for block in re.findall(r"```bash\n(.*?)```", (ROOT / "README.md").read_text(), re.S):
        current = ""
        for line in block.splitlines():
            current += line + "\n"
            if current.count('"') % 2 == 0:  # a complete command
                text = re.sub(r"\s+#[^\"\n]*$", "", current.strip())
                if text:
                    commands.append(text)
                current = ""
    return commands


def reduced(command: str) -> str:
    for pattern, replacement in SMALLER:
        command = re.sub(pattern, replacement, command)
    words = command.split()
    if words[:2] == ["mjregen", "evolve"] and "--resume" not in words:
        command += ("" if "--pop" in words else " --pop 4 --gens 1") + f" {FAST_WALK}"
    if words[:2] == ["mjregen", "regen"]:
        command += f" --no-video {FAST_WALK}"
    if words[:2] == ["mjregen", "render"]:
        command += f" {FAST_WALK} --width 64 --height 48"
    if words[:2] in (["mjregen", "walk"],):
        command += f" {FAST_WALK}"
    if "scripts/grow_and_walk.py" in command:
        command += " --duration 0.01 --width 64 --height 48"
    return command


def test_the_readme_has_commands_and_every_skip_names_one():
    commands = readme_commands()
    assert any(c.startswith("mjregen evolve") for c in commands)
    assert any(c.startswith("python -c") and "\n" in c for c in commands)  # kept whole
    for key in NOT_RUN:  # a skip that no longer matches a command is stale
        assert any(key in c for c in commands), key


def test_every_readme_command_runs(tmp_path):
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    for name in ("assets", "scripts"):
        (scratch / name).symlink_to(ROOT / name)
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    for command in readme_commands():
        if any(key in command for key in NOT_RUN):
            continue
        command = reduced(command).replace("python ", f"{sys.executable} ", 1)
        done = subprocess.run(command, shell=True, cwd=scratch, env=env, capture_output=True,
                              text=True, timeout=600)
        assert done.returncode == 0, f"{command}\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
