"""The Q-Delaunay triangulation (MATH.md "Connectivity", chapter (2.74)–(2.75)).

Checked against an independent construction: for constant Q, the lower hull of the lifted
points is the Delaunay triangulation (scipy.spatial.Delaunay) of the points mapped by F with
FᵀF = H = ∇²s. The flip-based `restore` must reach the same triangulation from a wrong one, and
meshes the mesher produces must have q_ij ≥ 0 on every interior edge.
"""

import re

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull, Delaunay

import qmesh
from cases import exp_plus_y2, locally_regular
from qmesh.geometry import topology
from qmesh.geometry.triangles import signed_areas
from qmesh.measure import edge_weights, q_nonnegative_fraction
from qmesh.mesher.triangulate import lower_hull, orient_ccw, restore

# strategies: the smaller principal conductivity, the anisotropy ratio, the angle, a point-set seed
k1s = st.floats(min_value=-2.0, max_value=2.0).map(lambda e: 10.0 ** e)
ratios = st.floats(min_value=0.0, max_value=3.0).map(lambda e: 10.0 ** e)
angles = st.floats(min_value=0.0, max_value=180.0)
seeds = st.integers(min_value=0, max_value=2**32 - 1)
sizes = st.integers(min_value=20, max_value=200)

FAST = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def disk_points(n: int, seed: int) -> np.ndarray:
    """n points uniformly distributed in the unit disk, from a seeded generator."""
    rng = np.random.default_rng(seed)
    r, t = np.sqrt(rng.random(n)), 2 * np.pi * rng.random(n)
    return np.column_stack([r * np.cos(t), r * np.sin(t)])


def triples(T) -> set:
    """A triangulation as a set of sorted vertex triples (orientation and order ignored)."""
    return set(map(tuple, np.sort(np.asarray(T), axis=1).tolist()))


def mapped_delaunay(P: np.ndarray, H: np.ndarray) -> np.ndarray:
    """Delaunay triangulation of x' = Lᵀx with L Lᵀ = H (Cholesky), i.e. |x'|² = xᵀHx."""
    L = np.linalg.cholesky(H)
    return Delaunay(P @ L).simplices       # row x ↦ xᵀL = (Lᵀx)ᵀ


def euclidean_delaunay(P: np.ndarray) -> np.ndarray:
    """The plain Delaunay triangulation, counter-clockwise: valid, but not Q-Delaunay in general."""
    return orient_ccw(P, Delaunay(P).simplices)


@FAST
@given(k1=k1s, ratio=ratios, angle=angles, n=sizes, seed=seeds)
def test_lower_hull_equals_delaunay_of_mapped_points(k1, ratio, angle, n, seed):
    P = disk_points(n, seed)
    A = qmesh.Anisotropy.principal(k1, k1 * ratio, angle)
    T = lower_hull(P, A)
    assert triples(T) == triples(mapped_delaunay(P, A.H))
    assert np.array_equal(np.unique(T), np.arange(n)), "every point must be a vertex"
    assert np.all(signed_areas(P, T) > 0), "triangles must be counter-clockwise"


@FAST
@given(k1=k1s, ratio=ratios, angle=angles, n=sizes, seed=seeds)
def test_lower_hull_of_random_spd_matrix(k1, ratio, angle, n, seed):
    """Built from Q directly (constant), with any factor F, FᵀF = H: the symmetric square root."""
    t = np.deg2rad(angle)
    R = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    Q = R @ np.diag([k1, k1 * ratio]) @ R.T
    A = qmesh.Anisotropy.constant(0.5 * (Q + Q.T))
    w, V = np.linalg.eigh(A.H)
    F = V @ np.diag(np.sqrt(w)) @ V.T                      # H^{1/2}: FᵀF = H
    P = disk_points(n, seed)
    T = lower_hull(P, A)
    assert triples(T) == triples(Delaunay(P @ F.T).simplices)
    assert len(np.unique(T)) == n
    assert np.all(signed_areas(P, T) > 0)


def test_strong_anisotropy_changes_the_triangulation():
    """The restore tests below start from a triangulation that really is wrong."""
    P = disk_points(100, 1)
    A = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    assert triples(euclidean_delaunay(P)) != triples(lower_hull(P, A))


@FAST
@given(k1=k1s, ratio=st.floats(min_value=1.0, max_value=3.0).map(lambda e: 10.0 ** e),
       angle=angles, n=sizes, seed=seeds)
def test_restore_from_euclidean_delaunay_reaches_lower_hull(k1, ratio, angle, n, seed):
    P = disk_points(n, seed)
    A = qmesh.Anisotropy.principal(k1, k1 * ratio, angle)
    T0 = euclidean_delaunay(P)
    T, twin, flips = restore(P, T0, topology.twins(T0), A)
    assert triples(T) == triples(lower_hull(P, A))
    assert flips >= 0
    assert np.all(signed_areas(P, T) > 0)
    np.testing.assert_array_equal(twin, topology.twins(T))


def test_restore_leaves_a_q_delaunay_triangulation_alone():
    P = disk_points(150, 3)
    A = qmesh.Anisotropy.principal(1.0, 300.0, 17.0)
    T0 = lower_hull(P, A)
    T, twin, flips = restore(P, T0, topology.twins(T0), A)
    assert flips == 0
    np.testing.assert_array_equal(T, T0)




@pytest.mark.parametrize("scale", [1.0, 3.0])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_varying_s_lower_hull_and_restore_agree(seed, scale):
    """s = exp(x) + y² on points of a disk of radius `scale` (larger: stronger variation)."""
    P = scale * disk_points(150, seed)
    A = exp_plus_y2()
    T_hull = lower_hull(P, A)
    assert len(np.unique(T_hull)) == len(P)
    assert np.all(signed_areas(P, T_hull) > 0)
    # the lower hull is locally regular on every interior edge (checked from the definition)
    assert locally_regular(P, T_hull, A).min() > -1e-12
    T0 = euclidean_delaunay(P)
    assert triples(T0) != triples(T_hull)
    T, twin, _ = restore(P, T0, topology.twins(T0), A)
    assert triples(T) == triples(T_hull)
    np.testing.assert_array_equal(twin, topology.twins(T))


def test_euclidean_delaunay_is_not_locally_regular_for_strong_anisotropy():
    """The independent check above can fail: it flags the wrong triangulation."""
    P = disk_points(100, 5)
    A = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    assert locally_regular(P, euclidean_delaunay(P), A).min() < -1e-6
    assert locally_regular(P, lower_hull(P, A), A).min() > -1e-12


@settings(max_examples=8, deadline=None)
@given(k1=k1s, ratio=ratios, angle=angles, n=st.integers(60, 150),
       vb=st.integers(8, 32), seed=st.integers(0, 1000))
def test_mesher_output_has_nonnegative_q_ij(k1, ratio, angle, n, vb, seed):
    A = qmesh.Anisotropy.principal(k1, k1 * ratio, angle)
    try:
        m = qmesh.mesh(qmesh.Disk(vb), A, target_vertices=n, seed=seed)
    except qmesh.QmeshError as e:
        # a coarse polygon under strong anisotropy can need more boundary vertices than n to
        # keep every boundary q_ij ≥ 0: refused only with that reason, and only when it is so
        assert re.search(r"target_vertices = \d+ is too few", str(e)), e
        assert ratio >= 10
        return
    _, q, interior = edge_weights(m, A)
    assert interior.any()
    assert (q[interior] / np.abs(q).max()).min() >= -1e-9
    assert q_nonnegative_fraction(m, A) == 1.0


def _strip_points(n: int, width: float, seed: int) -> np.ndarray:
    """n points of the strip [0, 1] × [0, width]: half of them evenly along its two long sides
    (each side's points collinear), the rest at random inside."""
    rng = np.random.default_rng(seed)
    k = n // 4
    x = np.linspace(0.0, 1.0, k)
    inside = rng.random((n - 2 * k, 2)) * [1.0, width]
    return np.vstack([np.column_stack([x, np.zeros(k)]), np.column_stack([x, np.full(k, width)]),
                      inside])


@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(width=st.floats(1e-3, 1e-2), ratio=st.floats(1.0, 1000.0), angle=angles,
       n=st.integers(4100, 6000), seed=seeds)
def test_a_thin_point_set_is_triangulated_in_one_qhull_build(width, ratio, angle, n, seed):
    """Points spread THIN times further along than across in the metric take Qhull's joggled
    2-D Delaunay, once (the joggled lifted hull, tried first before, loses the points of a
    straight side that the joggle moves off its line whenever the strip is thin enough, and was
    then built for nothing), then `restore`: a valid triangulation of every point, locally
    regular on every interior edge."""
    from unittest import mock
    from qmesh.mesher import triangulate
    P = _strip_points(n, width, seed)
    A = qmesh.Anisotropy.principal(1.0, ratio, angle)
    X = P @ np.linalg.cholesky(A.H)
    assume(triangulate._thin(X - X.mean(axis=0)))
    builds = []
    with mock.patch.object(triangulate, "ConvexHull", lambda *a, **k: builds.append("hull") or
                           ConvexHull(*a, **k)), \
            mock.patch.object(triangulate, "Delaunay", lambda *a, **k: builds.append("2-D") or
                              Delaunay(*a, **k)):
        T, twin = triangulate.first_triangulation(P, A)
    assert builds == ["2-D"]
    assert np.all(signed_areas(P, T) > 0)
    assert np.array_equal(np.unique(T), np.arange(len(P)))
    np.testing.assert_array_equal(twin, topology.twins(T))
    assert locally_regular(P, T, A).min() > -1e-9
