"""The architecture as a contract: the package's layers (docs/design.md), bottom to top

    base → grid → growth → physics → tasks → search → validation → experiments → faces

import only from their own layer or below (imports inside functions included, imports for
type checking only left out), nothing has an import cycle, and walking a robot imports
only what it needs."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import mjregen
from mjregen.resources import asset

ROOT = Path(mjregen.__file__).parent


# Each layer by module prefix. base: utilities every layer may use; faces: what a person
# touches (the command line, rendering, figures, the dm_control environment).
LAYERS = {
    "base": ("mjregen.errors", "mjregen.fileio", "mjregen.resources", "mjregen.interrupt",
             "mjregen.plotting"),
    "grid": ("mjregen.grid",),
    "growth": ("mjregen.growth",),
    "physics": ("mjregen.physics",),
    "tasks": ("mjregen.tasks",),
    "search": ("mjregen.search",),
    "validation": ("mjregen.validation",),
    "experiments": ("mjregen.experiments",),
    "faces": ("mjregen.cli", "mjregen.render", "mjregen.figures", "mjregen.env",
              "mjregen.gl", "mjregen.video", "mjregen.__main__"),
}
ORDER = list(LAYERS)
FACADE = "mjregen"  # the package itself: its lazy names reach into the layers on request


def layer_of(module: str) -> str:
    """The layer of a module name (KeyError for a module that has none: place it)."""
    for layer, prefixes in LAYERS.items():
        if any(module == p or module.startswith(p + ".") for p in prefixes):
            return layer
    raise KeyError(module)


def layer_violations(graph: dict[str, set[str]]) -> list[str]:
    """Each import of a module from a higher layer, as "a (layer) imports b (layer)"."""
    found = []
    for module, targets in sorted(graph.items()):
        if module == FACADE:
            continue
        for target in sorted(targets - {FACADE}):
            if ORDER.index(layer_of(target)) > ORDER.index(layer_of(module)):
                found.append(f"{module} ({layer_of(module)}) imports {target} "
                             f"({layer_of(target)})")
    return found


def _type_checking_only(tree: ast.Module) -> set[int]:
    """ids of the import nodes inside ``if TYPE_CHECKING:`` blocks."""
    skipped = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            skipped.update(id(child) for stmt in node.body for child in ast.walk(stmt))
    return skipped


def module_graph() -> dict[str, set[str]]:
    """Module name -> the mjregen modules it imports anywhere in its source, type-checking
    imports aside."""
    files = {}
    for path in ROOT.rglob("*.py"):
        parts = ("mjregen", *path.relative_to(ROOT).with_suffix("").parts)
        files[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    graph = {name: set() for name in files}
    for name, path in files.items():
        tree = ast.parse(path.read_text())
        skipped = _type_checking_only(tree)
        for node in ast.walk(tree):
            if id(node) in skipped:
                continue
            if isinstance(node, ast.ImportFrom) and node.module:
                targets = []
                for alias in node.names:
                    member = f"{node.module}.{alias.name}"
                    if member in files and name.startswith(node.module + "."):
                        # a package's own module importing a sibling through the package
                        # (`from mjregen.physics import voxel_plugin` in mjregen.physics.compile):
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
    assert "mjregen.physics.voxel_plugin" in graph["mjregen.physics.builders"]
    assert "mjregen.physics" not in graph["mjregen.physics.compile"]  # siblings only
    assert "mjregen.physics" in graph["mjregen.tasks.locomotion"]  # the package's own names
    cycle = find_cycle(graph)
    assert not cycle, "import cycle: " + " -> ".join(cycle)


def _has_layer(module: str) -> bool:
    try:
        layer_of(module)
    except KeyError:
        return False
    return True


def test_every_module_has_a_layer():
    assert [m for m in module_graph() if m != FACADE and not _has_layer(m)] == []


def test_a_layer_imports_only_from_its_own_layer_or_below():
    violations = layer_violations(module_graph())
    assert not violations, "imports against the layers:\n" + "\n".join(violations)


def test_the_contract_catches_a_wrong_import():
    """A lower layer importing a higher one (the command line below the faces, a task
    reaching into the search) is caught; an import inside a function counts, one for type
    checking only does not."""
    graph = module_graph()
    graph["mjregen.grid"] = graph["mjregen.grid"] | {"mjregen.cli"}
    graph["mjregen.tasks.locomotion"] = graph["mjregen.tasks.locomotion"] | {"mjregen.search.runs"}
    assert layer_violations(graph) == [
        "mjregen.grid (grid) imports mjregen.cli (faces)",
        "mjregen.tasks.locomotion (tasks) imports mjregen.search.runs (search)"]
    source = ("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
              "    from mjregen.search.backends import Backend\n"
              "def f():\n    from mjregen.cli import main\n")
    tree = ast.parse(source)
    skipped = _type_checking_only(tree)
    imported = [n.module for n in ast.walk(tree)
                if isinstance(n, ast.ImportFrom) and id(n) not in skipped]
    assert imported == ["typing", "mjregen.cli"]


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


LONGEST_FUNCTION = 60  # lines, decorators and docstring included


def _long_functions(source: str) -> list[tuple[str, int]]:
    """(name, lines) of every function in `source` longer than `LONGEST_FUNCTION`."""
    return [(node.name, node.end_lineno - node.lineno + 1) for node in ast.walk(ast.parse(source))
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.end_lineno - node.lineno + 1 > LONGEST_FUNCTION]


def test_no_function_is_longer_than_sixty_lines():
    """The package, its benchmarks and its scripts: a longer function is split into parts
    with names that say what each does."""
    project = ROOT.parent
    files = [p for folder in ("mjregen", "benchmarks", "scripts")
             for p in sorted((project / folder).rglob("*.py"))]
    assert len(files) > 50
    long = {f"{path.relative_to(project)}:{name}": lines for path in files
            for name, lines in _long_functions(path.read_text())}
    assert not long, f"functions over {LONGEST_FUNCTION} lines: {long}"


def test_the_length_check_sees_a_long_function():
    body = "\n".join(f"    x{i} = {i}" for i in range(LONGEST_FUNCTION))
    assert _long_functions(f"def long():\n{body}\n") == [("long", LONGEST_FUNCTION + 1)]
    assert _long_functions(f"def short():\n{body[:-len(body.splitlines()[-1]) - 1]}\n") == []
