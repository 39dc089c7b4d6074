"""Cost follows N for inputs that once did not: ties in the lifting, steep s.

Each case once took tens of seconds or gigabytes. A hang or a return to that cost fails the
test by its pytest-timeout, set loose for a slow shared machine; how fast each case is today
is benchmarks/bench_scale_cases.py's figure, not a test's.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull

import qmesh
from qmesh.errors import QmeshError
from qmesh.geometry.rings import convex_width
from qmesh.mesher.triangulate import first_triangulation, lower_hull
from cases import locally_regular


@pytest.mark.timeout(60)
def test_co_circular_isotropic_disk_beyond_the_exact_hull_is_fast_and_q_delaunay():
    """6000 points on one circle: Qhull's exact 3-D hull merges facets quadratically there."""
    n = 6000
    t = 2 * np.pi * np.arange(n) / n
    inner = np.random.default_rng(1).uniform(-0.6, 0.6, (3000, 2))
    P = np.concatenate([np.column_stack([np.cos(t), np.sin(t)]), inner])
    A = qmesh.Anisotropy.constant(np.eye(2))
    T, twin = first_triangulation(P, A)
    used = np.zeros(len(P), bool)
    used[T.ravel()] = True
    assert used.all()
    assert len(T) == 2 * len(P) - n - 2                   # Euler: a triangulation of the hull
    assert locally_regular(P, T, A).min() > -1e-9


@pytest.mark.parametrize("Q", [np.eye(2), np.diag([0.1, 10.0])])
def test_perturbing_only_the_boundary_still_gives_a_q_delaunay_triangulation(Q):
    """The mesher's call: only the boundary points' heights are perturbed, and for a constant
    Q only their stars are checked by flips; the result must still be locally regular."""
    n = 5000
    t = 2 * np.pi * np.arange(n) / n
    inner = np.random.default_rng(2).uniform(-0.6, 0.6, (2000, 2))
    P = np.concatenate([np.column_stack([np.cos(t), np.sin(t)]), inner])
    A = qmesh.Anisotropy.constant(Q)
    T, _ = first_triangulation(P, A, np.arange(len(P)) < n)
    assert len(T) == 2 * len(P) - n - 2
    assert locally_regular(P, T, A).min() > -1e-9


def test_first_triangulation_equals_the_lower_hull_on_generic_points():
    P = np.random.default_rng(3).random((5000, 2))      # beyond the exact route's size
    A = qmesh.Anisotropy.principal(1.0, 30.0, 25.0)
    T, _ = first_triangulation(P, A)
    key = lambda T: set(map(tuple, np.sort(T, axis=1).tolist()))   # noqa: E731
    assert key(T) == key(lower_hull(P, A))


@pytest.mark.timeout(120)
def test_steep_radial_s_meshes_within_bounded_time():
    m = qmesh.mesh(qmesh.Disk(32), qmesh.Anisotropy.from_expression("(x**2+y**2+1)**20"),
                   target_vertices=600)
    assert abs(m.n_vertices - 600) <= 30


@pytest.mark.timeout(30)
def test_an_s_steeper_than_the_mesh_is_refused_quickly_and_not_called_non_convex():
    with pytest.raises(QmeshError) as e:
        qmesh.mesh(qmesh.Disk(32), qmesh.Anisotropy.from_expression("exp(20*x)+exp(20*y)"),
                   target_vertices=3000)
    assert "varies faster than a mesh" in str(e.value)
    assert "convex" not in str(e.value)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 80),
       sx=st.floats(-3, 3), sy=st.floats(-3, 3))
def test_convex_width_equals_the_all_pairs_width(seed, n, sx, sy):
    P = np.random.default_rng(seed).normal(size=(n + 3, 2)) * [10.0 ** sx, 10.0 ** sy]
    V = P[ConvexHull(P).vertices]
    E = np.roll(V, -1, axis=0) - V
    normal = np.column_stack([-E[:, 1], E[:, 0]]) / np.linalg.norm(E, axis=1)[:, None]
    brute = np.abs(np.einsum("ki,kni->kn", normal, V[None] - V[:, None])).max(axis=1).min()
    assert convex_width(V[::-1] if seed % 2 else V) == pytest.approx(brute, rel=1e-9,
                                                                      abs=1e-12 * np.abs(P).max())
