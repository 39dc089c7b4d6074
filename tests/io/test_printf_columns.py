"""The vectorised `%d` / `%.17g` of `qmesh.io.printf_columns` writes the same text as Python's
`%` operator, number by number (ties, powers of ten, zeros, non-finite values and subnormals
included), and the `.msh` writer built on it writes every node and element as that formatting
of the mesh's own numbers."""

import io

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial import Delaunay

import qmesh
from qmesh.io import printf_columns
from qmesh.io.payload import payload


def _texts(matrix: np.ndarray) -> list[str]:
    return [bytes(row[row != 0]).decode("ascii") for row in matrix]


_HARD = [0.0, -0.0, np.nan, np.inf, -np.inf, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308,
         1e-11, 1e-5, 1e-4, 9.999999999999999e-05, 0.1, 0.5, 1.0, 10.0, 1e15, 1e16, 1e17, 1e42, 1e43,
         99999.99999999999, 123456789012345678.0, 0.30000000000000004, 2.5, 1234567.5, -0.125]


@given(arrays(np.float64, st.integers(0, 300),
              elements=st.one_of(st.floats(), st.sampled_from(_HARD),
                                 st.integers(-2**53, 2**53).map(float),
                                 st.tuples(st.integers(-2**20, 2**20), st.integers(-60, 60))
                                 .map(lambda t: t[0] * 2.0 ** t[1]))))
@settings(max_examples=300, deadline=None)
def test_floats_are_printf_17g(x):
    assert _texts(printf_columns.float17_chars(x)) == ["%.17g" % v for v in x.tolist()]


def test_floats_of_every_magnitude_are_printf_17g():
    """Many numbers near every power of ten of the fast route and beyond, where the digit
    count or the exponent would change."""
    rng = np.random.default_rng(5)
    powers = 10.0 ** np.arange(-15, 46)
    x = np.concatenate([powers, np.nextafter(powers, 0), np.nextafter(powers, np.inf),
                        rng.uniform(-1, 1, 20_000) * 10.0 ** rng.integers(-15, 46, 20_000),
                        rng.uniform(-1, 1, 20_000)])
    assert _texts(printf_columns.float17_chars(x)) == ["%.17g" % v for v in x.tolist()]


def test_without_extended_long_double_python_formats_them(monkeypatch):
    """Where long double has no 64-bit mantissa every number takes Python's route: the same text."""
    monkeypatch.setattr(printf_columns, "_LONG", False)
    x = np.random.default_rng(2).uniform(-3, 3, 500)
    assert _texts(printf_columns.float17_chars(x)) == ["%.17g" % v for v in x.tolist()]


@given(arrays(np.int64, st.integers(0, 300), elements=st.integers(-2**63, 2**63 - 1)))
@settings(max_examples=200, deadline=None)
def test_integers_are_printf_d(a):
    assert _texts(printf_columns.int_chars(a)) == ["%d" % v for v in a.tolist()]


def test_unsigned_beyond_int64_are_printf_d():
    a = np.array([0, 7, 2**63, 2**64 - 1], dtype=np.uint64)
    f = io.BytesIO()
    printf_columns.write_rows(f, [a, b"\n"], len(a))
    assert f.getvalue().decode() == "".join("%d\n" % v for v in a.tolist())


def test_rows_join_parts_in_order_across_chunks(monkeypatch):
    monkeypatch.setattr(printf_columns, "CHUNK", 7)
    rng = np.random.default_rng(3)
    ids, x, flag = np.arange(1, 31), rng.standard_normal(30), rng.integers(0, 2, 30).astype(bool)
    f = io.BytesIO()
    printf_columns.write_rows(f, [ids, b" ", x, b" | ", flag, b"\n"], 30)
    assert f.getvalue().decode() == "".join("%d %.17g | %d\n" % t for t in zip(ids, x, flag))


def _section(text: str, name: str) -> list[str]:
    body = text.split(f"${name}\n", 1)[1].split(f"$End{name}\n", 1)[0]
    return body.splitlines()[1:]                    # after the count


@given(st.integers(0, 2**31), st.sampled_from([1e-9, 1e-3, 1.0, 3.0, 1e5]),
       st.floats(-1e6, 1e6))
@settings(max_examples=25, deadline=None)
def test_msh_nodes_and_elements_are_each_number_formatted(tmp_path_factory, seed, scale, shift):
    rng = np.random.default_rng(seed)
    corners = qmesh.Disk(12).seeds
    r, t = 0.9 * np.sqrt(rng.random(30)), 2 * np.pi * rng.random(30)
    P = np.vstack([corners, np.column_stack([r * np.cos(t), r * np.sin(t)])]) * scale + shift
    T = Delaunay(P - P.mean(axis=0)).simplices
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    T[cw] = T[cw][:, [0, 2, 1]]
    mesh = qmesh.Mesh(P, T, np.arange(len(P)) < len(corners))
    path = tmp_path_factory.mktemp("msh") / "m.msh"
    data = {"h": rng.standard_normal(len(P)) * scale}
    qmesh.io.write(path, mesh, point_data=data)
    text = path.read_text("ascii")
    assert _section(text, "Nodes") == ["%d %.17g %.17g 0" % (i + 1, x, y) for i, (x, y) in enumerate(P)]
    p = payload(mesh)
    k = len(p.edges)
    assert _section(text, "Elements") == (
        ["%d 1 2 %d %d %d %d" % (i + 1, t, t, a + 1, b + 1) for i, (t, (a, b)) in enumerate(zip(p.tags, p.edges))]
        + ["%d 2 2 %d %d %d %d %d" % (k + i + 1, r, r, *(tri + 1)) for i, (r, tri) in enumerate(zip(p.cell_tags, T))])
    h = text.split('"h"\n', 1)[1].split("$EndNodeData", 1)[0].splitlines()[6:]
    assert h == ["%d %.17g" % (i + 1, v) for i, v in enumerate(data["h"])]


@pytest.mark.parametrize("value", [0.0, -0.0, 1e-300, 1e300])
def test_one_column_alike_and_extreme(value):
    x = np.full(5, value)
    assert _texts(printf_columns.float17_chars(x)) == ["%.17g" % value] * 5
