"""A raster's tables and edge integrals are computed a band or a run at a time, bit for bit what
the formulas give over the whole raster at once, so a raster of a million cells meshes in the
memory of one band."""

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from qmesh.conductivity import means as _m


def whole_tables(x, y, q):
    """The tables of `means.Raster`'s docstring, each one cumulative sum over the whole raster."""
    x, y = x - x[0], y - y[0]
    w, h = np.diff(x), np.diff(y)
    ny, nx = q.shape[:2]
    row = np.zeros((ny, nx + 1, 3))
    row[:, 1:] = np.cumsum(q * w[None, :, None], axis=1)
    col = np.zeros((ny + 1, nx, 3))
    col[1:] = np.cumsum(q * h[:, None, None], axis=0)
    sat = np.zeros((ny + 1, nx + 1, 3))
    sat[1:, 1:] = np.cumsum(row[:, 1:] * h[:, None, None], axis=0)
    row_abs = _m.frobenius(np.sum(np.abs(q) * w[None, :, None], axis=1))
    return {"row": row, "col": col, "sat": sat, "row_abs": row_abs}


def cells(seed, ny, nx):
    rng = np.random.default_rng(seed)
    x = 1e3 + np.cumsum(0.1 + rng.random(nx + 1))
    y = -5 + np.cumsum(0.1 + rng.random(ny + 1))
    k1 = np.exp(3 * rng.normal(size=(ny, nx)))
    k2 = k1 * (0.01 + rng.random((ny, nx)))
    angle = 360 * rng.random((ny, nx)) - 180
    t = np.deg2rad(angle)
    c, s = np.cos(t), np.sin(t)
    q = np.stack([k1 * c * c + k2 * s * s, (k1 - k2) * c * s, k1 * s * s + k2 * c * c], axis=-1)
    return x, y, k1, k2, angle, q


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), ny=st.integers(1, 40), nx=st.integers(1, 40),
       rows=st.integers(1, 41))
def test_tables_built_in_bands_equal_the_whole_formula(seed, ny, nx, rows):
    x, y, k1, k2, angle, q = cells(seed, ny, nx)
    expected = whole_tables(x, y, q)
    for R in (_m.Raster.build(x, y, q, rows=rows),
              _m.Raster.from_principal(x, y, k1, k2, angle, rows=rows)):
        assert np.array_equal(R.q, q)
        for name, table in expected.items():
            assert np.array_equal(getattr(R, name), table), name


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), ny=st.integers(1, 30), nx=st.integers(1, 30),
       pieces=st.integers(1, 400))
def test_edge_integrals_in_runs_equal_all_at_once(seed, ny, nx, pieces):
    x, y, _, _, _, q = cells(seed, ny, nx)
    R = _m.Raster.build(x, y, q)
    rng = np.random.default_rng(seed)
    lo, hi = np.array([x[0], y[0]]), np.array([x[-1], y[-1]])
    P0, P1 = (lo + (hi - lo) * rng.random((60, 2)) for _ in range(2))
    P1[:5, 1] = P0[:5, 1]                                   # horizontal: no integral
    P1[5:10] = P0[5:10]                                     # and empty
    once = _m.raster_edge_integrals(R, P0, P1, pieces=10**12)
    runs = _m.raster_edge_integrals(R, P0, P1, pieces=pieces)
    assert np.array_equal(once[0], runs[0]) and np.array_equal(once[1], runs[1])
    assert np.all(once[0][:10] == 0)


CHILD = r"""
import sys
import numpy as np
import qmesh

def hwm():
    return int([l for l in open("/proc/self/status") if l.startswith("VmHWM")][0].split()[1]) * 1024

start = hwm()
n = int(sys.argv[1])
rng = np.random.default_rng(1)
field = qmesh.TensorField.from_raster(np.linspace(0, 1, n + 1), [0.0, 1.0], 1 + rng.random((1, n)),
                                      1.0, 30.0)
m = qmesh.mesh(qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]), field, target_vertices=500)
print("vertices", m.n_vertices, "start", start, "peak", hwm())
"""


@pytest.mark.timeout(120)
def test_a_raster_of_200_000_cells_in_a_row_meshes_in_bounded_memory():
    """1 × 200 000 cells at 500 vertices: each of the ~1 500 edges crosses ~7 000 cells, ~1e7
    pieces in all (2.2 GB at once before). Now the tables (96 bytes a cell: 19 MB), the raster's
    inputs (5 MB) and a run of EDGE_PIECES pieces (~40 arrays of 8 bytes each: ~20 MB) on top of
    the interpreter and its imports, within 200 MB."""
    out = subprocess.run([sys.executable, "-c", CHILD, "200000"], capture_output=True, text=True,
                         timeout=110)
    words = out.stdout.split()
    assert "vertices" in words, out.stderr
    assert int(words[words.index("vertices") + 1]) >= 450
    start, peak = int(words[words.index("start") + 1]), int(words[words.index("peak") + 1])
    assert peak - start < 200 * 2**20, (start, peak)
