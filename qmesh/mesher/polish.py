"""Boundary vertices removed where they leave a badly shaped fan: a local repair after a run.

A boundary edge split late in a run sized by a vertex count (insert.py: an edge a hair longer
than h, split while the last of the budget is spent) leaves two half-length boundary edges under
one far apex, a fan of metric quality ~0.5 that the vertex step cannot reshape: sliding the
boundary vertices only trades one short edge for another. Removing such a vertex onto a
neighbour on the same straight edge (an edge collapse) gives back the spacing the interior has.
A collapse is made only when it raises the worst quality of the two vertices' stars, and kept
only when afterwards (flips to Q-Delaunay) no boundary edge is encroached, so every boundary
share of q_ij stays ≥ 0 (GEOMETRY.md §1), and the triangles it made are better than those it
removed. The media path mends each face's run on Ω's own edges (an interface's vertices are its
neighbour's too).
"""

from __future__ import annotations

import numpy as np

from qmesh.geometry import topology
from qmesh.geometry.topology import NXT, PRV
from qmesh.geometry.triangles import metric_hessians, metric_quality, signed_areas
from qmesh.mesher.conform import encroached
from qmesh.mesher.triangulate import restore
from qmesh.triangle_mesh import Mesh

POOR = 0.6        # a boundary vertex whose fan is worse than this may be removed
PASSES = 4        # rounds of collapses (a collapse waits for a better one it touches)
ROUNDS = 3        # attempts, each without the collapses next to an edge the last one encroached
STRAIGHT = 1e-9   # |cross| / length² below which three boundary points lie on one straight edge


def collapse_poor_fans(mesh: Mesh, anisotropy, sliding: np.ndarray) -> Mesh:
    """`mesh` with the boundary vertices of poor fans removed where that helps (see the module).
    `sliding[tag]`: whether vertices inside boundary edges of that tag may go (False for an edge
    another mesh shares). Input points (`mesh.fixed`) stay; the other vertices keep their order.
    Up to PASSES passes: a collapse deferred for a better neighbour's may be made next."""
    for _ in range(PASSES):
        mended = _pass(mesh, anisotropy, sliding)
        if mended is mesh:
            break
        mesh = mended
    return mesh


def _pass(mesh: Mesh, anisotropy, sliding: np.ndarray) -> Mesh:
    """One round of independent collapses."""
    P, T, n = mesh.points, mesh.triangles, mesh.n_vertices
    q = _quality(P, T, anisotropy)
    stars = _Stars(T, n)
    v, u, a, b, w, tag_out = _candidates(mesh, anisotropy, sliding, q)
    v, u, near, near_of = _chosen(P, T, stars, q, anisotropy, v, u, a, b, w)
    for _ in range(ROUNDS):
        if not len(v):
            break
        out, bad = _collapsed(mesh, anisotropy, q, v, u, tag_out)
        if bad is None:
            return out
        drop = np.zeros(len(v), bool)
        drop[near_of[np.isin(near, bad)]] = True
        if not drop.any():
            break
        keep, stays = ~drop, ~drop[near_of]
        v, u, near, near_of = v[keep], u[keep], near[stays], (np.cumsum(keep) - 1)[near_of[stays]]
    return mesh


class _Stars:
    """The corners (3 t + position) at each vertex, as one sorted index."""

    def __init__(self, T: np.ndarray, n: int) -> None:
        self.order = np.argsort(T.ravel(), kind="stable")
        self.first = np.searchsorted(T.ravel()[self.order], np.arange(n + 1))

    def corners(self, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(which of V, corner) for every corner at a vertex of V."""
        count = self.first[V + 1] - self.first[V]
        owner = np.repeat(np.arange(len(V)), count)
        at = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
        return owner, self.order[np.repeat(self.first[V], count) + at]


def _quality(P, T, anisotropy) -> np.ndarray:
    return metric_quality(P, T, metric_hessians(anisotropy, P, T))


def _candidates(mesh: Mesh, anisotropy, sliding, q):
    """Boundary vertices v (not input points, inside a straight run of edges of one sliding tag)
    whose fan is worse than POOR, twice each: removed onto u = its predecessor a, then onto its
    successor b; w the apex of the edge that stays (a→v's when u = b, v→b's when u = a); and the
    tag of every vertex's outgoing boundary edge."""
    P, T, n = mesh.points, mesh.triangles, mesh.n_vertices
    twin = topology.twins(T)
    hb = np.flatnonzero(twin < 0)
    t, k = np.divmod(hb, 3)
    s, e, apex = T[t, k], T[t, NXT[k]], T[t, PRV[k]]
    key = topology.edge_keys(mesh.boundary_edges[:, 0], mesh.boundary_edges[:, 1], n)
    o = np.argsort(key)
    at = np.minimum(np.searchsorted(key[o], topology.edge_keys(s, e, n)), max(len(key) - 1, 0))
    tag = np.where(key[o][at] == topology.edge_keys(s, e, n), mesh.boundary_tags[o][at], -1)
    tag_out, h_out, h_in = np.full(n, -1), np.full(n, -1), np.full(n, -1)
    tag_out[s], h_out[s], h_in[e] = tag, np.arange(len(hb)), np.arange(len(hb))
    fan = np.full(n, np.inf)
    np.minimum.at(fan, T.ravel(), np.repeat(q, 3))
    one = (np.bincount(s, minlength=n) == 1) & (np.bincount(e, minlength=n) == 1)
    v = np.flatnonzero(one & ~mesh.fixed & (fan < POOR))
    i, j = h_in[v], h_out[v]
    same = (tag[i] == tag[j]) & (tag[i] >= 0)
    ok = same & np.asarray(sliding)[np.clip(tag[i], 0, len(sliding) - 1)] & (tag[i] < len(sliding))
    a, b = s[i], e[j]
    d, f = P[b] - P[a], P[v] - P[a]
    ok &= np.abs(d[:, 0] * f[:, 1] - d[:, 1] * f[:, 0]) <= STRAIGHT * (d * d).sum(axis=1)
    v, i, j, a, b = v[ok], i[ok], j[ok], a[ok], b[ok]
    return (np.concatenate([v, v]), np.concatenate([a, b]), np.concatenate([a, a]),
            np.concatenate([b, b]), np.concatenate([apex[j], apex[i]]), tag_out)


def _chosen(P, T, stars: _Stars, q, anisotropy, v, u, a, b, w):
    """Of the candidate collapses v → u, the better of each v's two where it is valid (no
    triangle inverted, the link condition, the merged edge a→b not encroached by its apex w)
    and raises the worst quality of the stars of v and u; then those whose stars touch no
    better-ranked one's. Returns (v, u, the vertices of their stars, which collapse each is)."""
    n, m = len(P), len(v)
    if not m:
        return v, u, v, v
    ov, cv = stars.corners(v)
    ou, cu = stars.corners(u)
    shared = (T[cv // 3] == u[ov, None]).any(axis=1)
    # v's triangles but the one on edge u–v take u in v's place
    r_own, r_c = ov[~shared], cv[~shared]
    Tn = T[r_c // 3].copy()
    Tn[np.arange(len(r_c)), r_c % 3] = u[r_own]
    good = np.ones(m, bool)
    np.logical_and.at(good, r_own, signed_areas(P, Tn) > 0)
    new = np.full(m, np.inf)
    if len(Tn):
        np.minimum.at(new, r_own, _quality(P, Tn, anisotropy))
    kept = ~(T[cu // 3] == v[ou, None]).any(axis=1)
    np.minimum.at(new, ou[kept], q[cu[kept] // 3])
    old = np.full(m, np.inf)
    np.minimum.at(old, np.concatenate([ov, ou]), q[np.concatenate([cv, cu]) // 3])
    # link condition: v and u have exactly one common neighbour (the apex of edge u–v)
    nv = np.column_stack([np.repeat(ov, 3), T[cv // 3].ravel()])
    nu = np.column_stack([np.repeat(ou, 3), T[cu // 3].ravel()])
    nv = np.unique(nv[(nv[:, 1] != v[nv[:, 0]]) & (nv[:, 1] != u[nv[:, 0]])], axis=0)
    nu = np.unique(nu[(nu[:, 1] != v[nu[:, 0]]) & (nu[:, 1] != u[nu[:, 0]])], axis=0)
    both = np.concatenate([nv, nu])
    both = both[np.lexsort((both[:, 1], both[:, 0]))]
    dup = (both[1:] == both[:-1]).all(axis=1)
    good &= np.bincount(both[1:, 0][dup], minlength=m) == 1
    good &= ~encroached(P[a], P[b], P[w], anisotropy) & (new > old)
    half = m // 2                           # option k and k + half remove the same vertex
    pick = np.where(new[half:] > new[:half], np.arange(half) + half, np.arange(half))
    pick = pick[good[pick]]
    if not len(pick):
        return v[:0], u[:0], v[:0], v[:0]
    # independent: the worst stars first; a collapse goes when it ranks best on all its triangles
    rank = np.empty(len(pick))
    rank[np.argsort(-old[pick], kind="stable")] = np.arange(1, len(pick) + 1)
    where = np.full(m, -1)
    where[pick] = np.arange(len(pick))
    own = np.concatenate([ov, ou])
    sel = where[own] >= 0
    tri, who = np.concatenate([cv, cu])[sel] // 3, where[own[sel]]
    best = np.zeros(len(T))
    np.maximum.at(best, tri, rank[who])
    lost = np.zeros(len(pick), bool)
    lost[who[best[tri] != rank[who]]] = True
    pick = pick[~lost]
    where[:] = -1
    where[pick] = np.arange(len(pick))
    sel = where[own] >= 0
    near_of = np.repeat(where[own[sel]], 3)
    near = T[np.concatenate([cv, cu])[sel] // 3].ravel()
    return v[pick], u[pick], near, near_of


def _collapsed(mesh: Mesh, anisotropy, q, v, u, tag_out):
    """(the mesh with each v removed onto its u and flipped to Q-Delaunay, None) when no boundary
    edge is then encroached and the new triangles beat the old, else (None, the vertices of the
    encroached edges or v where the shapes got worse, in `mesh`'s numbering)."""
    P, T, n = mesh.points, mesh.triangles, mesh.n_vertices
    to = np.arange(n)
    to[v] = u
    T2 = to[T]
    T2 = T2[(T2[:, 0] != T2[:, 1]) & (T2[:, 1] != T2[:, 2]) & (T2[:, 2] != T2[:, 0])]
    keep = np.ones(n, bool)
    keep[v] = False
    old_id = np.flatnonzero(keep)
    new_id = np.cumsum(keep) - 1
    P2 = P[keep]
    T2, twin, _ = restore(P2, new_id[T2], topology.twins(new_id[T2]), anisotropy)
    hb = np.flatnonzero(twin < 0)
    t, k = np.divmod(hb, 3)
    s, e, w = T2[t, k], T2[t, NXT[k]], T2[t, PRV[k]]
    enc = encroached(P2[s], P2[e], P2[w], anisotropy)
    if enc.any():
        return None, old_id[np.concatenate([s[enc], e[enc], w[enc]])]
    before, after = np.sort(T, axis=1), np.sort(old_id[T2], axis=1)
    gone, made = ~_member(before, after), ~_member(after, before)
    q2 = _quality(P2, T2, anisotropy)
    if made.any() and gone.any() and q2[made].min() <= q[gone].min():
        return None, v
    edges = np.column_stack([s, e])
    return Mesh(P2, T2, mesh.fixed[keep], edges, tag_out[old_id[s]], mesh.tag_names), None


def _member(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Which rows of A (sorted triples) are rows of B."""
    both = np.concatenate([A, B])
    o = np.lexsort(both.T[::-1])
    x = both[o]
    same = np.zeros(len(both), bool)
    eq = (x[1:] == x[:-1]).all(axis=1)
    same[o[1:][eq]] = True
    same[o[:-1][eq]] = True
    return same[:len(A)]
