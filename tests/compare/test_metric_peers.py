"""Peers for any domain and a varying s (qmesh.compare.metric_peers) and their two measurements."""

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh import measure
from qmesh.compare import metric_peers, peers
from qmesh.geometry.triangles import signed_areas

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "core"))
from cases import locally_regular  # noqa: E402  (the lifted in-circle test, written independently)

ROTATED = qmesh.Anisotropy.principal(100.0, 1.0, 30.0)
DOMAINS = {"L-shape": qmesh.domains.lshape, "square with hole": qmesh.domains.square_with_hole,
           "plate with holes": qmesh.domains.plate_with_holes}


def _on_segments(domain, P, tol=1e-9):
    """Distance of each point to the nearest boundary segment is ≤ tol."""
    A, B = domain.segment_ends
    E = B - A
    t = np.clip(np.einsum("nsi,si->ns", P[:, None] - A[None], E) / np.einsum("si,si->s", E, E), 0, 1)
    d = np.linalg.norm(P[:, None] - (A[None] + t[..., None] * E[None]), axis=2)
    return d.min(axis=1) <= tol


def _check_mesh_of(domain, mesh):
    assert np.all(signed_areas(mesh.points, mesh.triangles) > 0)
    assert signed_areas(mesh.points, mesh.triangles).sum() == pytest.approx(domain.area, rel=1e-9)
    assert mesh.fixed.sum() == len(domain.seeds)
    dist, _ = cKDTree(mesh.points[mesh.fixed]).query(domain.seeds)
    assert dist.max() <= 1e-12
    assert np.all(_on_segments(domain, mesh.points[mesh.boundary]))
    assert np.all(domain.contains(mesh.points))


@pytest.mark.parametrize("name", list(DOMAINS))
def test_stretched_triangle_lands_on_n_with_every_q_nonnegative(name):
    domain = DOMAINS[name]()
    pm = metric_peers.stretched_triangle(domain, ROTATED, 600)
    assert abs(pm.mesh.n_vertices - 600) <= 0.03 * 600
    _check_mesh_of(domain, pm.mesh)
    # conforming Delaunay in the metric: every interior and every boundary q_ij ≥ 0
    assert measure.q_nonnegative_fraction(pm.mesh, ROTATED) == 1.0
    assert measure.q_nonnegative_fraction_boundary(pm.mesh, ROTATED) == 1.0


@pytest.mark.parametrize("name", list(DOMAINS))
def test_mmg2d_with_a_varying_metric_lands_on_n_and_keeps_the_domain(name):
    reason = peers.available()["mmg2d"]
    if reason:
        pytest.skip(f"optional peer not installed: {reason}")
    domain = DOMAINS[name]()
    A = qmesh.Anisotropy.from_expression("exp(x) + 3*y**2")
    pm = metric_peers.mmg2d(domain, A, 500)
    assert abs(pm.mesh.n_vertices - 500) <= 0.03 * 500
    _check_mesh_of(domain, pm.mesh)
    assert pm.mesh.boundary.sum() > len(domain.seeds)            # MMG may split the sides


def test_start_mesh_uses_only_the_domain_points_and_leaves_holes_open():
    domain = qmesh.domains.plate_with_holes()
    P, T = metric_peers.start_mesh(domain)
    np.testing.assert_array_equal(P, domain.seeds)
    assert np.abs(signed_areas(P, T)).sum() == pytest.approx(domain.area, rel=1e-12)
    assert np.all(domain.contains(P[T].mean(axis=1)))


def test_calibrate_converges_on_a_power_law():
    calls = []

    def once(h):                                     # N = 10 fixed + 40/h², as a 2-D mesher
        calls.append(h)
        n = 10 + int(round(40 / h**2))
        return qmesh.Mesh(np.random.default_rng(0).random((n, 2)), np.array([[0, 1, 2]]))

    pm = peers.calibrate(once, 1.0, 1000, 10, rtol=0.01)
    assert abs(pm.mesh.n_vertices - 1000) <= 10
    assert pm.h == pytest.approx(np.sqrt(40 / 990), rel=0.01) and len(calls) <= 3


@settings(max_examples=25, deadline=None, derandomize=True)
@given(seed=st.integers(0, 10_000))
def test_sh_convex_fraction_agrees_with_the_lifted_incircle_test(seed):
    rng = np.random.default_rng(seed)
    P = np.vstack([qmesh.Disk(12).seeds, 0.9 * (rng.random((30, 2)) - 0.5)])
    from scipy.spatial import Delaunay
    T = Delaunay(P).simplices                      # Euclidean Delaunay: not Q-Delaunay for this s
    T[signed_areas(P, T) < 0] = T[signed_areas(P, T) < 0][:, [0, 2, 1]]
    mesh = qmesh.Mesh(P, T)
    A = qmesh.Anisotropy.from_expression("exp(3*x) + 5*y**2 + x*y")
    margin = locally_regular(P, T, A)              # one value per half-edge, both signs alike
    expected = np.mean(margin >= -1e-9)
    assert measure.sh_convex_fraction(mesh, A) == pytest.approx(expected, abs=1e-12)


def test_qmesh_mesh_is_convex_for_sh_and_a_flip_breaks_it():
    A = qmesh.Anisotropy.from_expression("log(exp(2*x) + exp(-2*x) + exp(2*y))")
    m = qmesh.mesh(qmesh.Disk(16), A, target_vertices=80, seed=0)
    assert measure.sh_convex_fraction(m, A) == 1.0
    # flip one interior edge: it becomes the only edge across which s_h is concave
    from qmesh.geometry import topology
    twin = topology.twins(m.triangles)
    h = int(np.flatnonzero(twin >= 0)[0])
    T, _ = topology.flip(m.triangles.copy(), twin.copy(), np.array([h]))
    flipped = qmesh.Mesh(m.points, T)
    n_interior = int((twin >= 0).sum() // 2)
    assert measure.sh_convex_fraction(flipped, A) == pytest.approx(1 - 1 / n_interior)
