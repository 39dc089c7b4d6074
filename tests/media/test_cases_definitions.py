"""The benchmark media are the published ones: FVCA5 test 4's strips (0.1 high, offset by 0.05
across x = 0.5, K per strip, u = 1 − x on ∂Ω) and FVCA6 test 5's quadrants (K and α per
quadrant, flux continuity of the exact solution across x = ½ and y = ½, f = −div(K∇u)); a small
qmesh run of FVCA6 test 5 keeps every q_ij ≥ 0 and gives a finite P1 error, and that error
(bench_media's) falls at second order on Triangle's meshes."""

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import qmesh
from qmesh import measure
from qmesh.compare.media_peers import region_of
from qmesh.domain import media_cases as cases

ROOT = Path(__file__).resolve().parents[2]
K1, K2 = np.diag([1e-2, 1e-3]), np.diag([1e2, 1e1])


def fvca4_is_k2(x, y):
    """The benchmark's K2 set: strips [0.2k, 0.2k + 0.1] on the right of the fault x = 0.5,
    the same shifted up by 0.05 on its left."""
    shifted = np.where(x <= 0.5, y - 0.05, y)
    return np.floor(10 * shifted) % 2 == 0


def test_fvca4_is_the_benchmarks_vertical_fault():
    domain, cond, g = cases.fvca4()
    assert len(domain.regions) == 5 and sorted(cond) == [0, 1, 2, 3, 4, 5]
    assert np.array_equal(cond[0].matrix, K1)
    assert all(np.array_equal(cond[t].matrix, K2) for t in range(1, 6))
    # the strips' edges: every 0.1 on the right, every 0.1 from 0.05 on the left
    for k, ring in enumerate(domain.regions):
        P = np.asarray(ring.rings[0], dtype=float)
        right, left = P[P[:, 0] > 0.5], P[P[:, 0] < 0.5]
        assert np.allclose(sorted(set(right[:, 1])), [0.2 * k, 0.2 * k + 0.1], atol=1e-15)
        assert np.allclose(sorted(set(left[:, 1])), [0.2 * k + 0.05, 0.2 * k + 0.15], atol=1e-15)
    # points off the lines: region K2 exactly where the benchmark puts K2
    x, y = np.meshgrid(np.linspace(0.013, 0.987, 36), np.arange(0.0125, 1.0, 0.025))
    X = np.column_stack([x.ravel(), y.ravel()])
    tags = region_of(domain, X)
    assert (tags >= 0).all()
    assert np.array_equal(tags > 0, fvca4_is_k2(X[:, 0], X[:, 1]))
    assert np.allclose(g(X[:, 0], X[:, 1]), 1 - X[:, 0])
    bottom_left = region_of(domain, np.array([[0.25, 0.025]]))
    assert bottom_left[0] == 0                      # the periodic pattern's K1 half strip


QUADRANTS = {0: (0.1, (10.0, 0.01)), 1: (10.0, (0.1, 100.0)), 2: (100.0, (0.01, 10.0)),
             3: (0.01, (100.0, 0.1))}


def test_fvca6_test5_quadrants_and_conductivities():
    domain, cond, g = cases.fvca6_test5()
    assert len(domain.regions) == 3 and sorted(cond) == [0, 1, 2, 3]
    for t, (_, k) in QUADRANTS.items():
        assert np.array_equal(cond[t].matrix, np.diag(k))
    X = np.array([[0.25, 0.25], [0.75, 0.25], [0.75, 0.75], [0.25, 0.75]])
    assert region_of(domain, X).tolist() == [0, 1, 2, 3]
    assert cases.quadrant(X[:, 0], X[:, 1]).tolist() == [0, 1, 2, 3]
    s = np.linspace(0, 1, 11)
    for x, y in ((s, 0 * s), (s, 0 * s + 1), (0 * s, s), (0 * s + 1, s)):
        assert np.allclose(g(x, y), 0, atol=1e-12)


def test_fvca6_test5_u_and_its_flux_are_continuous_across_the_quadrant_lines():
    t = np.linspace(0.01, 0.99, 99)
    t = t[np.abs(t - 0.5) > 1e-9]
    half = np.full_like(t, 0.5)
    # across x = ½ (normal e_x): quadrant 0 | 1 below y = ½, 3 | 2 above;
    # across y = ½ (normal e_y): quadrant 0 / 3 left of x = ½, 1 / 2 right
    for a, b, (x, y), axis in ((np.where(t <= 0.5, 0, 3), np.where(t <= 0.5, 1, 2), (half, t), 0),
                               (np.where(t <= 0.5, 0, 1), np.where(t <= 0.5, 3, 2), (t, half), 1)):
        ua, ub = cases.fvca6_test5_exact(x, y, a), cases.fvca6_test5_exact(x, y, b)
        assert np.allclose(ua, 0, atol=1e-12) and np.allclose(ub, 0, atol=1e-12)
        Ka = np.array([QUADRANTS[int(q)][1][axis] for q in a])
        Kb = np.array([QUADRANTS[int(q)][1][axis] for q in b])
        fa = Ka * cases.fvca6_test5_gradient(x, y, a)[:, axis]
        fb = Kb * cases.fvca6_test5_gradient(x, y, b)[:, axis]
        assert np.abs(fa).max() > 1e-3                       # a flux, not two zeros
        assert np.allclose(fa, fb, rtol=1e-12, atol=0)
        # while ∇u itself jumps by a factor 10 or more (α): K is what makes the flux continuous
        ga, gb = cases.fvca6_test5_gradient(x, y, a)[:, axis], cases.fvca6_test5_gradient(x, y, b)[:, axis]
        big = np.abs(ga) > 1e-6
        assert np.all(np.maximum(np.abs(ga[big] / gb[big]), np.abs(gb[big] / ga[big])) >= 9.99)


def test_fvca6_test5_source_is_minus_div_k_grad_u():
    rng = np.random.default_rng(5)
    X = rng.uniform(0.02, 0.98, (400, 2))
    X = X[np.abs(X - 0.5).min(axis=1) > 0.01]
    x, y = X.T
    tag = cases.quadrant(x, y)
    h = 1e-5
    kx = np.array([QUADRANTS[int(q)][1][0] for q in tag])
    ky = np.array([QUADRANTS[int(q)][1][1] for q in tag])
    # −div(K∇u) by central differences of the exact gradient times K
    dqx = (kx * cases.fvca6_test5_gradient(x + h, y, tag)[:, 0]
           - kx * cases.fvca6_test5_gradient(x - h, y, tag)[:, 0]) / (2 * h)
    dqy = (ky * cases.fvca6_test5_gradient(x, y + h, tag)[:, 1]
           - ky * cases.fvca6_test5_gradient(x, y - h, tag)[:, 1]) / (2 * h)
    f = cases.fvca6_test5_source(x, y, tag)
    assert np.allclose(f, -(dqx + dqy), rtol=1e-6, atol=1e-6 * np.abs(f).max())
    # and the gradient is u's: central differences of u
    du = np.column_stack([cases.fvca6_test5_exact(x + h, y, tag) - cases.fvca6_test5_exact(x - h, y, tag),
                          cases.fvca6_test5_exact(x, y + h, tag) - cases.fvca6_test5_exact(x, y - h, tag)])
    G = cases.fvca6_test5_gradient(x, y, tag)
    assert np.allclose(du / (2 * h), G, rtol=1e-6, atol=1e-6 * np.abs(G).max())
    alpha = np.array([QUADRANTS[int(q)][0] for q in tag])
    assert np.allclose(cases.fvca6_test5_exact(x, y), alpha * np.sin(2 * np.pi * x) * np.sin(2 * np.pi * y))


@pytest.fixture(scope="module")
def bench():
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import bench_media
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    return bench_media


def test_fvca6_test5_qmesh_keeps_every_q_ij_and_its_p1_error_is_finite(bench):
    domain, cond, _ = cases.fvca6_test5()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(domain, cond, target_vertices=500)
    assert 400 <= m.n_vertices <= 800       # about the target (how close is test_media_api's subject)
    assert set(np.unique(m.region_tags).tolist()) == {0, 1, 2, 3}
    r = measure.report(m, cond)
    assert r["q_nonnegative_fraction"] == r["q_nonnegative_fraction_interface"] == \
        r["q_nonnegative_fraction_boundary"] == 1.0
    err = bench.p1_l2_error(m, cond, cases.fvca6_test5_exact, cases.fvca6_test5_source)
    assert np.isfinite(err) and err > 0


def test_the_benchmarks_p1_error_falls_at_second_order(bench):
    pytest.importorskip("triangle")
    from qmesh.compare import media_peers as peers
    domain, cond, _ = cases.fvca6_test5()
    errs = [bench.p1_l2_error(peers.triangle(domain, n).mesh, cond, cases.fvca6_test5_exact,
                              cases.fvca6_test5_source) for n in (500, 2000)]
    assert 3.0 < errs[0] / errs[1] < 5.5                   # h halves: about 4
