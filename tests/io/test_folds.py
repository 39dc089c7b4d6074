"""qmesh.geometry.folds: a valid triangulation has none; a turned, doubled or overlapping
triangle is counted (what `qmesh report` shows for a file that could hide one)."""

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

import qmesh
from qmesh.geometry.folds import folded_mask, folded_triangles


def _cross(u, v):
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _delaunay(seed, n):
    P = np.random.default_rng(seed).random((n, 2))
    T = Delaunay(P).simplices
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    T[cw] = T[cw][:, [0, 2, 1]]
    return P, T


@settings(max_examples=30, deadline=None, derandomize=True)
@given(seed=st.integers(0, 10**6), n=st.integers(5, 60), data=st.data())
def test_valid_has_none_and_every_defect_is_counted(seed, n, data):
    P, T = _delaunay(seed, n)
    assume(len(T) >= 3)  # with two triangles, neither is "the other way" than most
    assert folded_triangles(qmesh.Mesh(P, T)) == 0
    k = data.draw(st.integers(0, len(T) - 1))
    turned = T.copy()
    turned[k] = turned[k][[0, 2, 1]]
    assert np.flatnonzero(folded_mask(P, turned)).tolist() == [k]
    doubled = np.vstack([T, T[k][[1, 2, 0]]])  # the same triangle again, same turn
    assert np.flatnonzero(folded_mask(P, doubled)).tolist() == [k, len(T)]
    # a triangle laid over a neighbour's edge from the same side: an overlap
    a, b, c = T[k]
    far = np.argmax(np.linalg.norm(P - P[[a, b]].mean(0), axis=1) * (_cross(P[b] - P[a], P - P[a]) > 0))
    if far not in (a, b, c) and _cross(P[b] - P[a], P[far] - P[a]) > 0:
        over = np.vstack([T, [a, b, far]])
        assert folded_mask(P, over)[[k, len(T)]].all()
