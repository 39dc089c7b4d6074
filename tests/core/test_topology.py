"""Half-edge adjacency and the batched local edits (flip, triangle split, boundary-edge split).

After every edit the incrementally maintained twin array must equal `twins(T)` recomputed from
scratch, triangles must stay counter-clockwise, and the total area must not change.
"""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

from qmesh.geometry import topology
from qmesh.geometry.triangles import signed_areas
from qmesh.mesher.triangulate import orient_ccw

SETTINGS = settings(max_examples=40, deadline=None)


def random_triangulation(n: int, seed: int):
    """Points in the unit square and their Delaunay triangulation, counter-clockwise."""
    P = np.random.default_rng(seed).random((n, 2))
    return P, orient_ccw(P, Delaunay(P).simplices)


def half_edges(T):
    """Start and end vertex of every half-edge h = 3t + e."""
    return T.ravel(), T[:, [1, 2, 0]].ravel()


def edge_counts(T):
    """How many triangles share each undirected edge, keyed by (min, max)."""
    a, b = half_edges(T)
    _, inverse, counts = np.unique(np.sort(np.column_stack([a, b]), axis=1), axis=0,
                                   return_inverse=True, return_counts=True)
    return counts[inverse.ravel()]


def triples(T) -> set:
    return set(map(tuple, np.sort(T, axis=1).tolist()))


def assert_consistent(P, T, twin, area):
    np.testing.assert_array_equal(twin, topology.twins(T))
    assert np.all(signed_areas(P, T) > 0)
    assert signed_areas(P, T).sum() == pytest.approx(area, rel=1e-12)


@SETTINGS
@given(n=st.integers(4, 150), seed=st.integers(0, 10**6))
def test_twins_pairs_interior_edges_and_marks_boundary(n, seed):
    P, T = random_triangulation(n, seed)
    twin = topology.twins(T)
    assert twin.shape == (3 * len(T),)
    a, b = half_edges(T)
    inner = twin >= 0
    h = np.flatnonzero(inner)
    # an involution without fixed points, joining the same edge run the other way
    np.testing.assert_array_equal(twin[twin[h]], h)
    assert np.all(twin[h] != h)
    np.testing.assert_array_equal(a[twin[h]], b[h])
    np.testing.assert_array_equal(b[twin[h]], a[h])
    # -1 exactly on edges that only one triangle has, which are the convex hull's edges
    counts = edge_counts(T)
    np.testing.assert_array_equal(inner, counts == 2)
    hull = Delaunay(P).convex_hull
    assert (~inner).sum() == len(hull)
    assert set(map(tuple, np.sort(np.column_stack([a, b])[~inner], axis=1).tolist())) == \
        set(map(tuple, np.sort(hull, axis=1).tolist()))


@SETTINGS
@given(n=st.integers(4, 150), seed=st.integers(0, 10**6), spread=st.sampled_from([1, 10**6]))
def test_twins_of_shuffled_and_sparsely_numbered_triangles(n, seed, spread):
    """Triangles in any order, vertex numbers so far apart that the sort keys no longer pack
    with their positions (spread 10**6): the same pairs as in the sorted, dense numbering."""
    P, T = random_triangulation(n, seed)
    perm = np.random.default_rng(seed).permutation(len(T))
    twin = topology.twins(T[perm] * spread)
    inner = twin >= 0
    back = np.empty_like(perm)
    back[perm] = np.arange(len(T))
    h = np.arange(3 * len(T))
    ref = topology.twins(T)[3 * perm[h // 3] + h % 3]            # T[perm]'s half-edge h in T
    np.testing.assert_array_equal(inner, ref >= 0)
    np.testing.assert_array_equal(3 * back[ref[inner] // 3] + ref[inner] % 3, twin[inner])


def test_left_of_a_cut_along_the_whole_boundary_is_everything_without_a_search(monkeypatch):
    """A convex domain's hull: every triangle lies on the left, known without the component
    search (which would fail here); a cut along part of the boundary still searches."""
    P, T = random_triangulation(60, 3)
    twin = topology.twins(T)
    boundary = np.flatnonzero(twin < 0)
    searched = []
    real = topology.connected_components
    monkeypatch.setattr(topology, "connected_components",
                        lambda *a, **k: searched.append(1) or real(*a, **k))
    assert topology.left_of(T, twin, boundary).all()
    assert not searched
    assert topology.left_of(T, twin, boundary[:-1]).all()
    assert searched


def test_twins_rejects_an_edge_in_three_triangles():
    T = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    with pytest.raises(ValueError):
        topology.twins(T)


def test_twins_rejects_inconsistent_orientation():
    T = np.array([[0, 1, 2], [0, 1, 3]])       # both run 0→1
    with pytest.raises(ValueError):
        topology.twins(T)


def flippable(P, T, twin):
    """Interior half-edges whose quadrilateral is strictly convex, at most one per triangle."""
    h = np.flatnonzero(twin > np.arange(len(twin)))             # one half-edge per interior edge
    t1, e1 = np.divmod(h, 3)
    t2, e2 = np.divmod(twin[h], 3)
    u, v, a = T[t1, e1], T[t1, (e1 + 1) % 3], T[t1, (e1 + 2) % 3]
    b = T[t2, (e2 + 2) % 3]
    # after the flip (u, b, a) and (b, v, a) must both be counter-clockwise (and not thin)
    ok = (signed_areas(P, np.column_stack([u, b, a])) > 1e-9) & \
         (signed_areas(P, np.column_stack([b, v, a])) > 1e-9)
    chosen, used = [], np.zeros(len(T), bool)
    for k in np.flatnonzero(ok):                                # test helper: a greedy matching
        if not used[t1[k]] and not used[t2[k]]:
            used[t1[k]] = used[t2[k]] = True
            chosen.append(h[k])
    return np.array(chosen, dtype=np.int64)


@SETTINGS
@given(n=st.integers(5, 150), seed=st.integers(0, 10**6))
def test_flip_keeps_twins_orientation_and_area(n, seed):
    P, T = random_triangulation(n, seed)
    twin = topology.twins(T)
    area = signed_areas(P, T).sum()
    h = flippable(P, T, twin)
    assume(len(h) > 0)
    T_in, twin_in = T.copy(), twin.copy()
    a, b = half_edges(T)
    old_edges = set(map(tuple, np.sort(np.column_stack([a[h], b[h]]), axis=1).tolist()))
    T2, twin2 = topology.flip(T, twin, h)
    assert T2.shape == T.shape
    assert_consistent(P, T2, twin2, area)
    # the flipped edges are gone, and the input was not modified
    a2, b2 = half_edges(T2)
    new_edges = set(map(tuple, np.sort(np.column_stack([a2, b2]), axis=1).tolist()))
    assert not (old_edges & new_edges)
    np.testing.assert_array_equal(T, T_in)
    np.testing.assert_array_equal(twin, twin_in)
    # flipping the new diagonals back restores the original triangles
    added = np.sort(np.column_stack([a2, b2]), axis=1)
    before = set(map(tuple, np.sort(np.column_stack([a, b]), axis=1).tolist()))
    is_new = np.array([tuple(e) not in before for e in added.tolist()])
    back = np.flatnonzero(is_new & (twin2 > np.arange(len(twin2))))
    assert len(back) == len(h)
    T3, twin3 = topology.flip(T2, twin2, back)
    assert triples(T3) == triples(T)
    assert_consistent(P, T3, twin3, area)


def test_flip_of_a_square_swaps_the_diagonal():
    P = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    T = np.array([[0, 1, 2], [0, 2, 3]])
    twin = topology.twins(T)
    h = np.flatnonzero(twin >= 0)[:1]
    T2, twin2 = topology.flip(T, twin, h)
    assert triples(T2) == {(0, 1, 3), (1, 2, 3)}
    assert_consistent(P, T2, twin2, 1.0)


@SETTINGS
@given(n=st.integers(3, 150), seed=st.integers(0, 10**6), frac=st.floats(0.05, 1.0))
def test_split_triangles_keeps_twins_orientation_and_area(n, seed, frac):
    P, T = random_triangulation(n, seed)
    twin = topology.twins(T)
    area = signed_areas(P, T).sum()
    rng = np.random.default_rng(seed)
    t = rng.choice(len(T), size=max(1, int(frac * len(T))), replace=False)
    w = rng.dirichlet([2.0, 2.0, 2.0], size=len(t))              # strictly inside each triangle
    new = np.einsum("kc,kci->ki", w, P[T[t]])
    P2 = np.vstack([P, new])
    T2, twin2 = topology.split_triangles(T, twin, t, len(P) + np.arange(len(t)))
    assert len(T2) == len(T) + 2 * len(t)
    assert_consistent(P2, T2, twin2, area)
    assert np.array_equal(np.unique(T2), np.arange(len(P2)))
    untouched = np.setdiff1d(np.arange(len(T)), t)
    np.testing.assert_array_equal(T2[untouched], T[untouched])


@SETTINGS
@given(n=st.integers(3, 150), seed=st.integers(0, 10**6), frac=st.floats(0.05, 1.0),
       where=st.floats(0.1, 0.9))
def test_split_boundary_edges_keeps_twins_orientation_and_area(n, seed, frac, where):
    P, T = random_triangulation(n, seed)
    twin = topology.twins(T)
    area = signed_areas(P, T).sum()
    bnd = np.flatnonzero(twin < 0)
    # at most one boundary half-edge per triangle
    _, first = np.unique(bnd // 3, return_index=True)
    bnd = bnd[first]
    rng = np.random.default_rng(seed)
    h = rng.choice(bnd, size=max(1, int(frac * len(bnd))), replace=False)
    a, b = half_edges(T)
    new = (1 - where) * P[a[h]] + where * P[b[h]]
    P2 = np.vstack([P, new])
    T2, twin2 = topology.split_boundary_edges(T, twin, h, len(P) + np.arange(len(h)))
    assert len(T2) == len(T) + len(h)
    assert_consistent(P2, T2, twin2, area)
    # the new vertices are on the boundary, and the boundary gained one edge per split
    assert (twin2 < 0).sum() == (twin < 0).sum() + len(h)
    a2, _ = half_edges(T2)
    assert set(np.unique(a2[twin2 < 0])) >= set(range(len(P), len(P2)))


def test_edits_compose():
    """A split, then a boundary split, then flips: the twin array stays exact throughout."""
    P, T = random_triangulation(60, 11)
    twin = topology.twins(T)
    area = signed_areas(P, T).sum()
    t = np.arange(0, len(T), 3)
    P = np.vstack([P, P[T[t]].mean(axis=1)])
    T, twin = topology.split_triangles(T, twin, t, len(P) - len(t) + np.arange(len(t)))
    assert_consistent(P, T, twin, area)
    h = np.flatnonzero(twin < 0)
    _, first = np.unique(h // 3, return_index=True)
    h = h[first]
    a, b = half_edges(T)
    P = np.vstack([P, 0.5 * (P[a[h]] + P[b[h]])])
    T, twin = topology.split_boundary_edges(T, twin, h, len(P) - len(h) + np.arange(len(h)))
    assert_consistent(P, T, twin, area)
    for _ in range(3):
        h = flippable(P, T, twin)
        assert len(h) > 0
        T, twin = topology.flip(T, twin, h)
        assert_consistent(P, T, twin, area)


@SETTINGS
@given(n=st.integers(5, 150), seed=st.integers(0, 10**6), where=st.floats(0.1, 0.9))
def test_split_edges_keeps_twins_orientation_and_area(n, seed, where):
    """Interior edges split at a point on them: each of the two triangles becomes two."""
    P, T = random_triangulation(n, seed)
    twin = topology.twins(T)
    area = signed_areas(P, T).sum()
    h = np.flatnonzero(twin > np.arange(len(twin)))
    assume(len(h) > 0)
    # at most one split edge per triangle (test helper: a greedy matching)
    chosen, used = [], np.zeros(len(T), bool)
    for k in h:
        if not used[k // 3] and not used[twin[k] // 3]:
            used[k // 3] = used[twin[k] // 3] = True
            chosen.append(k)
    h = np.array(chosen, dtype=np.int64)
    a, b = half_edges(T)
    P2 = np.vstack([P, (1 - where) * P[a[h]] + where * P[b[h]]])
    T2, twin2 = topology.split_edges(T, twin, h, len(P) + np.arange(len(h)))
    assert len(T2) == len(T) + 2 * len(h)
    assert_consistent(P2, T2, twin2, area)
    assert (twin2 < 0).sum() == (twin < 0).sum()
    # the split edges are gone
    a2, b2 = half_edges(T2)
    after = set(map(tuple, np.sort(np.column_stack([a2, b2]), axis=1).tolist()))
    assert not after & set(map(tuple, np.sort(np.column_stack([a[h], b[h]]), axis=1).tolist()))


@SETTINGS
@given(n=st.integers(4, 150), seed=st.integers(0, 10**6), frac=st.floats(0.0, 0.5))
def test_remove_triangles_keeps_twins(n, seed, frac):
    P, T = random_triangulation(n, seed)
    twin = topology.twins(T)
    rng = np.random.default_rng(seed)
    t = rng.choice(len(T), size=int(frac * len(T)), replace=False)
    keep = np.ones(len(T), bool)
    keep[t] = False
    T2, twin2 = topology.remove_triangles(T, twin, t)
    # the same rows, unchanged (the last rows fill the holes, so the order may differ)
    assert sorted(map(tuple, T2.tolist())) == sorted(map(tuple, T[keep].tolist()))
    np.testing.assert_array_equal(twin2, topology.twins(T2))
    assert signed_areas(P, T2).sum() == pytest.approx(signed_areas(P, T[keep]).sum(), rel=1e-12)
