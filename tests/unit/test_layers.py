"""The structure of DESIGN.md section 2 holds: each package imports only the packages below it in the
layering (core at the bottom, the viewer at the top), nothing imports upward, and no two packages or
two files import each other, directly or through others (every import counts, in-function ones too)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# bottom to top: a package may import only packages earlier in this list
LAYERS = ["core", "geometry", "sph", "rigid", "render", "scenes", "sim", "anisofrac", "viewer"]


def _modules() -> dict[str, Path]:
    return {f"{p}.{f.stem}": f for p in LAYERS for f in sorted((ROOT / p).glob("*.py"))}


def _imports(path: Path) -> set[str]:
    """Every project module or package a file imports (top-level and in-function)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
            out |= {f"{node.module}.{a.name}" for a in node.names}
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
    return {n for n in out if n.split(".")[0] in LAYERS}


def _cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the directed graph, or None (depth-first search with colours)."""
    state: dict[str, int] = {}

    def visit(u: str, path: list[str]) -> list[str] | None:
        state[u] = 1
        for v in sorted(edges.get(u, ())):
            if state.get(v) == 1:
                return path[path.index(v):] + [v]
            if v not in state:
                found = visit(v, path + [v])
                if found:
                    return found
        state[u] = 2
        return None

    for u in sorted(edges):
        if u not in state:
            found = visit(u, [u])
            if found:
                return found
    return None


def test_packages_import_only_lower_layers():
    rank = {p: i for i, p in enumerate(LAYERS)}
    upward = []
    for mod, path in _modules().items():
        pkg = mod.split(".")[0]
        for name in _imports(path):
            other = name.split(".")[0]
            if rank[other] > rank[pkg]:
                upward.append(f"{mod} imports {name}")
    assert not upward, "\n".join(upward)


def test_no_import_cycle_between_files():
    mods = _modules()
    edges: dict[str, set[str]] = {}
    for mod, path in mods.items():
        targets = set()
        for name in _imports(path):
            parts = name.split(".")
            target = ".".join(parts[:2])
            if target in mods and target != mod:
                targets.add(target)
        edges[mod] = targets
    assert _cycle(edges) is None, _cycle(edges)


def test_cycle_finder_finds_a_cycle():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


MAX_FILE_LINES = 500  # lines: a file holds one responsibility
MAX_FUNCTION_LINES = 80  # lines: a function does one step (Algorithm 1's steps, a rigid stage, ...)


def test_files_and_functions_stay_small():
    too_long = []
    for mod, path in _modules().items():
        text = path.read_text()
        if text.count("\n") > MAX_FILE_LINES:
            too_long.append(f"{mod}: {text.count(chr(10))} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    too_long.append(f"{mod}.{node.name}: {n} lines")
    assert not too_long, "\n".join(too_long)


def test_every_module_says_what_it_does():
    missing = [mod for mod, path in _modules().items() if ast.get_docstring(ast.parse(path.read_text())) is None]
    assert not missing, missing
