"""TensorField's constructors, evaluation, box means and refusals: every refusal is a QmeshError
naming the component, the point or the cell."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.conductivity.anisotropy import principal_matrix
from tests.fields import reference as ref

P3 = np.array([[0.2, 0.3], [0.9, 0.1], [0.5, 0.8]])


def test_public_and_labelled():
    assert "TensorField" in qmesh.__all__ and qmesh.TensorField.__module__ == "qmesh.conductivity.field"
    assert qmesh.TensorField.from_expressions("1 + x*x", 0, 2).label == "Q = [[1 + x*x, 0], [0, 2]]"
    f = qmesh.TensorField.from_raster(np.linspace(0, 1, 4), np.linspace(0, 2, 3), 1.0, 1.0)
    assert f.label == "raster 2 × 3" and f.is_raster
    assert np.array_equal(f.bounds[0], [0, 0]) and np.array_equal(f.bounds[1], [1, 2])
    g = qmesh.TensorField(lambda x, y: np.broadcast_to(np.eye(2), np.shape(x) + (2, 2)), "unit")
    assert g.label == "unit" and not g.is_raster and g.bounds is None


def test_principal_follows_principal_matrix():
    """k1 along the angle, as Anisotropy.principal: numbers, texts and a raster agree."""
    Q = principal_matrix(3.0, 0.5, 30.0)
    for f in (qmesh.TensorField.principal(3, 0.5, 30), qmesh.TensorField.principal("3", "0.5 + 0*x", "15 + 15"),
              qmesh.TensorField.from_raster([0, 1], [0, 1], [[3.0]], [[0.5]], [[30.0]])):
        assert np.allclose(f(P3), Q, rtol=0, atol=1e-14)
    f = qmesh.TensorField.principal("1 + x", 0.1, "90 * y")
    assert np.allclose(f(P3), [principal_matrix(1 + p[0], 0.1, 90 * p[1]) for p in P3], atol=1e-14)


def test_callable_shapes_and_symmetrisation():
    """f(x, y) gets arrays of one shape; a round-off asymmetry is averaged away."""
    seen = []

    def f(x, y):
        seen.append(np.shape(x))
        Q = np.zeros(np.shape(x) + (2, 2))
        Q[..., 0, 0], Q[..., 1, 1] = 2 + x, 1 + y * y
        Q[..., 0, 1], Q[..., 1, 0] = 0.1 * x, 0.1 * x * (1 + 1e-14)
        return Q
    Q = qmesh.TensorField(f)(P3)
    assert seen == [(3,)] and np.array_equal(Q[:, 0, 1], Q[:, 1, 0])


def test_raster_lookup():
    """Q at a point is its cell's; on a cell line, either cell; at the far edges, the last cell."""
    x, y = np.array([0.0, 1.0, 3.0]), np.array([-1.0, 0.0, 2.0])
    k1 = np.array([[1.0, 2.0], [3.0, 4.0]])
    f = qmesh.TensorField.from_raster(x, y, k1, 0.5)
    q = f([[0.5, -0.5], [2.0, -0.5], [0.5, 1.0], [2.0, 1.0], [3.0, 2.0], [0.0, -1.0]])[:, 0, 0]
    assert q.tolist() == [1.0, 2.0, 3.0, 4.0, 4.0, 1.0]
    assert f([[1.0, 1.0]])[0, 0, 0] in (3.0, 4.0)


# --------------------------------------------------------------------------- box means

def test_box_means_of_constants_and_linear_formulas():
    f = qmesh.TensorField.principal(2.0, 0.02, 45)
    assert np.array_equal(f.box_means(P3, 0.3), np.broadcast_to(principal_matrix(2.0, 0.02, 45), (3, 2, 2)))
    r = qmesh.TensorField.from_raster(np.linspace(-1, 2, 9), np.linspace(-1, 2, 5), 2.0, 0.02, 45.0)
    assert np.allclose(r.box_means(P3, [0.1, 0.5, 2.0]), principal_matrix(2.0, 0.02, 45), rtol=0, atol=1e-14)
    lin = qmesh.TensorField.from_expressions("3 + x - y", "0.2*x*y", "2 + y*y")   # Gauss is exact here
    h = np.array([0.1, 0.2, 0.05])
    exact = np.array([[[3 + p[0] - p[1], 0.2 * p[0] * p[1]], [0.2 * p[0] * p[1], 2 + p[1] ** 2 + hh * hh / 3]]
                      for p, hh in zip(P3, h)])
    assert np.allclose(lin.box_means(P3, h), exact, rtol=0, atol=1e-14)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2 ** 32 - 1))
def test_raster_box_means_equal_area_weighted_mean(seed):
    """The summed-area table = the cells' overlaps with the square, clipped to the raster, one
    cell at a time."""
    rng = np.random.default_rng(seed)
    nx, ny = rng.integers(1, 7, 2)
    x = rng.uniform(-50, 50) + np.r_[0, np.cumsum(rng.uniform(0.1, 1, nx))]
    y = rng.uniform(-50, 50) + np.r_[0, np.cumsum(rng.uniform(0.1, 1, ny))]
    k1 = np.exp(rng.normal(0, 2, (ny, nx)))
    k2, angle = k1 * rng.uniform(0.01, 1, (ny, nx)), rng.uniform(0, 180, (ny, nx))
    f = qmesh.TensorField.from_raster(x, y, k1, k2, angle)
    Q = ref.cell_tensors(k1, k2, angle)
    P = np.column_stack([rng.uniform(x[0] - 0.5, x[-1] + 0.5, 5), rng.uniform(y[0] - 0.5, y[-1] + 0.5, 5)])
    P[0] = x[rng.integers(len(x))], y[rng.integers(len(y))]          # a grid node
    h = rng.uniform(0.51, 3, 5)
    got = f.box_means(P, h)
    for p, hh, g in zip(P, h, got):
        assert np.allclose(g, ref.raster_box_mean(x, y, Q, p, hh), rtol=1e-11, atol=1e-11 * np.abs(Q).max())


# --------------------------------------------------------------------------- refusals

HOSTILE = ["__import__('os')", "__import__('os').system('true')", "x.__class__", "().__class__",
           "lambda: 1", "open('/etc/passwd')", "9**9**9**9", "x if x else y", "[x]", "eval('1')",
           "exp(x, y)", "x; y", "'1'", "x\ny", "é"]


@pytest.mark.parametrize("text", HOSTILE)
def test_hostile_texts_are_refused_naming_the_component(text):
    with pytest.raises(qmesh.QmeshError, match=r"^q12\(x, y\)"):
        qmesh.TensorField.from_expressions(1, text, 1)
    with pytest.raises(qmesh.QmeshError, match=r"^angle\(x, y\)"):
        qmesh.TensorField.principal(1, 1, text)


def test_a_column_is_named():
    with pytest.raises(qmesh.QmeshError, match=r"q22\(x, y\): column 5: 'open'"):
        qmesh.TensorField.from_expressions(1, 0, "1 + open(x)")


@pytest.mark.parametrize("args, message", [
    ((1, 2, 1), r"not positive definite: Q = \[\[1, 2\], \[2, 1\]\], det Q = -3"),
    ((-1, 0, 1), r"q11 = -1: a diagonal entry"),
    ((1, 0, "0 - 2"), r"q22 = -2"),
    ((1, float("nan"), 1), r"q12 must be finite"),
    ((1, True, 1), r"q12 must be a number or a text"),
    ((1, [0, 1], 1), r"q12 must be a number or a text"),
    ((1, 0, ""), r"q22\(x, y\) is empty"),
])
def test_constants_are_checked_at_once(args, message):
    with pytest.raises(qmesh.QmeshError, match=message):
        qmesh.TensorField.from_expressions(*args)


@pytest.mark.parametrize("args, message", [
    ((0, 1, 0), r"k1 = 0: principal conductivities must be > 0"),
    ((1, -2, 0), r"k2 = -2"),
    ((1, 1, float("inf")), r"angle must be finite"),
])
def test_principal_constants_are_checked_at_once(args, message):
    with pytest.raises(qmesh.QmeshError, match=message):
        qmesh.TensorField.principal(*args)


def test_formulas_are_checked_where_evaluated_naming_the_point():
    f = qmesh.TensorField.from_expressions("x", 0, 1)       # q11 = x: not SPD for x ≤ 0
    assert f(P3).shape == (3, 2, 2)
    with pytest.raises(qmesh.QmeshError, match=r"not positive definite at \(x, y\) = \(-0.5, 0.25\)"):
        f([[0.5, 0.5], [-0.5, 0.25], [-1, 0]])
    with pytest.raises(qmesh.QmeshError, match=r"not positive definite at \(x, y\) = \(-"):
        f.means([[-0.1, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    with pytest.raises(qmesh.QmeshError, match=r"q11\(x, y\) = 'log\(x\)' is nan at \(x, y\) = \(-1.0, 0.0\)"):
        qmesh.TensorField.from_expressions("log(x)", 0, 1)([[1, 0], [-1, 0]])
    with pytest.raises(qmesh.QmeshError, match=r"k2\(x, y\) = 'y' is -1.0 at \(x, y\) = \(0.0, -1.0\): principal"):
        qmesh.TensorField.principal(1, "y", 0)([[0, 1], [0, -1]])
    with pytest.raises(qmesh.QmeshError, match=r"not positive definite at \(x, y\) = \(-0.5, 0.0\)"):
        qmesh.TensorField.from_expressions(1, 0, "0.5 + x")([[1, 0], [-0.5, 0]])
    with pytest.raises(qmesh.QmeshError, match=r"not positive definite at \(x, y\) = \(1.9"):
        qmesh.TensorField.from_expressions(1, "x", 1).box_means([[2.0, 0.0]], 0.1)   # at a Gauss point


def test_callables_are_checked_naming_the_point():
    def asym(x, y):
        Q = np.broadcast_to(np.eye(2), np.shape(x) + (2, 2)).copy()
        Q[..., 0, 1] = np.where(x > 0.5, 0.3, 0.0)
        return Q
    with pytest.raises(qmesh.QmeshError, match=r"Q = asym\(x, y\): Q is not symmetric at \(x, y\) = \(0.9, 0.1\)"):
        qmesh.TensorField(asym)(P3)
    with pytest.raises(qmesh.QmeshError, match=r"not finite at \(x, y\) = \(0.0, 0.0\)"):
        qmesh.TensorField(lambda x, y: np.eye(2) / np.hypot(x, y)[..., None, None])([[1, 0], [0, 0]])
    with pytest.raises(qmesh.QmeshError, match=r"must return shape \(n, 2, 2\)"):
        qmesh.TensorField(lambda x, y: np.ones(np.shape(x) + (3,)))(P3)
    with pytest.raises(qmesh.QmeshError, match=r"raised ZeroDivisionError"):
        qmesh.TensorField(lambda x, y: 1 / 0)(P3)
    with pytest.raises(qmesh.QmeshError, match="callable"):
        qmesh.TensorField("x")


@pytest.mark.parametrize("cell, message", [
    ((1, 2), r"k1 is nan in cell \(row 1, column 2\) \(x in \[2, 3\], y in \[1, 2\]\)"),
])
def test_nan_cells_are_refused(cell, message):
    k1 = np.ones((3, 4))
    k1[cell] = np.nan
    with pytest.raises(qmesh.QmeshError, match=message + r".*NaN cells are not holes"):
        qmesh.TensorField.from_raster(np.arange(5.0), np.arange(4.0), k1, 1.0)


def test_raster_refusals():
    x, y = np.arange(5.0), np.arange(4.0)
    k = np.ones((3, 4))
    bad = k.copy()
    bad[2, 0] = -1
    with pytest.raises(qmesh.QmeshError, match=r"k2 is -1.0 in cell \(row 2, column 0\)"):
        qmesh.TensorField.from_raster(x, y, k, bad)
    bad[2, 0] = np.inf
    with pytest.raises(qmesh.QmeshError, match=r"angle is inf in cell \(row 2, column 0\)"):
        qmesh.TensorField.from_raster(x, y, k, k, bad)
    with pytest.raises(qmesh.QmeshError, match=r"k1 must be .* shape \(3, 4\)"):
        qmesh.TensorField.from_raster(x, y, np.ones((4, 3)), k)
    with pytest.raises(qmesh.QmeshError, match=r"x must be at least two increasing"):
        qmesh.TensorField.from_raster([0, 2, 1, 3, 4], y, k, k)
    f = qmesh.TensorField.from_raster(x, y, k, k)
    with pytest.raises(qmesh.QmeshError, match=r"point \(x, y\) = \(4.5, 1.0\) is outside the raster 3 × 4 \[0, 4\] × \[0, 3\]"):
        f([[1, 1], [4.5, 1.0]])
    with pytest.raises(qmesh.QmeshError, match=r"does not meet the raster"):
        f.box_means([[6.0, 1.0]], 1.0)
    with pytest.raises(qmesh.QmeshError, match=r"zero area"):
        f.means([[0, 0], [1, 1], [2, 2]], [[0, 1, 2]])


KS = np.ones((3, 4))


@pytest.mark.parametrize("name, value, kind", [
    ("k1", KS.astype("datetime64[s]"), "a datetime64 array"),
    ("k1", KS > 0, "a boolean array"),
    ("k2", KS.astype(str), "a string array"),
    ("k2", KS.astype(bytes), "a bytes array"),
    ("angle", KS + 1j, "a complex array"),
    ("angle", np.zeros((3, 4), dtype=[("k", float)]), r"a structured array \(dtype \[\('k'"),
    ("x", np.arange(5.0) + 0j, "a complex array"),
    ("k1", [[10**400] * 4] * 3, "holds an integer beyond any float"),
])
def test_raster_arrays_a_cast_would_change_are_refused_by_name(name, value, kind):
    """A cast to float would drop the imaginary part, turn dates into seconds and booleans into
    0 and 1: refused, naming the array and what it holds (a structured array: not its shape)."""
    args = {"x": np.arange(5.0), "y": np.arange(4.0), "k1": KS, "k2": KS, "angle": 0.0, name: value}
    with pytest.raises(qmesh.QmeshError, match=rf"{name} .*{kind}"):
        qmesh.TensorField.from_raster(**args)


def test_a_callables_imaginary_part_is_refused_not_dropped():
    def f(x, y, imag):
        return np.broadcast_to(np.eye(2) * (1 + imag * (x > 0.5))[..., None, None], np.shape(x) + (2, 2))
    assert qmesh.TensorField(lambda x, y: f(x, y, 0j))(P3).dtype == float       # exactly real: kept
    with pytest.raises(qmesh.QmeshError, match=r"imaginary part at \(x, y\) = \(0.9, 0.1\)"):
        qmesh.TensorField(lambda x, y: f(x, y, 1j))(P3)


@pytest.mark.parametrize("make, name", [
    (lambda: qmesh.TensorField.from_expressions(10**400, 0, 1), "q11"),
    (lambda: qmesh.TensorField.principal(1, 1, -10**400), "angle"),
    (lambda: qmesh.Polygon([(0, 0), (1, 0), (0, 1)], tags=2**63), "tags of the outline"),
])
def test_integers_beyond_any_float_or_tag_are_refused_naming_the_argument(make, name):
    with pytest.raises(qmesh.QmeshError, match=name):
        make()


@pytest.mark.parametrize("points, triangles, message", [
    (np.zeros((3, 3)), [[0, 1, 2]], r"points must have shape \(n, 2\)"),
    ([[0, 0], [1, 0], [0, np.nan]], [[0, 1, 2]], r"points has non-finite entries at row 2"),
    ([[0, 0], [1, 0], [0, 1]], [[0, 1, 3]], r"triangles index points 0..2"),
    ([[0, 0], [1, 0], [0, 1]], [[0.0, 1.0, 2.0]], r"triangles must be integer indices"),
    ([[0, 0], [1, 0], [0, 1]], [0, 1, 2], r"triangles must be integer indices of shape \(M, 3\)"),
])
def test_bad_shapes_are_refused(points, triangles, message):
    for f in (qmesh.TensorField.principal(1, 2, 3), qmesh.TensorField.from_expressions("1 + x*x", 0, 1)):
        with pytest.raises(qmesh.QmeshError, match=message):
            f.means(points, triangles)


def test_box_means_refusals():
    f = qmesh.TensorField.principal(1, 2, 3)
    with pytest.raises(qmesh.QmeshError, match=r"half_width must be finite and > 0, got 0.0 at point 1"):
        f.box_means(P3, [0.1, 0.0, 0.1])
    with pytest.raises(qmesh.QmeshError, match=r"half_width must be a number or an array of shape \(3,\)"):
        f.box_means(P3, [0.1, 0.2])


@pytest.mark.parametrize("shift", [1e-6, 0.3])
def test_a_domain_reaching_outside_a_raster_is_refused_naming_both_rectangles(shift):
    F = qmesh.TensorField.from_raster([0.0, 0.5, 1.0], [0.0, 1.0], [[1.0, 2.0]], [[1.0, 1.0]])
    square = [(0.0, 0.0), (1.0 + shift, 0.0), (1.0 + shift, 1.0), (0.0, 1.0)]
    for call in (qmesh.mesh, qmesh.iterate):
        with pytest.raises(qmesh.QmeshError, match=r"\[0, 1\] × \[0, 1\], where Q is not known"):
            call(qmesh.Polygon(square), F, target_vertices=100)
    inside = qmesh.mesh(qmesh.Polygon([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]), F,
                        target_vertices=100)
    assert inside.points.max() <= 1.0 and inside.conductivity is not None


@settings(max_examples=60, deadline=None)
@given(x0=st.floats(-1e3, 1e3), y0=st.floats(-1e3, 1e3), w=st.floats(1e-3, 1e3),
       h=st.floats(1e-3, 1e3), u=st.tuples(*[st.floats(-0.5, 1.5)] * 4))
def test_check_covers_refuses_exactly_the_boxes_reaching_outside_the_cells(x0, y0, w, h, u):
    F = qmesh.TensorField.from_raster([x0, x0 + w], [y0, y0 + h], [[1.0]], [[2.0]])
    lo = np.array([x0 + min(u[0], u[1]) * w, y0 + min(u[2], u[3]) * h])
    hi = np.array([x0 + max(u[0], u[1]) * w, y0 + max(u[2], u[3]) * h])
    inside = min(u) >= 0.0 and max(u) <= 1.0
    assume(inside or min(u) < -1e-6 or max(u) > 1 + 1e-6)   # round-off of the edges is allowed
    if inside:
        F.check_covers((lo, hi))
    else:
        with pytest.raises(qmesh.QmeshError, match="reaches outside the cells"):
            F.check_covers((lo, hi))
    qmesh.TensorField.from_expressions("1", "0", "1").check_covers((lo, hi))   # no cells: any box
