"""Point insertion near badly shaped or oversized triangles (chapter Section 2.3.2, (2.94)).

Size and shape are measured in metric space (the triangle mapped by H^{1/2} at its centroid).
A triangle is refined when its metric area exceeds the area threshold (set by the mesher from
the target size or vertex count), or when its quality (2.94) is below the threshold — never when its
metric area is below `min_area` ("Triangles smaller than a preset minimum area are not refined").
Where the point goes is not critical, since the next adjustment moves it (the chapter): interior
triangles are split at their centroid (the metric centroid too, the map being affine); when a
triangle's longest metric edge lies on the domain boundary, that edge is split at its midpoint
instead, which is how vertices appear on the boundary between the seed points. Boundary edges
longer than `boundary_length` (metric) are split as well, so the boundary keeps pace with the
interior.

Neighbouring triangles are not both refined in one round unless they are grossly oversized; the
highest-priority (largest area / quality) candidates win, up to the vertex budget.

One exception to `min_area` and to "the point is not critical": next to boundary points much
finer than h (the tips of the chapter's disk, ten times finer in the metric) a triangle with a
short boundary edge and a far apex, or three points of a tightly curved run, cannot be shaped by
moving its apex; it gets its metric circumcentre (Ruppert's point), first in the budget, which
grades the mesh down to the boundary's spacing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from qmesh.geometry import topology
from qmesh.geometry.portable import eigvalsh2
from qmesh.geometry.triangles import chunks, metric_hessians, metric_measures, rounded

GROSS = 4.0             # above this multiple of the threshold, neighbours may be refined together
GRADE_QUALITY = 0.35    # below this metric quality, a triangle whose shortest edge is a boundary
                        # edge gets its metric circumcentre
DUPLICATE = 1e-6        # a grading point this close to a vertex (in circumradii) is that vertex
LOCATE_STEPS = 16       # walk at most this many triangles from a bad triangle to its circumcentre


@dataclass
class Insertion:
    """What one insertion stage did: the new points, their boundary edge (-1 interior)."""

    T: np.ndarray
    twin: np.ndarray
    points: np.ndarray      # (k, 2) new points, appended after the existing ones
    edge_id: np.ndarray     # (k,) polygon edge of new boundary points, -1 for interior ones


def insert(P, T, twin, anisotropy, *, area_threshold, boundary_length, corner_edge,
           quality_threshold, min_area, budget, refine_boundary=True) -> Insertion:
    """Choose where to add points and split the triangles there.

    `corner_edge[i]` is the polygon edge a boundary vertex i starts (its own edge for sliding
    vertices, the outgoing edge for a seed corner); it names the edge of points split in after i.
    """
    n = len(P)
    none = Insertion(T, twin, np.empty((0, 2)), np.empty(0, np.int64))
    if budget <= 0:
        return none
    Hm = metric_hessians(anisotropy, P, T)
    area, quality, L2 = metric_measures(P, T, Hm, rounding=True)  # L2: edge opposite each corner
    At = area_threshold
    cand = (area > At) | ((quality < quality_threshold) & (area > min_area))
    # badly shaped triangles first (they have a budget only while N is below its target),
    # then the largest
    priority = rounded(area / At / np.maximum(quality, 1e-3)
                       + np.where(quality < quality_threshold, 10.0, 0.0))

    # the longest metric edge of each triangle, as a half-edge (edge opposite corner c is c+1→c+2)
    c, short = _longest_shortest(L2)
    longest = 3 * np.arange(len(T)) + topology.NXT[c]
    on_boundary = twin[longest] < 0
    # boundary half-edges long in metric space are refined whatever their triangle
    long_bnd = np.zeros(len(T), bool)
    if refine_boundary:
        bnd = np.flatnonzero(twin < 0)
        too_long = _half_edge_lengths2(L2, bnd) > boundary_length ** 2
        long_bnd[bnd[too_long] // 3] = True
    else:
        # a point inside a triangle standing on a boundary edge that may not be split would
        # only make thinner triangles on that edge: such triangles get none
        cand &= ~on_boundary
        on_boundary[:] = False

    # a triangle of low quality whose shortest edge is a boundary edge — two boundary points much
    # closer than h and a far apex, or three points of a tightly curved run — gets its metric
    # circumcentre (Ruppert's point), which grades the mesh down to the boundary spacing; these
    # are not bound by min_area and come first in the budget. (At a sharp corner the shortest
    # edge faces the corner's small angle, which no point can widen: those are left alone.)
    shortest = 3 * np.arange(len(T)) + topology.NXT[short]
    grade = (twin[shortest] < 0) & (quality < GRADE_QUALITY) & ~long_bnd
    g_tri, g_pts, g_host = _grading_points(P, T, twin, Hm, quality, grade, budget)
    budget -= len(g_tri)
    cand[g_tri] = False

    want = cand | long_bnd
    prio = np.where(long_bnd, np.maximum(priority, 2.0), priority)
    gross = (area > GROSS * At) & ~long_bnd
    chosen = want & (_local_max(T, twin, np.where(want, prio, -np.inf)) | gross | long_bnd)
    idx = np.flatnonzero(chosen)
    idx = idx[np.argsort(-prio[idx], kind="stable")][:max(budget, 0)]

    # each chosen triangle splits an edge: its longest one, or its longest boundary edge when
    # that one is too long; grossly oversized triangles are split at their centroid instead
    tri_he = (3 * idx[:, None] + np.arange(3))
    bnd_len = np.where(twin[tri_he] < 0, _half_edge_lengths2(L2, tri_he), -1.0)
    longest_bnd = tri_he[np.arange(len(idx)), np.argmax(bnd_len, axis=1)]
    edge = np.where(long_bnd[idx] & ~on_boundary[idx], longest_bnd, longest[idx])
    by_edge = ~gross[idx]
    he = _independent(T, twin, edge[by_edge], prio[idx[by_edge]])
    hosted = np.zeros(len(T), bool)
    hosted[g_host] = True
    he = he[~hosted[he // 3] & ~hosted[np.where(twin[he] >= 0, twin[he], he) // 3]]
    touched = hosted.copy()
    touched[he // 3] = True
    touched[twin[he[twin[he] >= 0]] // 3] = True
    tri = idx[~by_edge & ~touched[idx]]
    hb, hi = he[twin[he] < 0], he[twin[he] >= 0]
    if len(hb) + len(hi) + len(tri) + len(g_host) == 0:
        return none
    # the per-triangle arrays are not needed any more: free them before the splits copy T
    del Hm, area, quality, L2, cand, priority, longest, on_boundary, long_bnd, shortest
    del grade, want, prio, gross, chosen, hosted, touched

    new_b = _midpoints(P, T, hb)
    new_e = _midpoints(P, T, hi)
    new_c = np.concatenate([P[T[tri]].mean(axis=1), g_pts])
    tri = np.concatenate([tri, g_host])
    edge_b = corner_edge[T[hb // 3, hb % 3]]
    k0, k1 = n + len(hb), n + len(hb) + len(hi)
    # one copy of T and twin with room for every new triangle, which the splits fill in order
    m0, m1, m2 = len(T), len(T) + len(hb), len(T) + len(hb) + 2 * len(hi)
    T, twin = topology.grow(T, twin, len(hb) + 2 * len(hi) + 2 * len(tri))
    T, twin = topology.split_boundary_edges(T, twin, hb, n + np.arange(len(hb)),
                                            rows=np.arange(m0, m1))
    T, twin = topology.split_edges(T, twin, hi, k0 + np.arange(len(hi)), rows=np.arange(m1, m2))
    T, twin = topology.split_triangles(T, twin, tri, k1 + np.arange(len(tri)),
                                       rows=np.arange(m2, len(T)))
    return Insertion(T, twin, np.concatenate([new_b, new_e, new_c]),
                     np.concatenate([edge_b, np.full(len(hi) + len(tri), -1)]))


def _half_edge_lengths2(L2, h):
    """The squared metric length of half-edges h, from the lengths L2 (M, 3) of the edges
    opposite each corner: half-edge 3t + e is opposite corner e + 2."""
    return L2[h // 3, topology.PRV[h % 3]]


def _longest_shortest(L2):
    """np.argmax(L2, axis=1) and np.argmin(L2, axis=1) — the corner facing each triangle's
    longest and shortest edge, the first of equals — by two comparisons per row, CHUNK rows
    at a time (NumPy's reductions along a row of three took a fifth of the stage at 1e6);
    a block holding NaN takes NumPy's (which picks the first NaN)."""
    longest, shortest = np.empty(len(L2), np.int64), np.empty(len(L2), np.int64)
    for c in chunks(len(L2)):
        L = L2[c]
        if np.isnan(L).any():
            longest[c], shortest[c] = np.argmax(L, axis=1), np.argmin(L, axis=1)
            continue
        a, b, e = L[:, 0], L[:, 1], L[:, 2]
        for out, better in ((longest, np.greater), (shortest, np.less)):
            one = better(b, a)
            out[c] = np.where(better(e, np.where(one, b, a)), 2, one)
    return longest, shortest


def metric_circumcentres(P, T, Hm):
    """Centres of the metric circumcircles (ellipses (x − c)ᵀH(x − c) = r²) of triangles T."""
    a = P[T[:, 0]]
    e1, e2 = P[T[:, 1]] - a, P[T[:, 2]] - a
    He1, He2 = np.einsum("mij,mj->mi", Hm, e1), np.einsum("mij,mj->mi", Hm, e2)
    M = np.stack([He1, He2], axis=1)                   # 2 eᵀH u = eᵀH e for both edges from a
    rhs = 0.5 * np.column_stack([np.einsum("mi,mi->m", e1, He1), np.einsum("mi,mi->m", e2, He2)])
    det = M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] * M[:, 1, 0]
    det = np.where(det != 0, det, np.inf)
    u = np.column_stack([M[:, 1, 1] * rhs[:, 0] - M[:, 0, 1] * rhs[:, 1],
                         M[:, 0, 0] * rhs[:, 1] - M[:, 1, 0] * rhs[:, 0]]) / det[:, None]
    return a + u


def locate(P, T, twin, start, X, steps=LOCATE_STEPS):
    """The triangle holding each point X[k], walking from triangle start[k] across the edge
    facing it; -1 where the walk leaves the domain or takes more than `steps` triangles."""
    t = np.asarray(start, np.int64).copy()
    found = np.full(len(t), -1, np.int64)
    live = np.arange(len(t))
    for _ in range(steps):
        if not len(live):
            break
        tt = t[live]
        x = P[T[tt]]                                              # (k, 3, 2)
        rel = x - X[live, None, :]
        # twice the signed area of (X, corner c+1, corner c+2): X's weight for corner c
        w = (rel[:, topology.NXT, 0] * rel[:, topology.PRV, 1]
             - rel[:, topology.NXT, 1] * rel[:, topology.PRV, 0])
        worst = np.argmin(w, axis=1)
        inside = w[np.arange(len(tt)), worst] >= 0
        found[live[inside]] = tt[inside]
        nxt = twin[3 * tt + topology.NXT[worst]]                  # the edge opposite that corner
        go = ~inside & (nxt >= 0)
        t[live[go]] = nxt[go] // 3
        live = live[go]
    return found


def _grading_points(P, T, twin, Hm, quality, grade, budget):
    """Circumcentres of the `grade` triangles that lie in Ω, one per host triangle and none within
    half a circumradius of a better one: (triangles, points, host triangles)."""
    idx = np.flatnonzero(grade)
    if budget <= 0 or not len(idx):
        return idx[:0], np.empty((0, 2)), idx[:0]
    idx = idx[np.argsort(quality[idx], kind="stable")]
    Hs = Hm[idx] if Hm.strides[0] else np.broadcast_to(Hm[0], (len(idx), 2, 2))
    C = metric_circumcentres(P, T[idx], Hs)
    ok = np.all(np.isfinite(C), axis=1)
    host = np.full(len(idx), -1, np.int64)
    host[ok] = locate(P, T, twin, idx[ok], C[ok])
    keep = host >= 0
    # none on a corner of its host: where the triangulation is not Delaunay in this triangle's
    # metric (a metric that varies) a vertex may sit inside the circle, even at its centre, and
    # a point there would duplicate it (folded triangles around the pair; farther ones are kept:
    # dropping those within half a radius doubled κ2 on FVCA5 test 5's field at N 2000)
    D = P[T[idx, 0]] - C
    r2 = np.einsum("mi,mij,mj->m", D, Hs, D)
    E = P[T[np.maximum(host, 0)]] - C[:, None, :]
    keep &= ~(np.einsum("mci,mij,mcj->mc", E, Hs, E) < DUPLICATE ** 2 * r2[:, None]).any(axis=1)
    # one per host, the worst triangle first
    _, first = np.unique(host[keep], return_index=True)
    sel = np.flatnonzero(keep)[np.sort(first)]
    idx, C, host, Hs = idx[sel], C[sel], host[sel], Hs[sel]
    # no two points closer than half the circumradius of the worse triangle's circle
    r = np.sqrt(r2[sel])
    if len(idx) > 1:
        lam = eigvalsh2(Hs)[:, 0]                          # Euclidean radius bound
        hits = cKDTree(C).query_ball_point(C, 0.5 * r / np.sqrt(lam))
        count = np.fromiter((len(h) for h in hits), np.int64, len(hits))
        i = np.repeat(np.arange(len(idx)), count)
        j = np.fromiter((k for h in hits for k in h), np.int64, int(count.sum()))
        i, j = i[j > i], j[j > i]                                   # i is the worse triangle
        D = C[j] - C[i]
        close = np.einsum("mi,mij,mj->m", D, Hs[i], D) < (0.5 * r[i]) ** 2
        drop = np.zeros(len(idx), bool)
        drop[j[close]] = True
        idx, C, host = idx[~drop], C[~drop], host[~drop]
    return idx[:budget], C[:budget], host[:budget]


def _midpoints(P, T, h):
    """Midpoints of half-edges h (also the metric midpoints: the metric map is affine)."""
    t, e = np.divmod(h, 3)
    return 0.5 * (P[T[t, e]] + P[T[t, topology.NXT[e]]])


def _independent(T, twin, h, prio):
    """A subset of the half-edges h, one per edge, no two touching the same triangle."""
    if len(h) == 0:
        return h
    tw = twin[h]
    canon = np.where(tw >= 0, np.minimum(h, tw), h)
    order = np.lexsort((-prio, canon))
    canon, prio = canon[order], prio[order]
    first = np.r_[True, canon[1:] != canon[:-1]]
    canon, prio = canon[first], prio[first]
    rank = np.empty(len(canon))
    rank[np.argsort(prio, kind="stable")] = np.arange(1, len(canon) + 1)
    best = np.zeros(len(T))
    t1 = canon // 3
    t2 = np.where(twin[canon] >= 0, twin[canon] // 3, t1)
    np.maximum.at(best, t1, rank)
    np.maximum.at(best, t2, rank)
    return canon[(best[t1] == rank) & (best[t2] == rank)]


def _local_max(T, twin, prio):
    """Triangles whose priority is finite and at least that of each edge-neighbour (CHUNK
    triangles at a time: the whole mesh's neighbour rows were six temporaries of twin's size)."""
    ext = np.append(prio, -np.inf)              # the -1 of a boundary half-edge reads -inf
    out = np.empty(len(T), bool)
    for c in chunks(len(T)):
        nb = twin[3 * c.start:3 * c.stop].reshape(-1, 3) // 3
        p = prio[c]
        out[c] = ((p >= ext[nb[:, 0]]) & (p >= ext[nb[:, 1]]) & (p >= ext[nb[:, 2]])
                  & np.isfinite(p))
    return out


def relocate_degree3(P, T, twin, anisotropy, on_boundary):
    """Move interior vertices with only three neighbours to the largest triangles.

    Such a vertex sits inside the triangle of its neighbours and adds nothing there; held by
    the energy near a boundary it can leave a sliver of quality ~0.1 that the vertex step
    never removes (seen on the chapter's case). Removing it and inserting it at the centroid
    of the largest metric triangle keeps N and the triangle count. Returns (T, twin, P, moved).
    """
    deg = np.bincount(T.ravel(), minlength=len(P))
    lonely = (deg == 3) & ~on_boundary
    if not lonely.any():
        return T, twin, P, np.empty(0, np.int64)
    corner = np.flatnonzero(lonely[T.ravel()])
    tri, vert = corner // 3, T.ravel()[corner]
    shared = np.bincount(tri, minlength=len(T)) > 1          # triangle with two such vertices
    bad = np.zeros(len(P), bool)
    bad[vert[shared[tri]]] = True
    keep = ~bad[vert]
    tri, vert = tri[keep], vert[keep]
    order = np.argsort(vert, kind="stable")
    tri, vert = tri[order], vert[order]
    v, star = vert[::3], tri.reshape(-1, 3)
    Hm = metric_hessians(anisotropy, P, T)
    area, quality, _ = metric_measures(P, T, Hm)
    size = rounded(area / np.maximum(quality, 1e-3))
    size[star.ravel()] = -np.inf
    target = np.argsort(-size, kind="stable")[:len(v)]
    P = P.copy()
    P[v] = P[T[target]].mean(axis=1)
    T, twin = topology.relocate_vertices(T, twin, v, star, target)
    return T, twin, P, v
