"""measure.monotonicity: the certificate never claims what the exact test (monotone_oracle)
refutes, says "M-matrix" for qmesh's meshes, and "monotone" on hand-made meshes whose matrix has
positive off-diagonals; the evidence names the entries that break it."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.spatial import Delaunay

import qmesh
from qmesh import QmeshError, measure

from monotone_oracle import KINDS, ccw, exact, random_case, rotated


def union_jack(k: int, angle: float = 0.0) -> qmesh.Mesh:
    """A k×k grid of the unit square, rotated by `angle`, each cell cut by a diagonal whose
    direction alternates like a chessboard's colours: every other vertex has no diagonal."""
    x = np.linspace(0.0, 1.0, k)
    X, Y = np.meshgrid(x, x, indexing="ij")
    c, s = np.cos(angle), np.sin(angle)
    P = np.column_stack([X.ravel(), Y.ravel()]) @ np.array([[c, s], [-s, c]])
    v = np.arange(k * k).reshape(k, k)
    a, b, cc, d = v[:-1, :-1].ravel(), v[1:, :-1].ravel(), v[1:, 1:].ravel(), v[:-1, 1:].ravel()
    flip = (np.add.outer(np.arange(k - 1), np.arange(k - 1)) % 2 == 1).ravel()[:, None]
    T = np.vstack([np.where(flip, np.column_stack([a, b, d]), np.column_stack([a, b, cc])),
                   np.where(flip, np.column_stack([b, cc, d]), np.column_stack([a, cc, d]))])
    return qmesh.Mesh(P, ccw(P, T))


def certified_and_exact(mesh, Q):
    cert = measure.monotonicity(mesh, Q)
    return cert, exact(mesh, Q, cert.perturbation)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), kind=st.sampled_from([k for k in KINDS if k != "qmesh"]))
def test_the_certificate_is_never_refuted_by_the_exact_test(seed, kind):
    mesh, Q = random_case(np.random.default_rng(seed), kind)
    cert, truth = certified_and_exact(mesh, Q)
    if str(cert) != "none":
        assert truth.monotone, (str(cert), truth)
    assert cert.perturbation <= 1e-9


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_qmesh_meshes_are_m_matrices(seed):
    mesh, Q = random_case(np.random.default_rng(seed), "qmesh")
    cert, truth = certified_and_exact(mesh, Q)
    assert str(cert) == "M-matrix" and cert.n_positive == cert.n_positive_boundary == 0
    assert truth.monotone


def test_a_union_jack_grid_is_monotone_though_not_an_m_matrix():
    """Q = diag(1, 0.1) turned 0.05 rad off the grid: the diagonals against the turn get
    K_ij > 0; their ends are the vertices with diagonals, and the paths through the other
    corners of the cell (vertices with none) dominate them."""
    mesh, Q = union_jack(12), qmesh.Anisotropy.constant(rotated(0.05, 0.1))
    cert, truth = certified_and_exact(mesh, Q)
    assert str(cert) == "monotone"
    assert cert.n_positive > 0 and cert.n_positive_boundary > 0
    assert truth.monotone and truth.min_inverse > 0
    free = measure.free_vertices(mesh)
    no_diagonal = np.add.outer(np.arange(12), np.arange(12)).ravel() % 2 == 1
    assert set(cert.eliminated.tolist()) <= set(free[no_diagonal[free]].tolist())
    assert measure.report(mesh, Q)["q_nonnegative_fraction"] < 1.0


def test_a_grid_turned_with_q_is_an_m_matrix():
    """Right triangles with legs along Q's principal directions: q_ij = 0 on the diagonals up
    to round-off, which the tolerance takes as 0."""
    angle = 0.3
    mesh = union_jack(9, angle)
    cert = measure.monotonicity(mesh, qmesh.Anisotropy.constant(rotated(angle, 1e-3)))
    assert str(cert) == "M-matrix" and cert.perturbation < 1e-12


def test_a_refuted_mesh_names_its_positive_entries():
    """Q = diag(1, 0.01) turned 0.4 rad off the grid: exactly not monotone, and the pairs
    given as breaking it have K_ij > 0."""
    mesh, Q = union_jack(8), qmesh.Anisotropy.constant(rotated(0.4, 0.01))
    cert, truth = certified_and_exact(mesh, Q)
    assert str(cert) == "none" and not truth.monotone
    K = measure.stiffness(mesh, Q)
    i, j = cert.breaking.T
    assert len(i) == len(cert.excess) > 0
    assert np.all(K[i, j].A1 > 0) and np.all(cert.excess > 0)
    assert not mesh.boundary[i].any()


def test_one_interior_vertex_needs_its_boundary_couplings_nonpositive():
    """A lone interior vertex: A⁻¹ = 1/a > 0 always, so only −A⁻¹B ≥ 0 (B ≤ 0) decides."""
    P = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.3, 0.5]])
    mesh = qmesh.Mesh(P, ccw(P, Delaunay(P).simplices))
    seen = set()
    for angle in np.linspace(0.0, np.pi, 7):
        Q = qmesh.Anisotropy.constant(rotated(angle, 1e-3))
        K = measure.stiffness(mesh, Q).toarray()
        positive = bool((K[4, :4] > 0).any())
        cert, truth = certified_and_exact(mesh, Q)
        assert str(cert) == ("none" if positive else "M-matrix")
        assert truth.monotone == (not positive)
        seen.add(positive)
    assert seen == {True, False}


def test_element_means_and_a_given_conductivity_agree():
    rng = np.random.default_rng(3)
    mesh, Qs = random_case(rng, "means")
    with_means = qmesh.Mesh(mesh.points, mesh.triangles, conductivity=Qs)
    a, b = measure.monotonicity(with_means), measure.monotonicity(mesh, Qs)
    assert str(a) == str(b) and a.n_positive == b.n_positive and np.array_equal(a.breaking, b.breaking)


def test_triangle_and_a_mesh_file(tmp_path):
    triangle = pytest.importorskip("triangle")
    t = triangle.triangulate({"vertices": [[0, 0], [1, 0], [1, 1], [0, 1]]}, "qa0.01")
    P, T = t["vertices"], ccw(t["vertices"], t["triangles"])
    mesh = qmesh.Mesh(P, T)
    Q = qmesh.Anisotropy.constant(rotated(0.7, 1e-2))
    cert, truth = certified_and_exact(mesh, Q)
    assert str(cert) == "none" or truth.monotone
    path = tmp_path / "elsewhere.vtk"
    qmesh.io.write(path, mesh)
    again = measure.monotonicity(qmesh.io.read(path), Q)
    assert str(again) == str(cert) and again.n_positive == cert.n_positive


def test_scaling_q_keeps_the_certificate():
    mesh, Q = union_jack(10), rotated(0.05, 0.1)
    certs = {str(measure.monotonicity(mesh, qmesh.Anisotropy.constant(c * Q))) for c in (1e-3, 1.0, 64.0)}
    assert certs == {"monotone"}


def test_meshes_without_a_positive_definite_matrix():
    P = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    alone = measure.monotonicity(qmesh.Mesh(P, np.array([[0, 1, 2]])))
    assert str(alone) == "M-matrix" and alone.n_interior == 0 and "no interior vertex" in alone.reason
    mesh = union_jack(5)
    Qs = np.tile(np.diag([1.0, -1.0]), (mesh.n_triangles, 1, 1))
    bad = measure.monotonicity(mesh, Qs)
    assert str(bad) == "none" and "not positive definite" in bad.reason


@pytest.mark.parametrize("rtol", [-1e-3, 2.0, float("nan"), "small"])
def test_bad_rtol_is_refused(rtol):
    with pytest.raises(QmeshError, match="rtol"):
        measure.monotonicity(union_jack(4), rtol=rtol)


def test_a_zero_area_triangle_is_refused():
    mesh = union_jack(4)
    P = mesh.points.copy()
    P[5] = P[4]                                  # the triangles with both are flat
    with pytest.raises(QmeshError, match="zero-area"):
        measure.monotonicity(qmesh.Mesh(P, mesh.triangles))
    assert measure.report(qmesh.Mesh(P, mesh.triangles), qmesh.Anisotropy.constant(np.eye(2)))["monotonicity"] is None
