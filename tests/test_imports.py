"""The packages' imports form no cycle, counting imports inside functions too.

A cycle hidden in a function-level import still ties two layers together: the data flow of
ARCHITECTURE.md (conductivity, domain, geometry → mesher → measure, io → cli, app) points one way.
"""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {"qmesh": ROOT / "qmesh", "qmesh_view": ROOT / "app"}


def modules() -> dict[str, Path]:
    """Every module of qmesh and qmesh_view by its dotted name (a package by its __init__)."""
    found = {}
    for name, folder in PACKAGES.items():
        for path in folder.rglob("*.py"):
            parts = [name, *path.relative_to(folder).with_suffix("").parts]
            if parts[-1] == "__init__":
                parts.pop()
            found[".".join(parts)] = path
    return found


def imports_of(name: str, path: Path, known: set[str]) -> set[str]:
    """The known modules `path` imports anywhere in its body, relative imports resolved."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(up + ([base] if base else []))
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base
                       for a in node.names]
        else:
            continue
        for t in targets:
            while t and t not in known:            # `import qmesh.io.formats` names the module
                t = t.rpartition(".")[0]
            if t and t != name:
                out.add(t)
    return out


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def graph() -> dict[str, set[str]]:
    mods = modules()
    return {n: imports_of(n, p, set(mods)) for n, p in mods.items()}


def test_the_import_graph_is_read():
    g = graph()
    assert "qmesh.mesher.stages" in g["qmesh.mesher.loop"]
    assert "qmesh.conductivity.expression" in g["qmesh.conductivity.anisotropy"]
    assert "qmesh.compare.table" in g["qmesh.cli"]                # a function-level import


def test_a_planted_cycle_is_found():
    g = graph()
    g["qmesh.errors"] = g["qmesh.errors"] | {"qmesh.cli"}
    assert any("qmesh.errors" in c and "qmesh.cli" in c for c in cycles(g))


@pytest.mark.parametrize("package", sorted(PACKAGES))
def test_no_import_cycles(package):
    found = [c for c in cycles(graph()) if c[0].split(".")[0] == package]
    assert not found, f"import cycles: {found}"
