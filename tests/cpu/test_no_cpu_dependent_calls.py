"""Where the mesher decides, no NumPy call whose last bits depend on the CPU: the matrix product
operator `@` (which the one-ulp harness cannot wrap), numpy.linalg, numpy.polynomial, and the
ufuncs NumPy sends to per-CPU kernels. `qmesh.geometry.portable` has their CPU-independent
versions; a line that only measures (a number in a message) says so with `# measures only`."""

import ast
from pathlib import Path

import pytest

from tests.cpu.meshes import DISPATCHED

QMESH = Path(__file__).parent.parent.parent / "qmesh"
DECIDING = ["mesher", "fields", "media", "domain", "geometry", "conductivity", "checks.py", "meshing.py"]
EXACT_POWERS = {0, 0.5, 1, 2, -1}          # NumPy computes these by square, sqrt, reciprocal


def _files():
    for part in DECIDING:
        path = QMESH / part
        yield from ([path] if path.is_file() else sorted(p for p in path.rglob("*.py") if p.name != "portable.py"))


def _offences(path: Path) -> list[str]:
    lines = path.read_text().splitlines()
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        what = None
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.MatMult):
            what = "@"
        elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "np" \
                and (node.attr in DISPATCHED or node.attr in ("linalg", "polynomial")):
            what = f"np.{node.attr}"
        elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow) \
                and isinstance(node.right, ast.Constant) and node.right.value not in EXACT_POWERS \
                and not isinstance(node.left, ast.Constant):
            what = f"** {node.right.value}"
        if what and "# measures only" not in lines[node.lineno - 1]:
            found.append(f"{path.name}:{node.lineno}: {what}")
    return found


@pytest.mark.parametrize("path", list(_files()), ids=lambda p: str(p.relative_to(QMESH)))
def test_no_cpu_dependent_call_where_the_mesher_decides(path):
    assert _offences(path) == []


def test_the_check_finds_what_it_looks_for(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import numpy as np\nx = a @ b\ny = np.exp(z)\nw = np.linalg.inv(m)\nv = u ** 3\n"
                   "ok = u ** 2 + 2 ** k\nmsg = np.arccos(c)   # measures only\n")
    assert sorted(o.split(": ")[1] for o in _offences(bad)) == ["** 3", "@", "np.exp", "np.linalg"]
