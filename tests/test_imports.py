"""The import graph of the package has no cycle (imports inside functions included), and
walking a robot imports only what it needs."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import mjregen
from mjregen.resources import asset

ROOT = Path(mjregen.__file__).parent


def module_graph() -> dict[str, set[str]]:
    """Module name -> the mjregen modules it imports anywhere in its source."""
    files = {}
    for path in ROOT.rglob("*.py"):
        parts = ("mjregen", *path.relative_to(ROOT).with_suffix("").parts)
        files[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    graph = {name: set() for name in files}
    for name, path in files.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module:
                targets = []
                for alias in node.names:
                    member = f"{node.module}.{alias.name}"
                    if member in files and name.startswith(node.module + "."):
                        # a package's own module importing a sibling through the package
                        # (`from mjregen.physics import native` in mjregen.physics.compile):
                        # the package is being initialised; only the sibling is loaded
                        targets.append(member)
                    else:
                        targets += [node.module, member]
            elif isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            else:
                continue
            graph[name].update(t for t in targets if t in files and t != name)
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str]:
    """One cycle as a path of module names, or [] when the graph is acyclic."""
    state: dict[str, int] = {}
    path: list[str] = []

    def visit(node: str) -> list[str]:
        state[node] = 1
        path.append(node)
        for child in sorted(graph[node]):
            if state.get(child) == 1:
                return path[path.index(child):] + [child]
            if child not in state and (cycle := visit(child)):
                return cycle
        path.pop()
        state[node] = 2
        return []

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)):
            return cycle
    return []


def test_find_cycle_finds_one():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) == []


def test_the_package_has_no_import_cycle():
    graph = module_graph()
    assert "mjregen.physics.native" in graph["mjregen.physics.compile"]
    assert "mjregen.physics" not in graph["mjregen.physics.compile"]  # siblings only
    assert "mjregen.physics" in graph["mjregen.locomotion"]  # the package's own names
    assert find_cycle(graph) == []


def test_walking_a_robot_imports_only_what_it_needs(tmp_path):
    """`mjregen walk` (start-up cost: docs/performance.md) loads neither torch, matplotlib,
    Ray nor any OpenGL binding."""
    robot = asset("robots", "paper", "tripod.npy")
    probe = ("import runpy, sys; sys.argv = ['mjregen', 'walk', %r, '--json', '--settle', '0',"
             " '--duration', '0']\ntry:\n    runpy.run_module('mjregen', run_name='__main__')\n"
             "except SystemExit:\n    pass\nprint(sorted(m for m in sys.modules if m.split('.')[0]"
             " in ('torch', 'matplotlib', 'ray', 'glfw', 'OpenGL')))" % str(robot))
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          cwd=tmp_path, check=True)
    assert '"stable": true' in done.stdout
    assert done.stdout.strip().splitlines()[-1] == "[]"


def test_importing_the_package_loads_neither_numpy_nor_mujoco():
    probe = ("import sys, mjregen; print(sorted(m for m in ('numpy', 'mujoco', 'torch') "
             "if m in sys.modules)); print(mjregen.Robot.__name__)")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          check=True)
    assert done.stdout.split() == ["[]", "Robot"]


def test_the_command_starts_no_blas_threads_unless_the_user_asks(tmp_path):
    """OpenBLAS starts its thread pool when numpy is imported: the `mjregen` command sets it
    to one thread first, and keeps a user's own setting (threads counted in /proc)."""
    probe = ("import os, mjregen.cli, numpy; print(os.environ['OPENBLAS_NUM_THREADS'], "
             "len(os.listdir('/proc/self/task')))")
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    alone = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                           env=env, check=True).stdout.split()
    asked = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                           env={**env, "OPENBLAS_NUM_THREADS": "2"}, check=True).stdout.split()
    assert alone[0] == "1" and asked[0] == "2"
    assert int(alone[1]) < int(asked[1])  # the user's second BLAS thread is there
