"""The plan of the house, held against the code: the root keeps only its face and a few shared
modules, packages import one another without a cycle (imports inside functions and under
TYPE_CHECKING counted), and a package reaches another only through its face (its ``__all__``)."""

from __future__ import annotations

import ast
import importlib
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SOURCE = ROOT / "frictionid_core" / "src" / "frictionid_core"
ROS_SOURCE = ROOT / "frictionid_ros" / "frictionid_ros"
PACKAGE = "frictionid_core"
# Modules at the package root besides __init__.py: the errors, the one time series, the thread
# pool, the lazy-import mechanism.
ROOT_MODULES = {"errors", "timeseries", "parallel", "lazy"}


def modules(source: Path = SOURCE) -> dict[str, Path]:
    """Every module of a package by its dotted name (a package by its own name)."""
    found = {}
    for path in source.rglob("*.py"):
        parts = path.relative_to(source.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        found[name] = path
    return found


def unit(module: str) -> str:
    """The package a module belongs to (``frictionid_core.X``), or the root module itself."""
    return ".".join(module.split(".")[:2])


def imports(path: Path, name: str, known: dict[str, Path], package: str = PACKAGE
            ) -> list[tuple[str, list[str], int]]:
    """(imported module, the names taken from it, line) for every import of ``package`` in ``path``,
    wherever it stands (module level, inside a function, under TYPE_CHECKING)."""
    out = []
    top = package
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(alias.name, [], node.lineno) for alias in node.names if alias.name.startswith(top)]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if not target.startswith(top):
                continue
            names = [alias.name for alias in node.names]
            submodules = [f"{target}.{n}" for n in names if f"{target}.{n}" in known]
            out.append((target, [n for n in names if f"{target}.{n}" not in known], node.lineno))
            out += [(sub, [], node.lineno) for sub in submodules]
    return out


def package_graph() -> dict[str, set[str]]:
    known = modules()
    graph = defaultdict(set)
    for name, path in known.items():
        for target, _, _ in imports(path, name, known):
            a, b = unit(name), unit(target)
            if a != b and b != PACKAGE:
                graph[a].add(b)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node (Tarjan)."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(set(graph) | {w for ws in graph.values() for w in ws}):
        if v not in index:
            visit(v)
    return found


def test_the_root_holds_only_its_face_and_the_shared_modules():
    root = {p.stem for p in SOURCE.glob("*.py")} - {"__init__"}
    assert root == ROOT_MODULES
    assert len(root) <= 6


def test_no_package_imports_one_that_imports_it_back():
    assert cycles(package_graph()) == []


@pytest.mark.parametrize("source", [SOURCE, ROS_SOURCE], ids=["frictionid_core", "frictionid_ros"])
def test_no_module_imports_one_that_imports_it_back(source):
    """No circle of files, a package's face counted as the modules it names (what it imports)."""
    known = modules(source)
    graph = defaultdict(set)
    for name, path in known.items():
        for target, _, _ in imports(path, name, known, source.name):
            if target in known and target != name and not name.startswith(target + "."):
                graph[name].add(target)
    assert cycles(graph) == []


def test_the_cycle_finder_finds_a_cycle_through_three_packages():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_packages_reach_one_another_only_through_their_faces():
    known = modules()
    faces = {name for name, path in known.items() if path.name == "__init__.py" and name != PACKAGE}
    leaks = []
    for name, path in sorted(known.items()):
        for target, names, line in imports(path, name, known):
            if unit(target) == unit(name) or target == PACKAGE:
                continue
            where = f"{path.relative_to(SOURCE)}:{line}"
            if target in faces:
                public = importlib.import_module(target).__all__
                leaks += [f"{where}: {target}.{n}" for n in names if n not in public]
            elif unit(target) in faces and target.rpartition(".")[2] in importlib.import_module(unit(target)).__all__:
                continue  # a submodule the face lists (``robots.tx40``)
            elif unit(target) in faces:
                leaks.append(f"{where}: {target} (inside the package {unit(target)})")
            else:  # a root module: its public names only
                leaks += [f"{where}: {target}.{n}" for n in names if n.startswith("_")]
    assert leaks == []


@pytest.mark.parametrize("face", sorted(p.parent.name for p in SOURCE.glob("*/__init__.py")))
def test_a_face_lists_names_that_exist(face):
    module = importlib.import_module(f"{PACKAGE}.{face}")
    assert module.__all__ == sorted(set(module.__all__), key=module.__all__.index)
    for name in module.__all__:
        assert getattr(module, name) is not None, f"{face}.{name}"
