"""The vertex step (MATH.md "Vertex adjustment", chapter (2.85)–(2.93)).

E = ⅓ Σ_i |Ω_i| s(x_i) − ∫s; the step solves H(x_i) d_i = b_i with b_i = −3∇_{x_i}E / |Ω_i|.
For a star whose ring is fixed, E is quadratic in the centre, so the unrelaxed step (α = 1)
lands exactly on the minimiser, which for a regular ring (in metric space) is its centre.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from cases import exp_plus_y2
from qmesh.mesher import adjust
from qmesh.geometry import triangles
from qmesh.geometry.triangles import signed_areas
from qmesh.measure import energy, triangle_energy
from qmesh.mesher.triangulate import lower_hull

RING = np.column_stack([np.cos(np.pi / 3 * np.arange(6)), np.sin(np.pi / 3 * np.arange(6))])
STAR = np.array([[0, 1 + k, 1 + (k + 1) % 6] for k in range(6)])      # centre 0, CCW




def inverse_sqrt(H: np.ndarray) -> np.ndarray:
    w, V = np.linalg.eigh(H)
    return V @ np.diag(w ** -0.5) @ V.T


def step_star(P, A, alpha=1.0):
    fixed = np.arange(7) > 0
    return adjust.vertex_step(P, STAR, A, fixed=fixed, tangent=np.zeros((7, 2)), alpha=alpha)


@pytest.mark.parametrize("offset", [(0.1, -0.05), (-0.2, 0.15), (0.0, 0.3)])
def test_isotropic_star_centre_returns_to_the_centre(offset):
    A = qmesh.Anisotropy.constant(np.eye(2))
    P = np.vstack([offset, RING])
    assert np.all(signed_areas(P, STAR) > 0)
    Pn, d = step_star(P, A)
    np.testing.assert_allclose(Pn[0], [0.0, 0.0], atol=1e-12)
    np.testing.assert_array_equal(Pn[1:], RING)
    np.testing.assert_allclose(d[0], -np.asarray(offset), atol=1e-12)


def test_relaxed_step_moves_half_way():
    """α = ½ (2.92): half the Newton step."""
    A = qmesh.Anisotropy.constant(np.eye(2))
    P = np.vstack([(0.1, -0.05), RING])
    Pn, _ = step_star(P, A, alpha=0.5)
    np.testing.assert_allclose(Pn[0], [0.05, -0.025], atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(k1=st.floats(-2, 2).map(lambda e: 10.0 ** e), ratio=st.floats(0, 3).map(lambda e: 10.0 ** e),
       angle=st.floats(0, 180), cx=st.floats(-2, 2), cy=st.floats(-2, 2),
       u=st.floats(-0.3, 0.3), v=st.floats(-0.3, 0.3))
def test_anisotropic_star_centre_returns_to_the_centre(k1, ratio, angle, cx, cy, u, v):
    """The star mapped by H^{-1/2} (regular in metric space), centred anywhere (affine invariance)."""
    A = qmesh.Anisotropy.principal(k1, k1 * ratio, angle)
    M = inverse_sqrt(A.H)
    c = np.array([cx, cy])
    P = np.vstack([c + M @ [u, v], c + RING @ M.T])
    assert np.all(signed_areas(P, STAR) > 0)
    Pn, _ = step_star(P, A)
    # compare in the star's own (metric) coordinates, where the ring has radius 1
    err = np.linalg.solve(M, Pn[0] - c)
    np.testing.assert_allclose(err, [0.0, 0.0], atol=1e-12)
    np.testing.assert_array_equal(Pn[1:], P[1:])


def perturbed_mesh(A, seed, amount=0.25):
    """A Q-Delaunay mesh of Disk(16) whose interior vertices are pushed off their optimum.

    Each interior vertex moves by up to `amount` of its smallest height (distance to the edge
    opposite it in any of its triangles), so no triangle inverts; the connectivity is then kept.
    """
    rng = np.random.default_rng(seed)
    D = qmesh.Disk(16)
    r, t = 0.9 * np.sqrt(rng.random(60)), 2 * np.pi * rng.random(60)
    P = np.vstack([D.seeds, np.column_stack([r * np.cos(t), r * np.sin(t)])])
    T = lower_hull(P, A)
    fixed = np.arange(len(P)) < 16
    X = P[T]
    opposite = np.linalg.norm(X[:, [2, 0, 1]] - X[:, [1, 2, 0]], axis=2)      # (M, 3)
    heights = 2 * signed_areas(P, T)[:, None] / opposite
    smallest = np.full(len(P), np.inf)
    np.minimum.at(smallest, T.ravel(), heights.ravel())
    d = rng.uniform(-1, 1, (len(P), 2)) * (amount / np.sqrt(2) * smallest)[:, None]
    d[fixed] = 0.0
    Pp = P + d
    assert np.all(signed_areas(Pp, T) > 0)
    return Pp, T, fixed


ANISOTROPIES = {
    "chapter": lambda: qmesh.Anisotropy.constant(qmesh.CHAPTER_Q),
    "isotropic": lambda: qmesh.Anisotropy.constant(np.eye(2)),
    "rotated": lambda: qmesh.Anisotropy.principal(1.0, 50.0, 30.0),
    "exp_plus_y2": exp_plus_y2,
}


@pytest.mark.parametrize("name", ANISOTROPIES)
@pytest.mark.parametrize("alpha", [0.5, 1.0])
@pytest.mark.parametrize("seed", range(4))
def test_one_vertex_step_does_not_increase_energy(name, alpha, seed):
    A = ANISOTROPIES[name]()
    P, T, fixed = perturbed_mesh(A, seed)
    E0 = triangle_energy(P, T, A).sum()
    Pn, d = adjust.vertex_step(P, T, A, fixed=fixed, tangent=np.zeros_like(P), alpha=alpha)
    E1 = triangle_energy(Pn, T, A).sum()
    assert E1 <= E0 * (1 + 1e-12)
    assert E1 < E0                               # it is perturbed, so the step must gain something
    np.testing.assert_array_equal(Pn[fixed], P[fixed])
    np.testing.assert_array_equal(d[fixed], 0.0)
    np.testing.assert_allclose(Pn, P + d, rtol=0, atol=1e-15)
    assert np.all(signed_areas(Pn, T) > 0)
    assert energy(qmesh.Mesh(Pn, T, fixed), A) == pytest.approx(E1, rel=1e-12)


def finite_difference_gradient(P, T, A, vertices, eps):
    """Central differences of E = Σ_T triangle_energy (the domain is fixed, so ∫s is constant)."""
    g = np.zeros((len(vertices), 2))
    for n, i in enumerate(vertices):                # test helper: loops are fine here
        for j in range(2):
            Xp, Xm = P.copy(), P.copy()
            Xp[i, j] += eps
            Xm[i, j] -= eps
            g[n, j] = (triangle_energy(Xp, T, A).sum() - triangle_energy(Xm, T, A).sum()) / (2 * eps)
    return g


@pytest.mark.parametrize("name,rtol", [("chapter", 1e-7), ("isotropic", 1e-7), ("rotated", 1e-7),
                                       ("exp_plus_y2", 1e-4)])
def test_energy_gradient_matches_finite_differences(name, rtol):
    """For varying s the quadrature of ∫_T s moves with the vertices, hence the looser tolerance."""
    A = ANISOTROPIES[name]()
    P, T, fixed = perturbed_mesh(A, 0)
    interior = np.flatnonzero(~fixed)
    g = adjust.energy_gradient(P, T, A)
    fd = finite_difference_gradient(P, T, A, interior, eps=1e-6)
    scale = np.abs(fd).max()
    assert scale > 0
    np.testing.assert_allclose(g[interior], fd, rtol=0, atol=rtol * scale)


@pytest.mark.parametrize("name", ANISOTROPIES)
def test_newton_rhs_is_minus_three_gradient_over_star_area(name):
    A = ANISOTROPIES[name]()
    P, T, fixed = perturbed_mesh(A, 1)
    interior = ~fixed
    b, star = adjust.newton_rhs(P, T, A)
    expected_star = np.zeros(len(P))
    np.add.at(expected_star, T.ravel(), np.repeat(signed_areas(P, T), 3))
    np.testing.assert_allclose(star, expected_star, rtol=1e-12)
    g = adjust.energy_gradient(P, T, A)
    expected = -3.0 * g[interior] / star[interior, None]
    np.testing.assert_allclose(b[interior], expected, rtol=0, atol=1e-10 * np.abs(expected).max())


def test_sliding_boundary_vertex_moves_along_its_tangent():
    """A non-seed boundary vertex given a tangent only moves along it."""
    A = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    P, T, fixed = perturbed_mesh(A, 2)
    tangent = np.zeros_like(P)
    k = 5                                              # a seed corner, released to slide
    tangent[k] = (-np.sin(0.3), np.cos(0.3))
    fixed = fixed.copy()
    fixed[k] = False
    _, d = adjust.vertex_step(P, T, A, fixed=fixed, tangent=tangent, alpha=0.5)
    cross = d[k, 0] * tangent[k, 1] - d[k, 1] * tangent[k, 0]
    assert abs(cross) <= 1e-14 * max(np.abs(d[k]).max(), 1.0)
    assert np.abs(d[k]).max() > 0


@settings(max_examples=25, deadline=None)
@given(k1=st.floats(-2, 2).map(lambda e: 10.0 ** e), ratio=st.floats(0, 3).map(lambda e: 10.0 ** e),
       angle=st.floats(0, 180), seed=st.integers(0, 10**6), amount=st.floats(0.05, 0.45))
def test_vertex_step_does_not_increase_energy_for_random_q(k1, ratio, angle, seed, amount):
    A = qmesh.Anisotropy.principal(k1, k1 * ratio, angle)
    P, T, fixed = perturbed_mesh(A, seed, amount)
    E0 = triangle_energy(P, T, A).sum()
    Pn, _ = adjust.vertex_step(P, T, A, fixed=fixed, tangent=np.zeros_like(P), alpha=0.5)
    assert triangle_energy(Pn, T, A).sum() <= E0 * (1 + 1e-12)
    assert np.all(signed_areas(Pn, T) > 0)
    np.testing.assert_array_equal(Pn[fixed], P[fixed])


@pytest.mark.parametrize("name", sorted(ANISOTROPIES))
def test_blocks_of_triangles_change_no_bit_of_the_step(name, monkeypatch):
    """newton_rhs and limit_moves work CHUNK triangles at a time (their memory); any block size
    gives exactly the whole-array result."""
    A = ANISOTROPIES[name]()
    P, T, _ = perturbed_mesh(A, 1)
    d = np.random.default_rng(0).normal(size=P.shape) * 0.05
    whole = adjust.newton_rhs(P, T, A), adjust.limit_moves(P, T, d)
    monkeypatch.setattr(triangles, "CHUNK", 7)
    assert len(triangles.chunks(len(T))) > 3
    blocks = adjust.newton_rhs(P, T, A), adjust.limit_moves(P, T, d)
    for a, b in zip(whole, blocks):
        assert all(np.array_equal(x, y) for x, y in zip(a, b))
