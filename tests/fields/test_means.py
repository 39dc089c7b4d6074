"""Element means Q̄_T = (1/|T|) ∫_T Q (FIELDS.md §2): exact for constant and linear formula
fields, within the returned bound of a fine reference for smooth ones, and for rasters equal to
the exact clipping of every cell."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.conductivity.anisotropy import principal_matrix
from tests.fields import reference as ref

def _triangle(rng, centre, scale):
    """A random triangle near `centre` of size ~ scale, not flatter than area 1e-3 scale²."""
    while True:
        T = rng.uniform(-1, 1, (3, 2))
        a = (T[1, 0] - T[0, 0]) * (T[2, 1] - T[0, 1]) - (T[1, 1] - T[0, 1]) * (T[2, 0] - T[0, 0])
        if abs(a) > 1e-3:
            return centre + scale * T


def _spd(rng, cond=1e3):
    k1 = 10 ** rng.uniform(-3, 3)
    return principal_matrix(k1, k1 / 10 ** rng.uniform(0, np.log10(cond)), rng.uniform(0, 180))


seeds = st.integers(0, 2 ** 32 - 1)


def linear_field(Q0, Gx, Gy, c, L):
    """Q(x, y) = Q0 + Gx (x − cx)/L + Gy (y − cy)/L, vectorised."""
    def f(x, y):
        x, y = np.asarray(x, float), np.asarray(y, float)
        return (Q0 + Gx * ((x - c[0]) / L)[..., None, None] + Gy * ((y - c[1]) / L)[..., None, None])
    return f


@settings(max_examples=40, deadline=None)
@given(seeds, st.floats(-1e4, 1e4), st.floats(-1e4, 1e4), st.floats(-4, 3))
def test_means_exact_for_constant_and_linear_fields(seed, cx, cy, log_scale):
    """Degree-5 quadrature: any linear Q has the mean Q(centroid), at any position and scale."""
    rng = np.random.default_rng(seed)
    centre, scale = np.array([cx, cy]), 10 ** log_scale
    tris = [_triangle(rng, centre, scale) for _ in range(3)]
    P, T = np.vstack(tris), np.arange(9).reshape(3, 3)
    Q0 = _spd(rng)
    lam = np.linalg.eigvalsh(Q0)[0]
    G = [0.15 * lam * (M + M.T) / 2 / np.abs(M).max() for M in rng.uniform(-1, 1, (2, 2, 2))]
    f = linear_field(Q0, G[0], G[1], centre, scale)
    field = qmesh.TensorField(f)
    m, err = field.means_with_error(P, T)
    exact = f(*np.mean(np.array(tris), axis=1).T)
    # the points themselves are known to |centre| ε: Q moves by |G| |centre| ε / scale under that
    tol = 1e-12 * np.abs(Q0).max() + 64 * np.finfo(float).eps * np.abs(centre).max() / scale * np.abs(G).max()
    assert np.allclose(m, exact, rtol=0, atol=tol)
    assert np.all(err <= 1e-11 * np.abs(Q0).max() + tol)
    const = qmesh.TensorField.from_expressions(Q0[0, 0], Q0[0, 1], Q0[1, 1])
    assert np.array_equal(const.means(P, T), np.broadcast_to(const(P[:1]), (3, 2, 2)))
    # the same constant given by a callable goes through the quadrature: still exact
    m = qmesh.TensorField(lambda x, y: np.broadcast_to(Q0, np.shape(x) + (2, 2))).means(P, T)
    assert np.allclose(m, Q0, rtol=0, atol=1e-14 * np.abs(Q0).max())


def test_linear_texts_are_exact():
    """Texts in x, y: a linear Q given as three expressions, its mean the value at the centroid."""
    field = qmesh.TensorField.from_expressions("3 + 0.5*x - 0.25*y", "0.1*x + 0.2*y", "2 - 0.3*x")
    P = np.array([[0.1, 0.2], [1.7, 0.4], [0.6, 1.9], [-0.8, 1.1]])
    T = np.array([[0, 1, 2], [0, 2, 3]])
    centroid = P[T].mean(axis=1)
    assert np.allclose(field.means(P, T), field(centroid), rtol=0, atol=1e-14)


def fvca5_test5(delta=1e-3):
    """FVCA5 test 5 (Herbin & Hubert 2008): K = [[δx² + y², (δ−1)xy], [(δ−1)xy, x² + δy²]] / (x² + y²)."""
    def K(x, y):
        x, y = np.asarray(x, float), np.asarray(y, float)
        r2 = x * x + y * y
        return np.stack([np.stack([delta * x * x + y * y, (delta - 1) * x * y], -1),
                         np.stack([(delta - 1) * x * y, x * x + delta * y * y], -1)], -2) / r2[..., None, None]
    return K


SMOOTH = {
    "fvca5_test5": (lambda: qmesh.TensorField(fvca5_test5(), "FVCA5 test 5"), fvca5_test5()),
    "principal_texts": (lambda: qmesh.TensorField.principal("1 + x*x", "0.01*exp(y)", "40*sin(2*x + y)"),
                        lambda x, y: np.stack([principal_matrix(1 + a * a, 0.01 * np.exp(b), 40 * np.sin(2 * a + b))
                                               for a, b in zip(x, y)])),
}


@pytest.mark.parametrize("name", sorted(SMOOTH))
@settings(max_examples=12, deadline=None)
@given(seed=seeds, cx=st.floats(0.4, 0.9), cy=st.floats(0.4, 0.9), scale=st.sampled_from([0.3, 0.05, 0.005]))
def test_means_of_smooth_fields_within_their_bound(name, seed, cx, cy, scale):
    """Away from FVCA5 test 5's rotation centre the field is smooth: the adaptive mean agrees with
    a fine reference of another rule (collapsed Gauss on 4⁴ pieces) within the returned bound —
    the rule's estimate for a callable, within RTOL; for a text the proven one, within its
    `bound_rtol` (`means.BOUND_RTOL`), the mean itself as close as the callable's."""
    from qmesh.conductivity import means as _m
    make, f = SMOOTH[name]
    tri = _triangle(np.random.default_rng(seed), np.array([cx, cy]), scale)
    m, err = make().means_with_error(tri, [[0, 1, 2]])
    expected = ref.fine_mean(f, tri, levels=3 if name == "principal_texts" else 4)
    gap = np.linalg.norm(m[0] - expected)
    assert gap <= err[0] + 1e-13 * np.linalg.norm(expected), (gap, err[0])
    if name == "principal_texts":
        assert err[0] <= _m.BOUND_RTOL * 1.01 * np.linalg.norm(m[0])
        assert gap <= 1e-9 * np.linalg.norm(expected)
    else:
        assert err[0] <= 1e-9 * np.linalg.norm(expected)


@pytest.mark.parametrize("name", ["fvca5_texts", "plasma_texts", "principal_texts"])
@pytest.mark.parametrize("rtol, depth", [(1e-10, 8), (1e-7, 8), (1e-14, 2), (np.inf, 0)])
def test_batched_means_equal_piece_by_piece_quadrature_bit_for_bit(name, rtol, depth):
    """The quadrature evaluates all the pieces of a level, of all the triangles, in a few batched
    calls: the means and bounds of many triangles at once are, to the bit, those of the same
    algorithm written out one triangle and one piece at a time (`reference`), at the field's
    tolerance, the repair's, at the depth cap and unrefined."""
    from qmesh.conductivity import means as _m
    field = {
        "fvca5_texts": lambda: qmesh.TensorField.from_expressions(
            "(0.001*x**2 + y**2)/(x**2 + y**2)", "(0.001 - 1)*x*y/(x**2 + y**2)",
            "(x**2 + 0.001*y**2)/(x**2 + y**2)"),
        "plasma_texts": lambda: qmesh.TensorField.from_expressions(
            "1e-4 + (1 - 1e-4)*(4*(y - 0.5))**2/((2*(x - 0.5))**2 + (4*(y - 0.5))**2)",
            "-(1 - 1e-4)*(2*(x - 0.5))*(4*(y - 0.5))/((2*(x - 0.5))**2 + (4*(y - 0.5))**2)",
            "1e-4 + (1 - 1e-4)*(2*(x - 0.5))**2/((2*(x - 0.5))**2 + (4*(y - 0.5))**2)"),
        "principal_texts": SMOOTH["principal_texts"][0],
    }[name]()
    rng = np.random.default_rng(7)
    centres = rng.uniform(0.1, 0.9, (400, 2))
    sizes = rng.choice([0.3, 0.05, 0.01], 400)
    away = np.linalg.norm(centres - 0.5, axis=1) > 0.1 + 1.5 * sizes   # from plasma's O-point
    tris = np.array([_triangle(rng, c, s) for c, s in zip(centres[away][:40], sizes[away][:40])])
    flip = rng.random(40) < 0.3                 # some clockwise
    tris[flip] = tris[flip][:, ::-1]
    q, e = _m.adaptive_means(field._evaluate, tris[:, 0], tris[:, 1], tris[:, 2], rtol=rtol,
                             max_depth=depth)
    one = [ref.adaptive_mean_one_piece_at_a_time(field._evaluate, t, rtol, max_depth=depth) for t in tris]
    assert np.array_equal(q, np.array([m for m, _ in one]))
    assert np.array_equal(e, np.array([b for _, b in one]))
    if rtol == 1e-10:            # and the field's own means are these, pieces split by its bound
        qb, eb = _m.adaptive_means(field._evaluate, tris[:, 0], tris[:, 1], tris[:, 2], rtol=rtol,
                                   max_depth=depth, bound=_m.enclosure_bound(field._forms))
        m, b = field.means_with_error(tris.reshape(-1, 2), np.arange(3 * len(tris)).reshape(-1, 3))
        assert np.array_equal(m, _m.full_tensors(qb)) and np.array_equal(b, eb)
        assert np.max(np.abs(qb - q)) <= 1e-6 * np.max(np.abs(q))     # smooth: the same means


def test_singular_corner_keeps_a_bound():
    """A triangle with a vertex at FVCA5 test 5's rotation centre: Q has no limit there; the
    quadrature never evaluates the vertex, stops at its depth cap, and the exact mean (K depends
    on the polar angle θ only: ∫_T K = ∫ K(θ) ρ(θ)²/2 dθ, ρ = 0.1/(cos θ + sin θ)) is within the
    returned bound."""
    from scipy.integrate import quad
    delta = 1e-3
    m, err = qmesh.TensorField(fvca5_test5(delta)).means_with_error([[0, 0], [0.1, 0], [0, 0.1]], [[0, 1, 2]])
    w = lambda t: (0.1 / (np.cos(t) + np.sin(t))) ** 2 / 2 / 0.005        # noqa: E731
    q11 = quad(lambda t: (delta * np.cos(t) ** 2 + np.sin(t) ** 2) * w(t), 0, np.pi / 2, epsabs=1e-14)[0]
    q12 = quad(lambda t: (delta - 1) * np.cos(t) * np.sin(t) * w(t), 0, np.pi / 2, epsabs=1e-14)[0]
    exact = np.array([[q11, q12], [q12, q11]])
    assert 0 < err[0] < 1e-5
    assert np.linalg.norm(m[0] - exact) <= err[0]


# --------------------------------------------------------------------------- rasters

def _raster(rng, max_cells=6):
    """Random uneven cell edges at any position and scale, every cell its own k1, k2, angle."""
    nx, ny = rng.integers(1, max_cells + 1, 2)
    x = rng.uniform(-100, 100) + 10 ** rng.uniform(-2, 2) * np.r_[0, np.cumsum(rng.uniform(0.2, 1, nx))]
    y = rng.uniform(-100, 100) + 10 ** rng.uniform(-2, 2) * np.r_[0, np.cumsum(rng.uniform(0.2, 1, ny))]
    k1 = np.exp(rng.normal(0, 2, (ny, nx)))
    k2 = k1 * np.exp(-rng.uniform(0, 6, (ny, nx)))
    return x, y, k1, k2, rng.uniform(-180, 360, (ny, nx))


def _point_in(rng, x, y):
    """A point of the raster: anywhere, or on a vertical grid line, or a grid node."""
    kind = rng.choice(["free", "free", "xline", "node"])
    px = rng.choice(x) if kind in ("xline", "node") else rng.uniform(x[0], x[-1])
    py = rng.choice(y) if kind == "node" else rng.uniform(y[0], y[-1])
    return px, py


@settings(max_examples=60, deadline=None)
@given(seeds)
def test_raster_means_equal_exact_clipping(seed):
    """Green's theorem along the edges = per-cell Sutherland–Hodgman clipping, for random rasters
    (uneven cell edges, every cell its own k1, k2, angle) and random triangles inside, vertices
    on grid lines and nodes included, either orientation."""
    rng = np.random.default_rng(seed)
    x, y, k1, k2, angle = _raster(rng)
    field = qmesh.TensorField.from_raster(x, y, k1, k2, angle)
    Q = ref.cell_tensors(k1, k2, angle)
    tris = []
    while len(tris) < 4:
        t = np.array([_point_in(rng, x, y) for _ in range(3)])
        if abs(ref.area([tuple(p) for p in t])) > 1e-6 * (x[-1] - x[0]) * (y[-1] - y[0]):
            tris.append(t)
    P, T = np.vstack(tris), np.arange(12).reshape(4, 3)
    m, err = field.means_with_error(P, T)
    for t, mt, et in zip(tris, m, err):
        expected, _ = ref.raster_mean_by_clipping(x, y, Q, t)
        scale = np.abs(Q).max()
        assert np.linalg.norm(mt - expected) <= et + 1e-9 * scale
        assert np.allclose(mt, expected, rtol=0, atol=1e-9 * scale)


def test_raster_means_share_edges():
    """A mesh of the raster's rectangle: the means, area-weighted, give the mean of all cells
    (each edge integrated once, with opposite signs on its two sides)."""
    from scipy.spatial import Delaunay
    rng = np.random.default_rng(3)
    x, y = np.r_[0, np.sort(rng.random(9)), 1] * 3, np.r_[0, np.sort(rng.random(6)), 1]
    k1, angle = np.exp(rng.normal(size=(7, 10))), rng.uniform(0, 180, (7, 10))
    field = qmesh.TensorField.from_raster(x, y, k1, 0.5 * k1, angle)
    P = np.vstack([rng.random((300, 2)) * [3, 1], [[0, 0], [3, 0], [3, 1], [0, 1]]])
    T = Delaunay(P).simplices
    u, v = P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]
    a = np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]) / 2
    cell_area = np.outer(np.diff(y), np.diff(x))
    Q = ref.cell_tensors(k1, 0.5 * k1, angle)
    expected = np.einsum("ji,jikl->kl", cell_area, Q) / cell_area.sum()
    assert np.allclose(np.einsum("t,tkl->kl", a, field.means(P, T)) / a.sum(), expected, atol=1e-12)


def test_constant_raster_gives_its_constant():
    rng = np.random.default_rng(0)
    x, y = np.r_[0, np.sort(rng.random(20)), 1], np.r_[-1, np.sort(rng.random(13)), 2]
    field = qmesh.TensorField.from_raster(x, y, 7.0, 0.07, 33.0)
    P = np.column_stack([rng.random(60), -1 + 3 * rng.random(60)])
    T = np.arange(60).reshape(20, 3)
    m, err = field.means_with_error(P, T)
    Q = principal_matrix(7.0, 0.07, 33.0)
    assert np.all(np.linalg.norm(m - Q, axis=(1, 2)) <= err + 1e-14 * 7)


def test_raster_of_linear_cell_averages_on_cell_aligned_triangles():
    """A raster holding a linear Q's cell averages (its value at each cell's centre) and two
    triangles splitting a block of whole cells: their area-weighted means are the formula's mean
    over the block, to round-off."""
    x, y = np.array([0.0, 0.3, 0.5, 1.1, 1.2, 2.0]), np.array([-1.0, -0.2, 0.4, 0.5, 1.5])
    f = qmesh.TensorField.from_expressions("4 + x + 0.5*y", "0.3*x - 0.2*y", "3 - 0.5*x + y")
    centres = np.stack(np.meshgrid((x[:-1] + x[1:]) / 2, (y[:-1] + y[1:]) / 2), -1).reshape(-1, 2)
    Qc = f(centres).reshape(len(y) - 1, len(x) - 1, 2, 2)
    k = np.linalg.eigh(Qc)
    angle = np.degrees(np.arctan2(k[1][..., 1, 1], k[1][..., 0, 1]))
    raster = qmesh.TensorField.from_raster(x, y, k[0][..., 1], k[0][..., 0], angle)
    assert np.allclose(raster(centres), Qc.reshape(-1, 2, 2), atol=1e-13)
    for (i0, i1, j0, j1) in [(0, 5, 0, 4), (1, 3, 1, 2), (2, 5, 0, 3), (0, 1, 0, 1)]:
        P = np.array([[x[i0], y[j0]], [x[i1], y[j0]], [x[i1], y[j1]], [x[i0], y[j1]]])
        T = np.array([[0, 1, 2], [0, 2, 3]])
        block = raster.means(P, T).mean(axis=0)          # two halves of equal area
        assert np.allclose(block, f([[(x[i0] + x[i1]) / 2, (y[j0] + y[j1]) / 2]])[0], atol=1e-12)
        # and the formula's own means of the two halves, averaged, agree too
        assert np.allclose(f.means(P, T).mean(axis=0), block, atol=1e-12)


def test_raster_triangle_reaching_outside_is_refused():
    field = qmesh.TensorField.from_raster([0, 1, 2], [0, 1], [[1.0, 2.0]], [[1.0, 1.0]])
    with pytest.raises(qmesh.QmeshError, match=r"vertex \(x, y\) = \(2.5, 0.5\) is outside the raster 1 × 2"):
        field.means([[0, 0], [2.5, 0.5], [0, 1]], [[0, 1, 2]])
    # a vertex on the boundary up to round-off is on it
    m = field.means([[0, 0], [2 + 1e-15, 0], [0, 1]], [[0, 1, 2]])
    assert np.allclose(m[0], np.diag([1.25, 1.0]))
