"""qmesh_view.maximum_principle: u_h stays in [0, 1] on a mesh whose every q_ij ≥ 0, leaves it on
a mesh obtuse in Q's metric, and the isotropic mesh of the same N fills the same domain."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

import qmesh
from qmesh import measure
from qmesh.errors import QmeshError
from qmesh.geometry.triangles import signed_areas
from qmesh_view import maximum_principle as mp
from qmesh_view.controller import Controller


def grid(n: int) -> qmesh.Mesh:
    """The unit square in n × n cells, each cut by its diagonal from lower left to upper right."""
    x = np.linspace(0.0, 1.0, n + 1)
    P = np.column_stack([a.ravel() for a in np.meshgrid(x, x)])
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n)))
    a, b, c, d = j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1, (j + 1) * (n + 1) + i
    return qmesh.Mesh(P, np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])]))


def ccw(P, T):
    T = np.array(T)
    flip = signed_areas(P, T) < 0
    T[flip] = T[flip][:, ::-1]
    return T


def interior_q(mesh, conductivity):
    """q_ij of the edges with an interior end: the ones the maximum principle depends on."""
    edges, q, _ = measure.edge_weights(mesh, conductivity)
    return q[~np.all(mesh.boundary[edges], axis=1)]


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(0.05, 0.95), st.floats(0.05, 0.95)), min_size=1, max_size=40,
                unique=True),
       st.floats(0.01, 100.0), st.floats(0.01, 100.0), st.floats(0.0, 180.0))
def test_every_q_nonnegative_keeps_u_in_0_1(inner, k1, k2, angle):
    """A mesh Delaunay in Q's metric (Delaunay in y, mapped by x = Q^½ y, where −div(Q∇u)
    becomes a Laplacian) has every q_ij ≥ 0 on an edge with an interior end: no vertex
    leaves [0, 1]."""
    side = np.linspace(0.0, 1.0, 7)[:-1]
    square = np.concatenate([np.column_stack([side, 0 * side]), np.column_stack([1 + 0 * side, side]),
                             np.column_stack([1 - side, 1 + 0 * side]),
                             np.column_stack([0 * side, 1 - side])])
    Y = np.concatenate([square, np.array(inner)])
    T = Delaunay(Y).simplices
    assume(np.abs(signed_areas(Y, T)).min() > 1e-6)
    A = qmesh.Anisotropy.principal(k1, k2, angle)
    w, V = np.linalg.eigh(A.matrix)
    X = Y @ ((V * np.sqrt(w)) @ V.T).T
    mesh = qmesh.Mesh(X, ccw(X, T))
    q = interior_q(mesh, A)
    assert q.min() >= -1e-9 * np.abs(q).max()
    solution = mp.solve(mesh, A)
    assert solution.n_outside == 0
    assert solution.u.min() >= -mp.TOLERANCE and solution.u.max() <= 1 + mp.TOLERANCE
    fixed, values = mp.dirichlet_data(mesh)
    np.testing.assert_array_equal(solution.u[fixed], values)
    assert 0 < values.sum() < len(values)                   # steep: both values on the boundary


def test_a_mesh_obtuse_in_q_metric_leaves_0_1():
    """Right triangles are fine for Q = I and obtuse in the metric of a 1000 : 1 Q at 60°: the
    same mesh, the same data, and u_h overshoots and undershoots."""
    mesh = grid(16)
    assert mp.solve(mesh, qmesh.Anisotropy.constant(np.eye(2))).n_outside == 0
    A = qmesh.Anisotropy.principal(1.0, 1e-3, 60.0)
    assert interior_q(mesh, A).min() < 0
    solution = mp.solve(mesh, A)
    outside = (solution.u < -mp.TOLERANCE) | (solution.u > 1 + mp.TOLERANCE)
    assert solution.n_outside == outside.sum() > 0
    assert solution.n_below > 0 and solution.n_above > 0
    assert solution.n_below + solution.n_above == solution.n_outside
    assert not mesh.boundary[solution.outside].any()        # the boundary keeps its data


def test_the_tolerance_counts_round_off_as_inside():
    A = qmesh.Anisotropy.principal(1.0, 1e-3, 60.0)
    u = mp.solve(grid(16), A).u
    worst = max(-u.min(), u.max() - 1)
    assert mp.solve(grid(16), A, tolerance=worst * 1.01).n_outside == 0


@pytest.mark.parametrize("tolerance", [-1e-9, float("nan"), 1.0])
def test_a_bad_tolerance_is_refused(tolerance):
    with pytest.raises(QmeshError, match="tolerance"):
        mp.solve(grid(2), qmesh.Anisotropy.constant(np.eye(2)), tolerance=tolerance)


def test_an_empty_mesh_is_refused():
    empty = qmesh.Mesh(np.zeros((3, 2)), np.zeros((0, 3), np.int64))
    with pytest.raises(QmeshError, match="mesh"):
        mp.solve(empty, qmesh.Anisotropy.constant(np.eye(2)))
    with pytest.raises(QmeshError, match="mesh"):
        mp.isotropic_mesh(empty)


@pytest.fixture(scope="module")
def holed():
    run = Controller(domain="square with hole", target_vertices=400, k1=0.05, k2=5.0, angle=30.0)
    run.finish()
    return run


def test_the_isotropic_mesh_fills_the_same_domain_with_the_same_n(holed):
    mesh = holed.current.mesh
    iso = mp.isotropic_mesh(mesh)
    assert iso.n_vertices == mesh.n_vertices
    assert np.all(signed_areas(iso.points, iso.triangles) > 0)
    area = lambda m: np.abs(signed_areas(m.points, m.triangles)).sum()   # noqa: E731
    assert area(iso) == pytest.approx(area(mesh), rel=1e-9)             # the hole stays open
    assert holed.domain.contains(iso.points[iso.triangles].mean(axis=1)).all()
    ours = {tuple(p) for p in mesh.points[mesh.boundary].tolist()}
    assert {tuple(p) for p in iso.points[iso.boundary].tolist()} == ours
    lengths = np.hypot(*(iso.points[iso.triangles[:, 1]] - iso.points[iso.triangles[:, 0]]).T)
    assert lengths.max() < 6 * np.median(lengths)                   # no direction, no size preferred


def test_compare_on_a_constant_q(holed):
    """qmesh's mesh keeps the principle, the isotropic one of the same N breaks it."""
    result = mp.compare(holed.current.mesh, holed.anisotropy)
    assert result.mesh.n_outside == 0 and result.isotropic.n_outside > 0
    assert result.isotropic.mesh.n_vertices == holed.current.mesh.n_vertices
    assert mp.cached(holed.current.mesh, holed.anisotropy).isotropic.n_outside == \
        result.isotropic.n_outside
    again = mp.cached(holed.current.mesh, holed.anisotropy)
    assert mp.cached(holed.current.mesh, holed.anisotropy) is again     # solved once


def test_a_medium_isotropic_mesh_takes_the_nearest_region():
    run = Controller(domain="layered", target_vertices=600)
    run.finish()
    mesh = run.current.mesh
    iso = mp.isotropic_mesh(mesh)
    assert set(np.unique(iso.region_tags)) == set(np.unique(mesh.region_tags))
    result = mp.compare(mesh, run.anisotropy)
    assert result.mesh.n_outside == 0
    assert np.isfinite(result.isotropic.u).all()
