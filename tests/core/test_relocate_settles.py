"""A degree-3 vertex that the insert stage moved is not sent back to the spot it left: where the
metric keeps it at degree 3 wherever it lands, the hole it leaves is the largest triangle of the
next round, and it went back and forth between two spots every round (the loop then never saw a
round that changed nothing)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

import qmesh
from qmesh.geometry import topology
from qmesh.geometry.triangles import metric_hessians, metric_measures
from qmesh.mesher import insert, triangulate

EPSILON = 1e-4


def islands(x, y):
    """Magnetic islands: Q = εI + (1 − ε) b bᵀ/|b|², b = (y − ½, 0.1π cos 2πx), an O- and an
    X-point in the unit square (the callable case of benchmarks/bench_fields.py)."""
    bx, by = y - 0.5, 0.1 * np.pi * np.cos(2 * np.pi * x)
    b2 = bx * bx + by * by
    q11, q22 = EPSILON + (1 - EPSILON) * bx * bx / b2, EPSILON + (1 - EPSILON) * by * by / b2
    q12 = (1 - EPSILON) * bx * by / b2
    return np.stack([np.stack([q11, q12], -1), np.stack([q12, q22], -1)], -2)


def _relocations(steps):
    """(vertex, the spot it left, the spot it went to) of every insert stage's relocations."""
    moves, prev = [], None
    for step in steps:
        if step.stage == "insert" and prev is not None:
            n0 = prev.mesh.n_vertices
            for v in step.added[step.added < n0]:
                moves.append((int(v), prev.mesh.points[v].copy(), step.mesh.points[v].copy()))
        prev = step
    return moves


@pytest.mark.filterwarnings("ignore::qmesh.QmeshWarning")     # the repair's vertices, said
def test_no_vertex_goes_back_to_a_spot_it_left_on_the_islands():
    square = qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])
    steps = list(qmesh.iterate(square, qmesh.TensorField(islands), target_vertices=2000))
    moves = _relocations(steps)
    assert moves                                 # the case relocates vertices
    left: dict[int, list] = {}
    for v, a, b in moves:
        jump = np.linalg.norm(b - a)
        for spot in left.get(v, []):
            assert np.linalg.norm(b - spot) > 0.1 * jump, f"vertex {v} went back"
        left.setdefault(v, []).append(a)
    # the loop stops once rounds change nothing (it took 21 while one vertex went to and fro)
    assert steps[-1].iteration <= 12


def _grid_with_split_largest(k, jitter, seed, Q):
    """A jittered k × k grid's Delaunay triangulation with its largest triangle (in the
    metric of Q) split at its centroid by a new last vertex: (P, T, twin, on_boundary, v)."""
    rng = np.random.default_rng(seed)
    g = np.linspace(0.0, 1.0, k)
    P = np.column_stack([a.ravel() for a in np.meshgrid(g, g)])
    inner = (P > 0).all(axis=1) & (P < 1).all(axis=1)
    P[inner] += jitter / (k - 1) * rng.uniform(-1, 1, (int(inner.sum()), 2))
    T = triangulate.orient_ccw(P, Delaunay(P).simplices)
    A = qmesh.Anisotropy.constant(Q)
    area, quality, _ = metric_measures(P, T, metric_hessians(A, P, T))
    t = int(np.argmax(area / quality))
    v = len(P)
    P = np.vstack([P, P[T[t]].mean(axis=0)])
    a, b, c = T[t]
    T = np.vstack([np.delete(T, t, axis=0), [[a, b, v], [b, c, v], [c, a, v]]])
    on_boundary = np.append(~inner, False)
    return P, T, topology.twins(T), on_boundary, v, A


@settings(max_examples=30, deadline=None)
@given(k=st.integers(5, 12), jitter=st.floats(0.0, 0.3), seed=st.integers(0, 10**6),
       ratio=st.floats(1.0, 100.0), angle=st.floats(0.0, np.pi))
def test_a_vertex_moved_before_does_not_refill_the_hole_it_leaves(k, jitter, seed, ratio, angle):
    """A degree-3 vertex in the largest triangle would leave that triangle, the largest, as a
    hole: moved before, it stays; never moved, it is moved as always."""
    c, s = np.cos(angle), np.sin(angle)
    R = np.array([[c, -s], [s, c]])
    Q = R @ np.diag([1.0, ratio]) @ R.T
    P, T, twin, on_boundary, v, A = _grid_with_split_largest(k, jitter, seed, Q)
    for before in (False, True):
        flag = np.zeros(len(P), bool)
        flag[v] = before
        T2, twin2, P2, moved = insert.relocate_degree3(P, T, twin, A, on_boundary, flag)
        assert (v in moved) is not before
        assert (P2[v] != P[v]).any() is not before
        assert len(T2) == len(T) and (twin2 >= -1).all()
