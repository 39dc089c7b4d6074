"""Disjoint domains meshed by one run of Algorithm 2.1, and its mesh cut back into one per domain.

A run has fixed costs (normalising, seeding, Qhull builds, the stages' passes) that a domain of a
few dozen vertices pays as much as one of a million. Domains that share one constant Q and one
size, and touch nowhere, can be meshed together: every stage is local to a triangle, an edge or a
vertex's star, Qhull's triangles outside Ω are dropped as for a domain with holes (Ω lies on the
left of every segment), and encroachment is tested on Ω's side of a segment only. The run sees
one domain whose rings are all the domains' rings; its input points come first, domain after
domain, so each domain's mesh keeps its own input points first (and bit for bit). Each domain
is seeded with its own metric lattice, placed on its own extent as it would be alone (one lattice
across all would leave a small domain's interior points to chance); what is the run's, not each
domain's: the lattices' jitter drawn in turn, one insertion budget, one test of convergence.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from qmesh.domain.domain import Domain
from qmesh.errors import QmeshError
from qmesh.geometry.portable import cholesky2, det2, eigh2, inv2, matmul2, moments2, times2
from qmesh.geometry.rings import signed_area
from qmesh.geometry.rings import point_segment_distance
from qmesh.geometry.triangles import rounded
from qmesh.mesher.seeding import ELONGATED, JITTER, MARGIN
from qmesh.triangle_mesh import Mesh


class Components(Domain):
    """Disjoint domains as one Ω, from their `rings` (each outline counter-clockwise, each hole
    clockwise; checked before, as Domains or as the faces of a partition), the rings' segment
    `tags` and `sizes`, each domain's point count: the rings' signed areas summed, the bounding
    box of all their points."""

    def __init__(self, rings: Sequence[NDArray[np.float64]], tags: Sequence[NDArray[np.int64]],
                 sizes: Sequence[int]) -> None:
        self._store(list(rings), list(tags), float(sum(signed_area(R) for R in rings)))
        self._tag_names, self._regions, self._region_names, self._partition = {}, (), {}, None
        self.sizes = np.asarray(sizes)

    @property
    def bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self.seeds.min(axis=0), self.seeds.max(axis=0)

    def lattice_points(self, H: NDArray[np.float64], h: float, rng: np.random.Generator) -> NDArray[np.float64]:
        """A run's first interior points (constant Q, a size): each domain's own metric lattice,
        placed on its own extent as it would be alone (`seeding.metric_lattice`), not one across
        all, whose place in a small domain would be left to chance. The same points bit for bit,
        the jitter drawn domain after domain, but laid out for all domains at once (`_lattices`):
        a call per domain costs more than its lattice."""
        return _lattices(self, np.asarray(H, float), h, rng)

    def scaled(self, center: Any, scale: float, area: float | None = None) -> Domain:
        """Domain.scaled with the area of all outlines, not of one."""
        return Domain.scaled(self, center, scale, self._area / scale**2 if area is None else area)


def split(mesh: Mesh, point_counts: Sequence[int]) -> list[Mesh]:
    """The mesh of a `Components` as one mesh per part (`point_counts`: each part's input points,
    in order), each with its vertices in the order they have in `mesh`; QmeshError when a
    triangle joins two parts."""
    if len(point_counts) == 1:
        return [mesh]
    T, n, sizes = mesh.triangles, mesh.n_vertices, np.asarray(point_counts)
    graph = coo_matrix((np.ones(2 * len(T)), (T[:, [0, 1]].ravel(), T[:, [1, 2]].ravel())), (n, n))
    _, label = connected_components(graph, directed=False)
    start = np.cumsum(sizes) - sizes
    part = np.full(label.max() + 1, -1)
    part[label[start]] = np.arange(len(sizes))
    of = part[label]                                        # the part of every vertex
    if (of < 0).any() or (of[:sizes.sum()] != np.repeat(np.arange(len(sizes)), sizes)).any():
        raise QmeshError("the domains' meshes do not fall apart one per domain")
    E = mesh.boundary_edges
    v, t, e = np.argsort(of, kind="stable"), np.argsort(of[T[:, 0]], kind="stable"), \
        np.argsort(of[E[:, 0]], kind="stable")
    new = np.empty(n, np.int64)
    cut_v, cut_t, cut_e = (np.searchsorted(np.sort(x), np.arange(len(sizes) + 1))
                           for x in (of, of[T[:, 0]], of[E[:, 0]]))
    new[v] = np.arange(n) - np.repeat(cut_v[:-1], np.diff(cut_v))
    # every array in part order once, read-only: each part's Mesh keeps views of them
    P, F, TT, EE, tags = mesh.points[v], mesh.fixed[v], new[T[t]], new[E[e]], mesh.boundary_tags[e]
    for a in (P, F, TT, EE, tags):
        a.setflags(write=False)
    return [Mesh(P[cut_v[p]:cut_v[p + 1]], TT[cut_t[p]:cut_t[p + 1]], F[cut_v[p]:cut_v[p + 1]],
                 EE[cut_e[p]:cut_e[p + 1]], tags[cut_e[p]:cut_e[p + 1]], mesh.tag_names)
            for p in range(len(sizes))]


def _lattices(dom: Components, H: NDArray[np.float64], h: float, rng: np.random.Generator) -> NDArray[np.float64]:
    """`seeding.metric_lattice` of every domain of `dom` in turn, its points concatenated: the
    same operations on each point and segment, made for all domains together, the jitter drawn
    domain after domain as one draw. The frame (the metric's axes, or a domain's own when it is
    ELONGATED in the metric) is found for all at once where the domain is clearly not elongated
    (with a margin), else by metric_lattice's own function, domain by domain; products by a
    frame are taken per domain, or over all rows at once for the metric's axes (which gives
    every row of a domain of two rows or more the bits its own product gives)."""
    sizes = np.asarray(dom.sizes, np.int64)
    n_d, start = len(sizes), np.cumsum(sizes) - sizes
    pid = np.repeat(np.arange(n_d), sizes)                  # domain of every seed and segment
    L = cholesky2(H)
    S = dom.seeds
    A, B = dom.segment_ends
    X, w = times2(S, L), np.hypot(*times2(B - A, L).T)
    W = np.add.reduceat(w, start)
    D = X - (np.add.reduceat(X * w[:, None], start) / W[:, None])[pid]
    cxx, cxy, cyy = (np.add.reduceat(w * u * v, start) for u, v in ((D[:, 0], D[:, 0]), (D[:, 0], D[:, 1]),
                                                                     (D[:, 1], D[:, 1])))
    with np.errstate(all="ignore"):
        mid, rad = 0.5 * (cxx + cyy), np.hypot(0.5 * (cxx - cyy), cxy)
        plain = (mid + rad) * (1 + 1e-6) < ELONGATED * (mid - rad)
    Am, Bm = times2(A, L), times2(B, L)
    inv = np.broadcast_to(inv2(L), (n_d, 2, 2)).copy()
    late = np.flatnonzero(~plain)
    for n in np.unique(sizes[late]).tolist():               # the frame metric_lattice finds, by size
        grp = late[sizes[late] == n]
        at = (start[grp][:, None] + np.arange(n)).ravel()
        M = _frames(X[at].reshape(-1, n, 2), w[at].reshape(-1, n), L)
        Am[at] = matmul2(A[at].reshape(-1, n, 1, 2), M[:, None]).reshape(-1, 2)
        Bm[at] = matmul2(B[at].reshape(-1, n, 1, 2), M[:, None]).reshape(-1, 2)
        inv[grp] = inv2(M)
    lo = np.minimum(np.minimum.reduceat(Am, start), np.minimum.reduceat(Bm, start))
    hi = np.maximum(np.maximum.reduceat(Am, start), np.maximum.reduceat(Bm, start))
    dy = h * np.sqrt(3.0) / 2.0
    with np.errstate(all="ignore"):
        n_rows = np.ceil(rounded((hi[:, 1] - lo[:, 1]) / dy)) + 1
    n_rows = np.where(n_rows <= 10 * 50_000_000, n_rows, 0).astype(np.int64)   # beyond: none, as there
    # rows: y of each domain's row j (j from 0), as metric_lattice lays them out
    row_d = np.repeat(np.arange(n_d), n_rows)
    row0 = np.cumsum(n_rows) - n_rows
    j = np.arange(len(row_d)) - row0[row_d]
    y = lo[row_d, 1] + (j + 0.5) * dy
    # scanlines: each domain's segments against its rows that may cross them (one more on either
    # side), kept where they straddle the row as rings.scanline_intervals keeps them
    seg = np.flatnonzero(n_rows[pid] > 0)
    d = pid[seg]
    ylo, yhi = np.minimum(Am[seg, 1], Bm[seg, 1]), np.maximum(Am[seg, 1], Bm[seg, 1])
    j0 = np.clip(np.floor((ylo - lo[d, 1]) / dy - 0.5).astype(np.int64) - 1, 0, None)
    j1 = np.minimum(np.ceil((yhi - lo[d, 1]) / dy - 0.5).astype(np.int64) + 1, n_rows[d] - 1)
    count = np.maximum(j1 - j0 + 1, 0)
    sg = np.repeat(seg, count)
    r = np.repeat(row0[d] + j0, count) + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    a, b = Am[sg], Bm[sg]
    straddle = (a[:, 1] > y[r]) != (b[:, 1] > y[r])
    r, a, b = r[straddle], a[straddle], b[straddle]
    t = (y[r] - a[:, 1]) / (b[:, 1] - a[:, 1])
    x = a[:, 0] + t * (b[:, 0] - a[:, 0])
    order = np.lexsort((x, r))
    r, x = r[order], x[order]
    row, x0, x1 = r[0::2], x[0::2], x[1::2]
    # each interval's lattice points, the jitter, the margin, as metric_lattice
    jr = j[row]
    off = lo[row_d[row], 0] + 0.5 * h * (jr % 2)
    i0 = np.ceil(rounded((x0 - off) / h)).astype(np.int64)
    count = np.maximum(np.floor(rounded((x1 - off) / h)).astype(np.int64) - i0 + 1, 0)
    rr = np.repeat(row, count)
    i = np.repeat(i0, count) + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    P = np.column_stack([lo[row_d[rr], 0] + (i + 0.5 * (j[rr] % 2)) * h, y[rr]])
    P += rng.uniform(-JITTER, JITTER, P.shape) * h
    P_d = row_d[rr]                                         # domain of every point (sorted)
    k = sizes[P_d]                                          # a point within the margin of a segment
    pt = np.repeat(np.arange(len(P)), k)                    # of its domain is dropped
    sg = np.repeat(start[P_d], k) + np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k)
    close = point_segment_distance(P[pt], Am[sg], Bm[sg]) <= rounded(MARGIN * h)
    keep = np.bincount(pt[close], minlength=len(P)) == 0
    P, P_d = P[keep], P_d[keep]
    out = times2(P, inv2(L))
    n_kept = np.bincount(P_d, minlength=n_d)
    at = np.cumsum(n_kept) - n_kept
    for p in np.flatnonzero((n_kept > 0) & (~plain | (n_kept == 1))).tolist():   # mapped back alone
        s, e = int(at[p]), int(at[p] + n_kept[p])
        out[s:e] = times2(P[s:e], inv[p])
    return out


def _frames(X: NDArray[np.float64], w: NDArray[np.float64], L: NDArray[np.float64]) -> NDArray[np.float64]:
    """`seeding._metric_frame` of g domains of n points each, stacked: X (g, n, 2) their points
    mapped by L, w (g, n) their segments' metric lengths; the same operations, matrix by matrix."""
    c = (X * w[..., None]).sum(axis=1) / w.sum(axis=1)[:, None]
    D = X - c[:, None, :]
    val, vec = eigh2(moments2(D, w))
    R = vec[..., ::-1]                                   # columns: longest direction first
    R *= np.where(np.abs(R[:, 0]) >= np.abs(R[:, 1]), np.sign(R[:, 0]), np.sign(R[:, 1]))[:, None, :]
    flip = det2(R) < 0
    R[flip, :, 1] *= -1
    M = matmul2(L, R)
    M[val[:, 1] < ELONGATED * val[:, 0]] = L             # not elongated: the metric's own axes
    return M
