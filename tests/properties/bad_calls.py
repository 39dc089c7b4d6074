"""Invalid calls of every public entry point: each must raise QmeshError whose
message names the argument.

`CALLS` is the whole list, built from per-argument kinds of bad value (a count, a positive real,
a matrix…) so every argument gets every value that is wrong for it and none that is valid. It is
small enough to run completely (`test_bad_arguments.py`, `benchmarks/stress.py`).
"""

from __future__ import annotations

import atexit
import math
import re
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

import qmesh
from qmesh import io, measure

NAN, INF = math.nan, math.inf
NOT_A_NUMBER = ["1", b"1", None, True, [1], 1 + 1j, {}]
COUNT = [NAN, INF, -INF, 10**400, -1, 2.5] + NOT_A_NUMBER
HUGE_COUNT = [10**30]
POSITIVE = [NAN, INF, -INF, 0, -1.0, 10**400] + NOT_A_NUMBER
REAL = [NAN, INF, -INF, 10**400] + NOT_A_NUMBER
UNIT = [NAN, INF, 0, 1.5, -0.5] + NOT_A_NUMBER
FRACTION = [NAN, INF, 1, 1.5, -0.5] + NOT_A_NUMBER
BOOL = [None, "yes", 1, 0, NAN, [True]]
POINTS = [None, "abc", 1.0, [[0, 0], [1, 0], [NAN, 1]], [[0, 0], [1, 0], [INF, 1]], [[0, 0], [1, 0]],
          [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0], [1, 0], ["a", 1]], [[0, 0], [1, 0], [1j, 1]],
          np.zeros((3, 2)), [[0, 0], [1, 0], [1, 0], [0, 1]]]
PAIR = [None, "ab", (NAN, 0), (INF, 0), (1, 2, 3), (1j, 0), True, 1.0]
MATRIX = [None, "I", [[NAN, 0], [0, 1]], np.eye(3), [[1, 0], [0, -1]], [[True, False], [False, True]],
          [[1j, 0], [0, 1]], [[1, 0], [0, 10**400]], [[1, 2], [0, 1]], 1.0]
MESHES = [None, "mesh.vtu", np.zeros((3, 2)), (np.zeros((3, 2)), [[0, 1, 2]]), 1.0]
ANISOTROPIES = [None, np.eye(2), "Q", 1.0, [[1, 0], [0, 1]]]
ANISOTROPIES_OR_NONE = ANISOTROPIES[1:]
FUNCTIONS = [None, 1.0, "s", np.eye(2)]
TEXTS = [None, 1, b"x"]
METHODS = ["eig", None, 1, "DENSE"]
PATHS = [None, 1.0, NAN, True, [1], 1j, b"\x00", "mesh.stl", "no_extension"]
INDICES = [None, "abc", [[0, 1]], [[0, 1, 5]], [[0, 1, -1]], [[0.5, 1, 2]]]


@dataclass(frozen=True)
class BadCall:
    """One invalid call: `what` to show, `call` to run, `names` one of which the message must hold."""

    what: str
    call: Callable
    names: tuple

    def __repr__(self):
        return self.what


_FOLDER = Path(tempfile.mkdtemp(prefix="qbad"))    # no "mesh" in it: messages must name the argument
atexit.register(shutil.rmtree, _FOLDER, ignore_errors=True)
OUT = str(_FOLDER / "out.vtu")


def _mesh():
    P = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.3, 0.3]])
    return qmesh.Mesh(P, [[0, 1, 3], [1, 2, 3], [2, 0, 3]], fixed=[True, True, True, False])


def _calls() -> list[BadCall]:
    D = lambda: qmesh.Disk(8)                        # noqa: E731
    A = lambda: qmesh.Anisotropy.constant(np.eye(2))  # noqa: E731
    f = lambda P: P                                   # noqa: E731
    out = []

    def add(entry: str, arg: str, values, call, names=None):
        for v in values:
            out.append(BadCall(f"{entry}({arg}={v!r:.40})", (lambda v=v: call(v)), tuple(names or (arg,))))

    mesh_options = {"target_vertices": COUNT + HUGE_COUNT, "size": POSITIVE, "alpha": UNIT,
                    "quality_threshold": FRACTION, "min_area": [NAN, INF, -1.0, 10**400] + NOT_A_NUMBER[:-1],
                    "max_iterations": COUNT + HUGE_COUNT, "seed": COUNT, "boundary_refinement": BOOL}
    for opt, values in mesh_options.items():
        values = [v for v in values if not (opt in ("size", "min_area") and v is None)]
        values = [v for v in values if not (opt in ("target_vertices", "seed") and v is None)]
        values = [v for v in values if not (opt == "seed" and v == 10**400)]   # NumPy takes any int
        add("mesh", opt, values, lambda v, opt=opt: qmesh.mesh(D(), A(), **{opt: v}))
        add("iterate", opt, values, lambda v, opt=opt: qmesh.iterate(D(), A(), **{opt: v}))
    add("mesh", "domain", [None, "disk", np.zeros((8, 2)), 1.0], lambda v: qmesh.mesh(v, A()), ["domain"])
    add("mesh", "anisotropy", ANISOTROPIES, lambda v: qmesh.mesh(D(), v), ["anisotropy"])
    add("iterate", "domain", [None, "disk"], lambda v: qmesh.iterate(v, A()), ["domain"])
    add("iterate", "anisotropy", ANISOTROPIES, lambda v: qmesh.iterate(D(), v), ["anisotropy"])
    add("mesh", "<unknown keyword>", ["target"], lambda v: qmesh.mesh(D(), A(), **{v: 10}), ["target"])
    add("iterate", "<unknown keyword>", ["target"], lambda v: qmesh.iterate(D(), A(), **{v: 10}), ["target"])

    add("Disk", "vb", COUNT + [2, 10**30], lambda v: qmesh.Disk(v), ["vb"])
    add("Disk", "radius", POSITIVE, lambda v: qmesh.Disk(8, radius=v))
    add("Disk", "center", PAIR, lambda v: qmesh.Disk(8, center=v))
    add("Polygon", "points", POINTS, lambda v: qmesh.Polygon(v), ["points", "polygon", "outline"])
    if hasattr(qmesh, "Domain"):
        square = [[0, 0], [1, 0], [1, 1], [0, 1]]
        add("Domain", "outer", POINTS, lambda v: qmesh.Domain(v), ["outer", "outline"])
        add("Domain", "holes", [None, "abc", 1.0, [[[0.4, 0.4], [0.6, 0.4], [NAN, 0.6]]]],
            lambda v: qmesh.Domain(square, v), ["holes", "hole"])

    add("Anisotropy.constant", "Q", MATRIX, lambda v: qmesh.Anisotropy.constant(v))
    add("Anisotropy.principal", "k1", POSITIVE, lambda v: qmesh.Anisotropy.principal(v, 1.0))
    add("Anisotropy.principal", "k2", POSITIVE, lambda v: qmesh.Anisotropy.principal(1.0, v))
    add("Anisotropy.principal", "angle_deg", REAL, lambda v: qmesh.Anisotropy.principal(1.0, 2.0, v))
    for i, name in enumerate(("s", "grad", "hessian")):
        add("Anisotropy.from_s", name, FUNCTIONS,
            lambda v, i=i: qmesh.Anisotropy.from_s(*[v if j == i else f for j in range(3)]))
    add("Anisotropy.from_s", "label", TEXTS, lambda v: qmesh.Anisotropy.from_s(f, f, f, label=v))
    add("Anisotropy.check_convex", "points", POINTS[:3] + POINTS[3:5],
        lambda v: A().check_convex(v), ["points"])

    add("Mesh", "points", POINTS[:5], lambda v: qmesh.Mesh(v, [[0, 1, 2]]), ["points"])
    add("Mesh", "triangles", INDICES, lambda v: qmesh.Mesh(np.eye(3)[:, :2], v), ["triangles"])
    add("Mesh", "fixed", ["abc", [True, False], [[True, False, True]]],
        lambda v: qmesh.Mesh(np.eye(3)[:, :2], [[0, 1, 2]], fixed=v), ["fixed"])

    for fn in (measure.energy, measure.quality, measure.stiffness, measure.stiffness_interior,
               measure.edge_weights, measure.q_nonnegative_fraction,
               measure.q_nonnegative_fraction_boundary, measure.condition_number,
               measure.interpolation_errors, measure.report, measure.sh_convex_fraction):
        add(f"measure.{fn.__name__}", "mesh", MESHES, lambda v, fn=fn: fn(v, A()))
        allowed_none = fn in (measure.stiffness, measure.stiffness_interior, measure.edge_weights,
                              measure.q_nonnegative_fraction, measure.q_nonnegative_fraction_boundary,
                              measure.condition_number)
        add(f"measure.{fn.__name__}", "anisotropy", ANISOTROPIES_OR_NONE if allowed_none else ANISOTROPIES,
            lambda v, fn=fn: fn(_mesh(), v))
    add("measure.condition_number", "method", METHODS, lambda v: measure.condition_number(_mesh(), method=v))
    add("measure.condition_number", "tol", FRACTION, lambda v: measure.condition_number(_mesh(), tol=v))
    add("measure.q_nonnegative_fraction", "rtol", [NAN, INF, -1.0, 2.0] + NOT_A_NUMBER,
        lambda v: measure.q_nonnegative_fraction(_mesh(), None, rtol=v))

    add("io.write", "path", PATHS, lambda v: io.write(v, _mesh()), ["path", "extension", "file"])
    add("io.write", "mesh", MESHES, lambda v: io.write(OUT, v), ["mesh"])
    add("io.write", "anisotropy", ANISOTROPIES[1:], lambda v: io.write(OUT, _mesh(), anisotropy=v),
        ["anisotropy"])
    add("io.write", "point_data", ["abc", 1.0, {"u": [1, 2]}, {"u": "abc"}],
        lambda v: io.write(OUT, _mesh(), point_data=v), ["point_data", "point data"])
    add("io.read", "path", PATHS, lambda v: io.read(v), ["path", "extension", "file"])
    return out


CALLS = _calls()


def outcome(bad: BadCall) -> str | None:
    """None when the call raises a QmeshError naming its argument, else what went wrong."""
    try:
        result = bad.call()
    except qmesh.QmeshError as e:
        if not isinstance(e, TypeError) or not isinstance(e, ValueError):
            return "QmeshError is not both a TypeError and a ValueError"
        text = str(e).lower()
        if not any(re.search(rf"\b{re.escape(n.lower())}\b", text) for n in bad.names):
            return f"QmeshError does not name {' or '.join(bad.names)}: {e}"
        return None
    except Exception as e:          # noqa: BLE001 - the defect recorded
        return f"{type(e).__name__} instead of QmeshError: {str(e)[:120]}"
    if hasattr(result, "__next__"):
        return "no error at the call (a generator that checks nothing until the first next())"
    return f"no error (returned {type(result).__name__})"
