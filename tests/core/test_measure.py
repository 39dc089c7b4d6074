"""Tests of qmesh.measure against closed forms and independent computations (MATH.md)."""

from __future__ import annotations

import json
from math import factorial

import numpy as np
import pytest
from scipy.integrate import dblquad
from scipy.spatial import Delaunay

import qmesh
from qmesh import measure
from qmesh.geometry import quadrature
from qmesh.conductivity.anisotropy import adj2

CHAPTER = qmesh.Anisotropy.constant([[0.1, 0.0], [0.0, 10.0]])   # s = 5x² + 0.05y²


# --------------------------------------------------------------------------- helpers

def square_mesh(n: int) -> qmesh.Mesh:
    """The unit square cut into n×n squares, each split into two right triangles (CCW)."""
    x = np.linspace(0.0, 1.0, n + 1)
    X, Y = np.meshgrid(x, x)
    P = np.c_[X.ravel(), Y.ravel()]
    i, j = np.meshgrid(np.arange(n), np.arange(n))
    v00 = (j * (n + 1) + i).ravel()
    v10, v01, v11 = v00 + 1, v00 + n + 1, v00 + n + 2
    T = np.r_[np.c_[v00, v10, v11], np.c_[v00, v11, v01]]
    return qmesh.Mesh(P, T)


def ccw(P, T):
    T = np.array(T)
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    T[cw] = T[cw][:, ::-1]
    return T


def disk_mesh(n: int, seed: int, map_by=None) -> qmesh.Mesh:
    """Random points in the unit disk (a 24-gon boundary); Delaunay of the points mapped by `map_by`."""
    rng = np.random.default_rng(seed)
    t = 2 * np.pi * np.arange(24) / 24
    r, a = np.sqrt(rng.random(n)) * 0.95, rng.random(n) * 2 * np.pi
    P = np.r_[np.c_[np.cos(t), np.sin(t)], np.c_[r * np.cos(a), r * np.sin(a)]]
    Pm = P if map_by is None else P @ map_by.T
    return qmesh.Mesh(P, ccw(P, Delaunay(Pm).simplices))


def sqrtm_spd(H):
    w, V = np.linalg.eigh(H)
    return (V * np.sqrt(w)) @ V.T


def random_spd(rng, max_ratio=1e3):
    t = rng.random() * np.pi
    R = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    k = np.exp(rng.uniform(0, np.log(max_ratio)))
    return R @ np.diag([1.0, k]) @ R.T * rng.uniform(0.1, 10)


def as_varying(anis):
    """The same s as `anis`, but through from_s, so measure takes its quadrature/centroid paths."""
    return qmesh.Anisotropy.from_s(anis.s, anis.grad, lambda P: np.array(anis.hessian(P)))


def triangle_integral(f, X):
    """∫_T f for the triangle with corners X (3, 2), by scipy dblquad over the reference triangle."""
    a, b, c = X
    jac = abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))

    def g(v, u):
        p = a + u * (b - a) + v * (c - a)
        return f(p[None, :])[0]

    val, _ = dblquad(g, 0.0, 1.0, 0.0, lambda u: 1.0 - u, epsabs=1e-15, epsrel=1e-12)
    return jac * val


def plane_through(X, values):
    """Coefficients (c0, cx, cy) of the affine function taking `values` at the corners X."""
    return np.linalg.solve(np.c_[np.ones(3), X], values)


def slope(N, err):
    return np.polyfit(np.log(N), np.log(err), 1)[0]


# --------------------------------------------------------------------------- quadrature

def test_dunavant_rule_integrates_every_monomial_up_to_degree_4():
    # Reference triangle (0,0), (1,0), (0,1): ∫ x^a y^b = a! b! / (a + b + 2)!.
    bary = quadrature.DUNAVANT4_POINTS
    w = quadrature.DUNAVANT4_WEIGHTS
    x, y = bary[:, 1], bary[:, 2]
    assert quadrature.DUNAVANT4_DEGREE == 4
    assert np.allclose(bary.sum(axis=1), 1.0, atol=1e-15)
    for d in range(5):
        for a in range(d + 1):
            b = d - a
            exact = factorial(a) * factorial(b) / factorial(a + b + 2)
            assert 0.5 * np.dot(w, x**a * y**b) == pytest.approx(exact, rel=2e-14, abs=0)
    # …and not beyond: the rule is degree 4, so some degree-6 monomial is wrong.
    assert 0.5 * np.dot(w, x**6) != pytest.approx(factorial(6) / factorial(8), rel=1e-6)


# --------------------------------------------------------------------------- conditioning

@pytest.mark.parametrize("method", ["dense", "sparse"])
@pytest.mark.parametrize("n", [4, 8, 16])
def test_laplacian_kappa2_on_structured_square_is_cot2(n, method):
    mesh = square_mesh(n)
    expected = 1.0 / np.tan(np.pi / (2 * n)) ** 2           # cot²(πh/2), h = 1/n
    assert measure.condition_number(mesh, None, method=method) == pytest.approx(expected, rel=1e-8)


@pytest.mark.parametrize("n, dense", [(8, True), (64, False)])
def test_kappa2_auto_picks_the_path_by_size_and_matches_closed_form(n, dense, monkeypatch):
    mesh = square_mesh(n)
    assert (len(measure.free_vertices(mesh)) <= measure.DENSE_LIMIT) == dense
    calls = []
    eigvalsh = measure.scipy.linalg.eigvalsh
    monkeypatch.setattr(measure.scipy.linalg, "eigvalsh", lambda A: calls.append(1) or eigvalsh(A))
    expected = 1.0 / np.tan(np.pi / (2 * n)) ** 2
    assert measure.condition_number(mesh) == pytest.approx(expected, rel=1e-8)
    assert bool(calls) == dense


def test_kappa2_dense_and_sparse_agree_for_anisotropic_q():
    mesh = disk_mesh(250, seed=3)
    dense = measure.condition_number(mesh, CHAPTER, method="dense")
    sparse = measure.condition_number(mesh, CHAPTER, method="sparse")
    assert sparse == pytest.approx(dense, rel=1e-8)
    assert dense != pytest.approx(measure.condition_number(mesh, None), rel=1e-3)


def test_kappa2_equals_eigenvalue_ratio_of_dirichlet_matrix():
    mesh = disk_mesh(120, seed=4)
    K = measure.stiffness(mesh, CHAPTER).toarray()
    free = ~mesh.boundary
    w = np.linalg.eigvalsh(K[np.ix_(free, free)])
    assert measure.condition_number(mesh, CHAPTER) == pytest.approx(w[-1] / w[0], rel=1e-9)
    Ki = measure.stiffness_interior(mesh, CHAPTER).toarray()
    assert np.allclose(Ki, K[np.ix_(free, free)], rtol=0, atol=1e-12 * np.abs(K).max())


def test_kappa2_bad_input():
    one_triangle = qmesh.Mesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    with pytest.raises(qmesh.QmeshError):
        measure.condition_number(one_triangle)
    with pytest.raises(qmesh.QmeshError):
        measure.condition_number(square_mesh(4), method="lanczos")


# --------------------------------------------------------------------------- stiffness, q_ij

@pytest.mark.parametrize("seed", [0, 1, 2])
def test_q_ij_equals_cotangent_formula_for_constant_q(seed):
    rng = np.random.default_rng(seed)
    Q = random_spd(rng)
    anis = qmesh.Anisotropy.constant(Q)
    mesh = disk_mesh(60, seed=seed)                         # plain Delaunay: not Q-Delaunay
    # Independent: map by H^{1/2}, cotangents of the mapped angles (MATH.md).
    L = sqrtm_spd(adj2(Q))
    Pm = mesh.points @ L.T
    expected, count = {}, {}
    for tri in mesh.triangles:
        for k in range(3):
            i, j = tri[(k + 1) % 3], tri[(k + 2) % 3]
            u, v = Pm[i] - Pm[tri[k]], Pm[j] - Pm[tri[k]]
            cot = np.dot(u, v) / abs(u[0] * v[1] - u[1] * v[0])
            key = (min(i, j), max(i, j))
            expected[key] = expected.get(key, 0.0) + 0.5 * np.sqrt(np.linalg.det(Q)) * cot
            count[key] = count.get(key, 0) + 1
    edges, q, interior = measure.edge_weights(mesh, anis)
    assert len(edges) == len(expected)
    got = dict(zip(map(tuple, edges.tolist()), q))
    scale = max(abs(v) for v in expected.values())
    for key, val in expected.items():
        assert got[key] == pytest.approx(val, abs=1e-10 * scale)
    assert [count[tuple(e)] == 2 for e in edges.tolist()] == interior.tolist()
    # The same numbers off the assembled matrix.
    K = measure.stiffness(mesh, anis)
    assert np.allclose(-np.asarray(K[edges[:, 0], edges[:, 1]]).ravel(), q, rtol=0, atol=1e-10 * scale)


def test_stiffness_rows_sum_to_zero_and_matrix_is_symmetric():
    rng = np.random.default_rng(5)
    mesh = disk_mesh(200, seed=5)
    for anis in (qmesh.Anisotropy.constant(random_spd(rng)), CHAPTER, None):
        K = measure.stiffness(mesh, anis)
        assert K.shape == (mesh.n_vertices, mesh.n_vertices)
        scale = abs(K).max()
        assert np.abs(K @ np.ones(mesh.n_vertices)).max() < 1e-12 * scale
        assert abs(K - K.T).max() < 1e-14 * scale
        assert np.all(K.diagonal() > 0)


def test_stiffness_for_varying_q_uses_q_at_the_centroid():
    # s = exp(x) + y² + x²: H = [[eˣ + 2, 0], [0, 2]], Q = adj H = [[2, 0], [0, eˣ + 2]].
    def hess(P):
        Hs = np.zeros((len(P), 2, 2))
        Hs[:, 0, 0], Hs[:, 1, 1] = np.exp(P[:, 0]) + 2, 2.0
        return Hs
    anis = qmesh.Anisotropy.from_s(lambda P: np.exp(P[:, 0]) + P[:, 1] ** 2 + P[:, 0] ** 2,
                                   lambda P: np.c_[np.exp(P[:, 0]) + 2 * P[:, 0], 2 * P[:, 1]], hess)
    X = np.array([[0.1, 0.2], [1.3, 0.4], [0.5, 1.7]])
    mesh = qmesh.Mesh(X, [[0, 1, 2]])
    A = np.c_[np.ones(3), X]
    grads = np.linalg.inv(A)[1:]                             # column a = ∇φ_a
    c = X.mean(axis=0)
    Qc = np.diag([2.0, np.exp(c[0]) + 2])
    area = 0.5 * abs(np.linalg.det(A))
    assert np.allclose(measure.stiffness(mesh, anis).toarray(), area * grads.T @ Qc @ grads, rtol=1e-13)


def test_measurements_are_translation_invariant_far_from_the_origin():
    mesh = disk_mesh(150, seed=14)
    far = qmesh.Mesh(mesh.points * 1e-2 + [3e4, -5e4], mesh.triangles)
    near = qmesh.Mesh(mesh.points * 1e-2, mesh.triangles)
    K_far, K_near = measure.stiffness(far, CHAPTER), measure.stiffness(near, CHAPTER)
    assert abs(K_far - K_near).max() < 1e-7 * abs(K_near).max()
    assert measure.quality(far, CHAPTER) == pytest.approx(measure.quality(near, CHAPTER), rel=1e-6)
    assert measure.energy(far, CHAPTER) == pytest.approx(measure.energy(near, CHAPTER), rel=1e-6)


def test_varying_path_matches_constant_path_for_the_same_quadratic_s():
    mesh = disk_mesh(150, seed=6)
    K1 = measure.stiffness(mesh, CHAPTER)
    K2 = measure.stiffness(mesh, as_varying(CHAPTER))
    assert abs(K1 - K2).max() < 1e-12 * abs(K1).max()


def test_q_nonnegative_fraction_is_one_exactly_on_the_q_delaunay_mesh():
    L = np.linalg.cholesky(CHAPTER.H).T                      # LᵀL = H
    q_delaunay = disk_mesh(300, seed=7, map_by=L)
    plain = disk_mesh(300, seed=7)
    assert measure.q_nonnegative_fraction(q_delaunay, CHAPTER) == 1.0
    _, q, interior = measure.edge_weights(plain, CHAPTER)
    negative = np.sum(q[interior] < -1e-9 * np.abs(q).max())
    assert negative > 0
    assert measure.q_nonnegative_fraction(plain, CHAPTER) == pytest.approx(1 - negative / interior.sum())
    # the Laplacian is the reverse case: the plain Delaunay mesh is its M-matrix mesh
    assert measure.q_nonnegative_fraction(plain, None) == 1.0


def test_q_nonnegative_fraction_tolerance_is_relative():
    # A right-triangle grid has q = 0 on its diagonals (cot 90°); rotated, round-off makes some of
    # them tiny negatives that must still count as ≥ 0, at any scale of the coordinates.
    mesh = square_mesh(10)
    t = 0.7
    R = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    for scale in (1e-6, 1.0, 1e6):
        m = qmesh.Mesh((mesh.points - 0.37) @ R.T * scale, mesh.triangles)
        _, q, interior = measure.edge_weights(m, None)
        assert np.any(q[interior] < 0)                       # round-off negatives exist
        assert measure.q_nonnegative_fraction(m, None) == 1.0
        assert measure.q_nonnegative_fraction(m, None, rtol=0.0) < 1.0


def test_degenerate_triangle_is_an_error_for_the_stiffness():
    mesh = qmesh.Mesh([[0, 0], [1, 0], [2, 0], [0, 1]], [[0, 1, 2], [0, 1, 3]])
    with pytest.raises(qmesh.QmeshError, match="degenerate"):
        measure.stiffness(mesh, CHAPTER)


# --------------------------------------------------------------------------- interpolation

def test_interpolation_error_is_zero_for_linear_s():
    linear = qmesh.Anisotropy.from_s(lambda P: 2 + 3 * P[:, 0] - P[:, 1],
                                     lambda P: np.broadcast_to([3.0, -1.0], P.shape),
                                     lambda P: np.zeros((len(P), 2, 2)))
    l2, h1 = measure.interpolation_errors(disk_mesh(200, seed=8), linear)
    assert l2 < 1e-13 and h1 < 1e-12


def test_interpolation_errors_converge_at_the_p1_rates():
    ns = [4, 8, 16, 32, 64]
    N, l2, h1 = [], [], []
    for n in ns:
        m = square_mesh(n)
        e0, e1 = measure.interpolation_errors(m, CHAPTER)
        N.append(m.n_vertices), l2.append(e0), h1.append(e1)
    assert slope(N, l2) == pytest.approx(-1.0, abs=0.1)
    assert slope(N, h1) == pytest.approx(-0.5, abs=0.1)


@pytest.mark.parametrize("seed", [0, 1])
def test_interpolation_errors_of_one_triangle_match_dblquad(seed):
    # Guards the chapter's suspected √2 in the L2 column: an independent integral, no shared code.
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, (3, 2))
    anis = qmesh.Anisotropy.constant(random_spd(rng, 100))
    mesh = qmesh.Mesh(X, ccw(X, [[0, 1, 2]]))
    c = plane_through(X, anis.s(X))
    sh = lambda P: c[0] + P @ c[1:]
    l2_ref = np.sqrt(triangle_integral(lambda P: (sh(P) - anis.s(P)) ** 2, X))
    h1_ref = np.sqrt(triangle_integral(lambda P: np.sum((c[1:] - anis.grad(P)) ** 2, axis=1), X))
    l2, h1 = measure.interpolation_errors(mesh, anis)
    assert l2 == pytest.approx(l2_ref, rel=1e-9)
    assert h1 == pytest.approx(h1_ref, rel=1e-9)


def test_interpolation_errors_on_a_chapter_like_mesh_match_the_varying_path():
    mesh = disk_mesh(300, seed=9)
    assert measure.interpolation_errors(mesh, as_varying(CHAPTER)) == pytest.approx(
        measure.interpolation_errors(mesh, CHAPTER), rel=1e-12)


# --------------------------------------------------------------------------- energy

def test_triangle_energy_closed_form_equals_quadrature_for_quadratic_s():
    rng = np.random.default_rng(10)
    P = rng.uniform(-2, 2, (3 * 50, 2))
    T = ccw(P, np.arange(len(P)).reshape(-1, 3))
    for _ in range(3):
        anis = qmesh.Anisotropy.constant(random_spd(rng))
        closed = measure.triangle_energy(P, T, anis)                 # |T|/24 Σ eᵀHe
        quad = measure.triangle_energy(P, T, as_varying(anis))       # Dunavant rule
        assert np.allclose(closed, quad, rtol=1e-11, atol=0)
        # one triangle by scipy's adaptive quadrature, independent of both
        X = P[T[0]]
        c = plane_through(X, anis.s(X))
        ref = triangle_integral(lambda Q: c[0] + Q @ c[1:] - anis.s(Q), X)
        assert closed[0] == pytest.approx(ref, rel=1e-9)


def test_energy_is_positive_and_decreases_under_refinement():
    energies = [measure.energy(square_mesh(n), CHAPTER) for n in (2, 4, 8, 16, 32)]
    assert all(e > 0 for e in energies)
    assert all(b < a for a, b in zip(energies, energies[1:]))
    # E = ‖s_h − s‖_L1 = Σ |T|/24 Σ eᵀHe is exactly ∝ h² on these self-similar grids
    assert np.allclose(np.divide(energies[:-1], energies[1:]), 4.0, rtol=1e-12)


def test_energy_is_the_sum_of_triangle_energies_and_the_l1_error():
    mesh = disk_mesh(100, seed=11)
    parts = measure.triangle_energy(mesh.points, mesh.triangles, CHAPTER)
    assert np.all(parts > 0)
    assert measure.energy(mesh, CHAPTER) == pytest.approx(parts.sum(), rel=1e-14)


def test_orientation_signs_energy_but_not_stiffness_or_errors():
    # E is signed (the smooth function the vertex step differentiates); K and the errors are not.
    X = np.array([[0.1, 0.2], [1.3, 0.4], [0.5, 1.7]])
    up, down = qmesh.Mesh(X, [[0, 1, 2]]), qmesh.Mesh(X, [[0, 2, 1]])
    e_up = measure.triangle_energy(X, up.triangles, CHAPTER)[0]
    assert e_up > 0
    assert measure.triangle_energy(X, down.triangles, CHAPTER)[0] == pytest.approx(-e_up, rel=1e-14)
    assert measure.triangle_energy(X, down.triangles, as_varying(CHAPTER))[0] == pytest.approx(-e_up, rel=1e-12)
    assert np.allclose(measure.stiffness(down, CHAPTER).toarray(), measure.stiffness(up, CHAPTER).toarray(),
                       rtol=1e-14)
    assert measure.interpolation_errors(down, CHAPTER) == pytest.approx(
        measure.interpolation_errors(up, CHAPTER), rel=1e-14)
    assert measure.report(down, CHAPTER)["inverted_triangles"] == 1


# --------------------------------------------------------------------------- quality

@pytest.mark.parametrize("seed", [0, 1, 2])
def test_quality_is_one_for_a_metric_equilateral_triangle(seed):
    rng = np.random.default_rng(seed)
    anis = qmesh.Anisotropy.constant(random_spd(rng))
    t = rng.random() * 2 * np.pi + np.array([0, 2 * np.pi / 3, 4 * np.pi / 3])
    Y = np.c_[np.cos(t), np.sin(t)]                          # equilateral, CCW
    X = Y @ np.linalg.inv(sqrtm_spd(anis.H)).T               # x = H^{-1/2} y
    q = measure.quality(qmesh.Mesh(X, [[0, 1, 2]]), anis)
    assert q[0] == pytest.approx(1.0, abs=1e-12)
    # …and the same triangle is not equilateral for another metric
    assert measure.quality(qmesh.Mesh(X, [[0, 1, 2]]), qmesh.Anisotropy.constant(np.eye(2)))[0] < 1 - 1e-6 \
        or np.allclose(anis.H / anis.H[0, 0], np.eye(2))


def test_quality_below_one_otherwise_and_scale_invariant():
    rng = np.random.default_rng(12)
    P = rng.uniform(-1, 1, (3 * 40, 2))
    T = ccw(P, np.arange(len(P)).reshape(-1, 3))
    q = measure.quality(qmesh.Mesh(P, T), CHAPTER)
    assert np.all((q > 0) & (q < 1))
    for c in (1e-3, 7.0):
        assert np.allclose(measure.quality(qmesh.Mesh(c * P, T), CHAPTER), q, rtol=1e-12)


# --------------------------------------------------------------------------- report

REPORT_KEYS = {"n_vertices", "n_triangles", "n_boundary", "n_interior", "l2_error", "h1_error",
               "kappa2", "kappa2_laplacian", "q_nonnegative_fraction", "min_q_ij_relative",
               "q_nonnegative_fraction_boundary", "min_q_ij_relative_boundary",
               "min_quality", "mean_quality", "energy", "inverted_triangles", "monotonicity"}


def test_report_is_complete_json_and_consistent():
    mesh = disk_mesh(250, seed=13)
    r = measure.report(mesh, CHAPTER)
    assert REPORT_KEYS <= set(r)
    assert all(type(v) in (int, float) for k, v in r.items() if k != "monotonicity")
    assert r["monotonicity"] == str(measure.monotonicity(mesh, CHAPTER)) == "none"   # Delaunay
    assert json.loads(json.dumps(r, allow_nan=False)) == r
    q = measure.quality(mesh, CHAPTER)
    l2, h1 = measure.interpolation_errors(mesh, CHAPTER)
    _, qij, interior = measure.edge_weights(mesh, CHAPTER)
    assert (r["n_vertices"], r["n_triangles"]) == (mesh.n_vertices, mesh.n_triangles)
    assert r["n_boundary"] == int(mesh.boundary.sum()) == 24
    assert r["n_interior"] == mesh.n_vertices - 24
    assert r["inverted_triangles"] == 0
    assert (r["l2_error"], r["h1_error"]) == pytest.approx((l2, h1), rel=1e-14)
    assert r["kappa2"] == pytest.approx(measure.condition_number(mesh, CHAPTER), rel=1e-12)
    assert r["kappa2_laplacian"] == pytest.approx(measure.condition_number(mesh), rel=1e-12)
    assert r["q_nonnegative_fraction"] == measure.q_nonnegative_fraction(mesh, CHAPTER)
    assert r["q_nonnegative_fraction"] < 1.0                 # plain Delaunay is not Q-Delaunay
    assert r["min_q_ij_relative"] == pytest.approx(qij[interior].min() / np.abs(qij).max())
    assert r["min_q_ij_relative"] < 0
    assert (r["min_quality"], r["mean_quality"]) == pytest.approx((q.min(), q.mean()))
    assert r["energy"] == pytest.approx(measure.energy(mesh, CHAPTER))


def test_report_of_a_mesh_with_a_degenerate_triangle_still_serialises():
    mesh = qmesh.Mesh([[0, 0], [1, 0], [2, 0], [0, 1], [1, 1]], [[0, 1, 2], [0, 1, 3], [1, 4, 3]])
    r = measure.report(mesh, CHAPTER)
    assert r["inverted_triangles"] == 1 and r["kappa2"] is None and r["l2_error"] is None
    json.dumps(r, allow_nan=False)
