"""A metric without s, before the first Qhull build: the boundary's crowding settled by k-d trees.

`conform._conforming` builds the whole triangulation from scratch (Qhull, then flips into the
local metric) every round that drops an interior point or splits a subsegment that is not yet
an edge; a tensor field paid four such builds at 2e4 vertices (plasma: 139, 104 and 100
encroached subsegments in its first three rounds). This pass reaches, without a triangulation,
the fixed point those rounds head for: interior points inside the diametral ellipse (the metric
at its midpoint, as `conform.encroached` tests it) of a short subsegment are dropped; a subsegment
whose ellipse holds another boundary point (in the metrics of both: the rounds test the apex of
a triangulation flipped in the local metric, and a boundary point far along a needle of the
midpoint's metric, where it has turned, is not that apex; testing it alone split 7% more
boundary points on plasma at 3e3), or (longer than LONG·h) any point, is split at
`conform.split_points`' place and its new point pinned. On the side of Ω only (the side whose
apex the rounds test), until no ellipse holds a point. The rounds that follow then usually build
once and split in place (conform._split_in_place) what the local flips still leave encroached.

An ellipse of metric length L with the metric H is found as the Euclidean disc of its longest
semi-axis ½L/√λ_min(H) (a k-d tree of the points), then tested exactly.
"""

from __future__ import annotations

from itertools import chain

import numpy as np
from scipy.spatial import cKDTree

from qmesh.geometry.portable import eigvalsh2
from qmesh.mesher import conform
from qmesh.mesher.corners import metric_at


def _in_ellipses(P, a, b, ids, anisotropy, tree=None, mutual=False):
    """Pairs (k, j): the point j (one of `ids`) on the left of a[k]→b[k] lies in its diametral
    ellipse, by `conform.encroached`'s test (the metric H at the midpoint, evaluated once per
    subsegment) on the candidates of a k-d tree of P[ids] (`tree`, when given). `mutual`: and
    in the ellipse measured in the metric at j, which a point far along a needle of the
    midpoint's metric, where the metric has turned, is not."""
    none = np.zeros(0, np.int64), np.zeros(0, np.int64)
    if not len(a) or not len(ids):
        return none
    M = 0.5 * (P[a] + P[b])
    E = P[b] - P[a]
    H = metric_at(anisotropy, M)
    L2 = np.einsum("ki,kij,kj->k", E, H, E)
    r = 0.5 * np.sqrt(L2 / np.clip(eigvalsh2(H)[:, 0], 1e-300, None)) * (1 + 1e-9)
    r = np.where(np.isfinite(r), r, 0.0)
    tree = cKDTree(P[ids]) if tree is None else tree
    count = tree.query_ball_point(M, r, return_length=True)
    some = np.flatnonzero(count > 0)
    if not len(some):
        return none
    hits = tree.query_ball_point(M[some], r[some])
    k = np.repeat(some, count[some])
    j = ids[np.fromiter(chain.from_iterable(hits), np.int64, int(count[some].sum()))]
    C = P[j] - P[a[k]]
    left = (j != a[k]) & (j != b[k]) & (E[k, 0] * C[:, 1] - E[k, 1] * C[:, 0] > 0)
    k, j = k[left], j[left]
    D = P[j] - M[k]
    depth = 0.5 * np.einsum("ki,kij,kj->k", D, H[k], D) - 0.125 * L2[k]      # as `encroached`
    enc = depth < -conform.ENCROACH_TOL * L2[k]
    if mutual:
        k, j, D = k[enc], j[enc], D[enc]
        Hj = metric_at(anisotropy, P[j])
        enc = np.einsum("ki,kij,kj->k", D, Hj, D) < 0.25 * np.einsum("ki,kij,kj->k", E[k], Hj, E[k])
    return k[enc], j[enc]


def split_crowded(domain, P, edge_id, anisotropy, size, max_points):
    """(P, edge_id, pinned) with the boundary's crowding settled as the module says (P as
    `conform.conforming_delaunay` takes it: seeds, boundary points, interior points), or None
    when the splits would pass `max_points` (the rounds then find and name the cause)."""
    n_seeds = len(domain.seeds)
    A, Bend = domain.segment_ends
    seg_len2 = np.einsum("ki,ki->k", Bend - A, Bend - A)
    inner = np.flatnonzero((np.arange(len(P)) >= n_seeds) & (edge_id < 0))
    itree = cKDTree(P[inner]) if len(inner) else None
    n_old = 0            # subsegments with an end at or past n_old are new since the last round
    alive = np.ones(len(P), bool)
    pinned = np.zeros(len(P), bool)
    for _ in range(conform.MAX_ROUNDS):
        on = edge_id >= 0
        t = np.zeros(len(P))
        t[on] = np.einsum("ki,ki->k", P[on] - A[edge_id[on]], Bend[edge_id[on]] - A[edge_id[on]]) \
            / seg_len2[edge_id[on]]
        a, b = conform._subsegments(domain, n_seeds, edge_id, t)
        L2 = conform.metric_lengths2(P[a], P[b], anisotropy)
        short = L2 <= (conform.LONG * size) ** 2
        bnd = np.flatnonzero((np.arange(len(P)) < n_seeds) | on)
        # boundary points are only added and interior ones only dropped: the subsegments that
        # stood last round were tested against every point then, and need only the new ones
        fresh = (a >= n_old) | (b >= n_old)
        new, old = np.flatnonzero(fresh), np.flatnonzero(~fresh)
        k1, _ = _in_ellipses(P, a[new], b[new], bnd, anisotropy, mutual=True)
        k2, _ = _in_ellipses(P, a[old], b[old], bnd[bnd >= n_old], anisotropy, mutual=True)
        kb = np.concatenate([new[k1], old[k2]])
        ki, ji = _in_ellipses(P, a[new], b[new], inner, anisotropy, itree)
        live = alive[ji]
        ki, ji = new[ki[live]], ji[live]
        drop = np.unique(ji[short[ki]])
        split = np.zeros(len(a), bool)
        split[kb] = True
        split[ki[~short[ki]]] = True
        split &= L2 > conform.SHORTEST ** 2
        if not len(drop) and not split.any():
            break
        alive[drop] = False
        a, b = a[split], b[split]
        if max_points is not None and int(alive.sum()) + len(a) > max_points:
            return None
        at = conform.split_points(P[a], P[b], a < n_seeds, b < n_seeds, anisotropy)
        n_old = len(P)
        P = np.concatenate([P, at])
        edge_id = np.concatenate([edge_id, np.where(a < n_seeds, a, edge_id[a])])
        pinned = np.concatenate([pinned, np.ones(len(a), bool)])
        alive = np.concatenate([alive, np.ones(len(a), bool)])
    return P[alive], edge_id[alive], pinned[alive]
