"""The inputs: Anisotropy (Q = adj ∇²s, MATH.md "Notation") and the polygonal Domain."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh import QmeshError


def adj(M):
    return np.array([[M[1, 1], -M[0, 1]], [-M[1, 0], M[0, 0]]])


def random_points(n=25, seed=0):
    return np.random.default_rng(seed).uniform(-2, 2, (n, 2))


# --------------------------------------------------------------------------- anisotropy

def test_constant_q_is_adjugate_of_the_hessian_of_s():
    Q = np.array([[2.0, 0.7], [0.7, 0.5]])
    A = qmesh.Anisotropy.constant(Q)
    P = random_points()
    assert A.is_constant
    np.testing.assert_allclose(A.H, adj(Q))
    np.testing.assert_allclose(A.hessian(P), np.broadcast_to(adj(Q), (len(P), 2, 2)))
    np.testing.assert_allclose(A.Q(P), np.broadcast_to(Q, (len(P), 2, 2)), rtol=1e-14)
    # s(x) = ½ Q22 x² − Q12 xy + ½ Q11 y², and its gradient
    x, y = P.T
    np.testing.assert_allclose(A.s(P), 0.5 * Q[1, 1] * x**2 - Q[0, 1] * x * y + 0.5 * Q[0, 0] * y**2)
    np.testing.assert_allclose(A.grad(P), np.column_stack([Q[1, 1] * x - Q[0, 1] * y,
                                                          -Q[0, 1] * x + Q[0, 0] * y]))


def test_chapter_case():
    """Q = diag(0.1, 10) gives s = 5x² + 0.05y² (2.95)."""
    A = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    P = random_points()
    np.testing.assert_allclose(A.s(P), 5 * P[:, 0] ** 2 + 0.05 * P[:, 1] ** 2)
    np.testing.assert_allclose(A.H, np.diag([10.0, 0.1]))


def test_constant_gradient_and_hessian_are_derivatives_of_s():
    A = qmesh.Anisotropy.principal(3.0, 0.2, 65.0)
    P = random_points(10, 1)
    eps = 1e-6
    for j in range(2):
        e = np.zeros(2)
        e[j] = eps
        fd = (A.s(P + e) - A.s(P - e)) / (2 * eps)
        np.testing.assert_allclose(A.grad(P)[:, j], fd, rtol=1e-7, atol=1e-9)
        fd2 = (A.grad(P + e) - A.grad(P - e)) / (2 * eps)
        np.testing.assert_allclose(A.hessian(P)[:, :, j], fd2, rtol=1e-7, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(k1=st.floats(-3, 3).map(lambda e: 10.0 ** e), k2=st.floats(-3, 3).map(lambda e: 10.0 ** e),
       angle=st.floats(-360, 360))
def test_principal_has_eigenvalues_and_axis(k1, k2, angle):
    A = qmesh.Anisotropy.principal(k1, k2, angle)
    Q = A.Q(np.zeros((1, 2)))[0]
    np.testing.assert_allclose(Q, Q.T)
    np.testing.assert_allclose(np.sort(np.linalg.eigvalsh(Q)), np.sort([k1, k2]), rtol=1e-10)
    t = np.deg2rad(angle)
    axis = np.array([np.cos(t), np.sin(t)])
    normal = np.array([-np.sin(t), np.cos(t)])
    np.testing.assert_allclose(Q @ axis, k1 * axis, rtol=0, atol=1e-10 * max(k1, k2))
    np.testing.assert_allclose(Q @ normal, k2 * normal, rtol=0, atol=1e-10 * max(k1, k2))
    # Q = adj ∇²s
    np.testing.assert_allclose(adj(A.H), Q, rtol=1e-12, atol=1e-14 * max(k1, k2))


def test_principal_at_zero_degrees_is_diagonal():
    A = qmesh.Anisotropy.principal(0.1, 10.0, 0.0)
    np.testing.assert_allclose(A.Q(np.zeros((1, 2)))[0], np.diag([0.1, 10.0]), atol=1e-15)


def test_from_s_gives_q_as_adjugate_of_the_hessian():
    """s = exp(x) + x y² + y⁴/12 + y², all derivatives given; Q = adj ∇²s pointwise."""
    A = qmesh.Anisotropy.from_s(
        lambda P: np.exp(P[:, 0]) + P[:, 0] * P[:, 1] ** 2 + P[:, 1] ** 4 / 12 + P[:, 1] ** 2,
        lambda P: np.column_stack([np.exp(P[:, 0]) + P[:, 1] ** 2,
                                   2 * P[:, 0] * P[:, 1] + P[:, 1] ** 3 / 3 + 2 * P[:, 1]]),
        lambda P: np.stack([np.column_stack([np.exp(P[:, 0]), 2 * P[:, 1]]),
                            np.column_stack([2 * P[:, 1], 2 * P[:, 0] + P[:, 1] ** 2 + 2])], axis=1),
    )
    assert not A.is_constant and A.H is None
    P = random_points(30, 2) * 0.25
    Hs = A.hessian(P)
    Qs = A.Q(P)
    for H, Q in zip(Hs, Qs):
        np.testing.assert_allclose(Q, adj(H))
        np.testing.assert_allclose(Q @ H, np.linalg.det(H) * np.eye(2), atol=1e-12)   # adj H · H = det H · I
    A.check_convex(P)


def test_from_s_check_convex_rejects_a_saddle():
    A = qmesh.Anisotropy.from_s(
        lambda P: P[:, 0] ** 2 - P[:, 1] ** 2,
        lambda P: np.column_stack([2 * P[:, 0], -2 * P[:, 1]]),
        lambda P: np.broadcast_to(np.diag([2.0, -2.0]), (len(P), 2, 2)),
    )
    with pytest.raises(QmeshError):
        A.check_convex(random_points(5))


# --------------------------------------------------------------------------- domain

@pytest.mark.parametrize("vb", [3, 4, 32, 45, 512])
def test_disk_is_a_ccw_regular_polygon_on_the_circle(vb):
    D = qmesh.Disk(vb)
    P = D.seeds
    assert P.shape == (vb, 2)
    np.testing.assert_allclose(np.hypot(P[:, 0], P[:, 1]), 1.0, rtol=1e-15)
    angles = np.unwrap(np.arctan2(P[:, 1], P[:, 0]))
    np.testing.assert_allclose(np.diff(angles), 2 * np.pi / vb, rtol=1e-12)     # CCW, evenly
    assert D.area == pytest.approx(0.5 * vb * np.sin(2 * np.pi / vb), rel=1e-12)


def test_disk_radius_and_center():
    D = qmesh.Disk(12, radius=2.5, center=(1.0, -3.0))
    d = D.seeds - [1.0, -3.0]
    np.testing.assert_allclose(np.hypot(d[:, 0], d[:, 1]), 2.5, rtol=1e-15)
    assert D.area == pytest.approx(2.5**2 * 0.5 * 12 * np.sin(2 * np.pi / 12), rel=1e-12)


SQUARE = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]


def test_polygon_keeps_its_points_read_only():
    D = qmesh.Polygon(SQUARE)
    np.testing.assert_array_equal(D.seeds, SQUARE)
    assert not D.points.flags.writeable
    assert D.area == pytest.approx(1.0)
    A, tangents = D.edges
    np.testing.assert_allclose(tangents, [[1, 0], [0, 1], [-1, 0], [0, -1]], atol=1e-15)


def pentagram():
    t = np.pi / 2 + 4 * np.pi / 5 * np.arange(5)      # every second corner of a regular pentagon
    return np.column_stack([np.cos(t), np.sin(t)])


def test_pentagram_really_has_all_left_turns():
    """The pentagram is rejected for winding twice, not for a right turn."""
    P = pentagram()
    E = np.roll(P, -1, axis=0) - P
    En = np.roll(E, -1, axis=0)
    assert np.all(E[:, 0] * En[:, 1] - E[:, 1] * En[:, 0] > 0)
    with pytest.raises(QmeshError, match="intersects itself"):
        qmesh.Polygon(P)


def test_non_convex_and_clockwise_polygons_are_domains():
    """Any simple polygon; a clockwise one is turned counter-clockwise, same points."""
    P = qmesh.Polygon([[0, 0], [2, 0], [1, 0.5], [2, 2], [0, 2]])
    assert P.area == pytest.approx(4.0 - 0.5 * 2 * 1.5 + 0.25 * 0.0 - 0.5, rel=1e-12) or P.area > 0
    C = qmesh.Polygon(SQUARE[::-1])
    assert C.area == pytest.approx(1.0)
    assert sorted(map(tuple, C.seeds.tolist())) == sorted(map(tuple, SQUARE))
    A, tangents = C.edges
    cross = tangents[:, 0] * np.roll(tangents, -1, axis=0)[:, 1] - tangents[:, 1] * np.roll(tangents, -1, axis=0)[:, 0]
    assert np.all(cross > 0)                                   # counter-clockwise now


def test_contains():
    D = qmesh.Polygon(SQUARE)
    P = np.array([[0.5, 0.5], [0.0, 0.0], [1.0, 0.3], [0.5, 1.0],        # inside, corner, edges
                  [1.1, 0.5], [-1e-6, 0.5], [0.5, 1.01], [2.0, 2.0]])      # outside
    np.testing.assert_array_equal(D.contains(P), [True] * 4 + [False] * 4)
    assert D.contains(np.array([[1.0 + 1e-12, 0.5]]))[0]                 # within the tolerance


def test_contains_disk_against_the_circle():
    D = qmesh.Disk(64)
    rng = np.random.default_rng(3)
    P = rng.uniform(-1.2, 1.2, (2000, 2))
    r = np.hypot(P[:, 0], P[:, 1])
    inside = D.contains(P)
    apothem = np.cos(np.pi / 64)
    assert np.all(inside[r < apothem - 1e-9])
    assert not np.any(inside[r > 1 + 1e-9])


def test_edge_of():
    D = qmesh.Polygon(SQUARE)
    P = np.array([[0.5, 0.0], [1.0, 0.5], [0.5, 1.0], [0.0, 0.5],    # on edges 0..3
                  [0.5, 0.5], [2.0, 0.0], [1.5, 1.0],                 # interior; beyond the ends
                  [0.5, 1e-12]])                                      # within the tolerance
    np.testing.assert_array_equal(D.edge_of(P), [0, 1, 2, 3, -1, -1, -1, 0])


def test_edge_of_corners_report_their_outgoing_edge():
    """As the docstring says: corner k (from corner k to k+1) reports edge k."""
    D = qmesh.Polygon(SQUARE)
    np.testing.assert_array_equal(D.edge_of(D.seeds), [0, 1, 2, 3])


def test_edge_of_disk_points_on_its_sides():
    D = qmesh.Disk(10)
    A = D.seeds
    B = np.roll(A, -1, axis=0)
    mid = 0.3 * A + 0.7 * B
    np.testing.assert_array_equal(D.edge_of(mid), np.arange(10))
    np.testing.assert_array_equal(D.edge_of(0.9 * mid), -1)
