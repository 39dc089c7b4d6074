"""Conforming Q-Delaunay triangulation of a domain with holes (GEOMETRY.md §1).

The lower hull of the lifted vertices triangulates their convex hull, not Ω. Two things make it
a mesh of Ω on which every stiffness off-diagonal q_ij is ≥ 0, interior and boundary edges alike:

1. no boundary subsegment is *encroached*: no vertex lies below the plane through the lifted
   ends of the subsegment whose slope across it is ∇s at its midpoint — for a constant Q the
   diametral ellipse (p − m)ᵀH(p − m) < ¼ (b − a)ᵀH(b − a). Then every subsegment is an edge of
   the Q-Delaunay triangulation, and its own q_ij (½ cot of the metric angle facing it) is ≥ 0;
2. the triangles outside Ω (in notches and holes) are removed: connected components of the
   triangles across edges that are not subsegments, labelled by the side of a subsegment they
   touch.

Encroached subsegments are split (Ruppert 1995): at the midpoint, or, next to an input point,
at a power-of-two metric distance from it ("concentric shells", Shewchuk's Triangle), so that
segments meeting at a small metric angle are split at matching distances and the splitting
cannot run away. During the mesher's iterations the boundary subsegments are the boundary
half-edges of the kept triangulation: flips never touch them, so the flips restore the
constrained Q-Delaunay triangulation, and splitting the encroached ones makes it the
conforming one restricted to Ω.
"""

from __future__ import annotations

from itertools import chain

from dataclasses import dataclass

import numpy as np

from qmesh.geometry import topology
from qmesh.errors import QmeshError
from qmesh.geometry.portable import cholesky2, round_log2, times2
from qmesh.geometry.triangles import signed_areas
from qmesh.mesher import corners, lattice_delaunay
from qmesh.mesher.corners import metric_at
from qmesh.mesher.triangulate import Crowded, first_triangulation, restore

ENCROACH_TOL = 1e-9     # relative depth below the plane that counts as encroaching
MAX_ROUNDS = 200        # split rounds before giving up (never reached on valid input)
LONG = 2.0              # encroached subsegments longer than this many h are split, not cleared
SHORTEST = 1e-9         # subsegments shorter than this (metric, normalised units) are not split
PUSH = 1.02             # an encroaching interior vertex goes this far out (× the ellipse radius)
PUSH_ROUNDS = 20        # rounds that may push vertices before only splits are made
MIN_KEPT = 0.1          # a push must leave every triangle of the star this share of its area


# --------------------------------------------------------------------------- the test

def encroached(A: np.ndarray, B: np.ndarray, C: np.ndarray, anisotropy) -> np.ndarray:
    """Whether point C[k] encroaches the subsegment A[k]→B[k] (GEOMETRY.md §1, the lifted test).

    Constant Q: C lies inside the diametral ellipse of AB in the metric H. Varying s: C lies
    below the plane through the lifted A and B whose slope across AB is ∇s(m)·n.
    """
    M = 0.5 * (A + B)
    E = B - A
    Hm = metric_at(anisotropy, M)
    L2 = np.einsum("ki,kij,kj->k", E, Hm, E)                 # (b − a)ᵀH(b − a)
    if anisotropy.is_constant or not anisotropy.potential:     # the ellipse in H at the midpoint
        D = C - M
        depth = 0.5 * np.einsum("ki,kij,kj->k", D, Hm, D) - 0.125 * L2
    else:
        length = np.hypot(E[:, 0], E[:, 1])
        t = E / length[:, None]
        n = np.column_stack([-t[:, 1], t[:, 0]])
        sA = np.asarray(anisotropy.s(A), dtype=float)
        sB = np.asarray(anisotropy.s(B), dtype=float)
        sC = np.asarray(anisotropy.s(C), dtype=float)
        gm = np.asarray(anisotropy.grad(M), dtype=float)
        g = ((sB - sA) / length)[:, None] * t + np.einsum("ki,ki->k", gm, n)[:, None] * n
        depth = sC - sA - np.einsum("ki,ki->k", g, C - A)
    return depth < -ENCROACH_TOL * L2


def sharpest_corner(domain, anisotropy) -> tuple[int, float]:
    """The input point with the domain's smallest angle, measured in the metric there, and
    that angle in degrees."""
    angles = corners.corner_angles(domain, anisotropy)
    k = int(np.argmin(angles))
    return k, float(angles[k])


class SharpCorner(QmeshError):
    """A corner so sharp in the metric that the points keeping q_ij ≥ 0 on its sides crowd
    closer than round-off: `seed` (its input point), `angle` (degrees), `n` points reached."""

    def __init__(self, seed: int, angle: float, n: int):
        super().__init__(f"input point {seed} is a corner of {angle:.3g}° in the metric")
        self.seed, self.angle, self.n = seed, angle, n


def split_points(A: np.ndarray, B: np.ndarray, a_is_seed: np.ndarray, b_is_seed: np.ndarray,
                 anisotropy) -> np.ndarray:
    """Where to split subsegments A→B: the midpoint, or a concentric-shell point next to a seed.

    With exactly one end an input point, the split lies at the power of two (in metric length,
    measured with the metric at that seed) nearest to half the subsegment, from that seed.
    """
    frac = np.full(len(A), 0.5)
    shell = a_is_seed != b_is_seed
    if shell.any():
        seed = np.where(a_is_seed[shell, None], A[shell], B[shell])
        E = B[shell] - A[shell]
        H = metric_at(anisotropy, seed)
        L = np.sqrt(np.einsum("ki,kij,kj->k", E, H, E))
        d = np.ldexp(1.0, round_log2(0.5 * L))
        f = np.clip(d / L, 0.25, 0.75)
        frac[shell] = np.where(a_is_seed[shell], f, 1.0 - f)
    return A + frac[:, None] * (B - A)


def marked(P: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Which points of P are exactly one of `corners` (a medium's junctions: partition vertices
    where three or more partition edges meet)."""
    out = np.zeros(len(P), bool)
    if len(corners):
        from scipy.spatial import cKDTree
        d, _ = cKDTree(corners).query(P)
        out = d == 0
    return out


def beside_corners(x, P, u, v, w, junction, anisotropy) -> np.ndarray:
    """Split points of subsegments u→v with one end a junction: the farthest point from the
    junction whose subsegment the apex w no longer encroaches, ρ = |w|² / ⟨w, t⟩ in the metric
    (t the unit direction of the subsegment, w from the junction), capped at ¾ of the way but
    never nearer the junction than w itself (ρ ≥ |w|): splits next to a junction follow the
    points already there instead of each face's own powers of two, which do not line up
    across faces in different metrics and would run towards the junction without end. The
    floor |w| keeps the point out of the diametral ellipse of the junction's subsegment to w
    (⟨w, t⟩ < |w|): capped below it, in a wedge under 30° in the metric, the two sides' first
    subsegments would encroach each other in turn, each split ¾ of the last, without end."""
    one = junction[u] != junction[v]
    if not one.any():
        return x
    k = np.flatnonzero(one)
    J = np.where(junction[u[k], None], P[u[k]], P[v[k]])
    O = np.where(junction[u[k], None], P[v[k]], P[u[k]])
    H = (np.broadcast_to(anisotropy.H, (len(k), 2, 2)) if anisotropy.is_constant
         else np.asarray(anisotropy.hessian(J), float))
    E, W = O - J, P[w[k]] - J
    L = np.sqrt(np.einsum("ki,kij,kj->k", E, H, E))
    ww = np.einsum("ki,kij,kj->k", W, H, W)
    wt = np.einsum("ki,kij,kj->k", W, H, E) / L
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.where(wt > 0, ww / wt / L, np.nan) * (1 - 1e-6)
    ok = np.isfinite(frac) & (frac > 0) & (frac < 1)
    frac = np.minimum(frac, np.maximum(0.75, np.sqrt(ww) / L))
    out = np.array(x)
    out[k[ok]] = J[ok] + frac[ok, None] * E[ok]
    return out


def metric_lengths2(A: np.ndarray, B: np.ndarray, anisotropy) -> np.ndarray:
    E = B - A
    return np.einsum("ki,kij,kj->k", E, metric_at(anisotropy, 0.5 * (A + B)), E)


# --------------------------------------------------------------------------- from scratch

@dataclass
class Conforming:
    """A conforming Q-Delaunay triangulation of Ω and its vertices."""

    P: np.ndarray           # (N, 2) points: the seeds first, then the rest
    T: np.ndarray           # (M, 3) counter-clockwise triangles inside Ω
    twin: np.ndarray        # half-edge twins of T
    edge_id: np.ndarray     # (N,) segment a non-seed boundary vertex lies on, else -1
    pinned: np.ndarray      # (N,) boundary points split in where two segments crowd each other


def _subsegments(domain, n_seeds, edge_id, t):
    """Consecutive boundary points along every segment: arrays (a, b) of point indices."""
    seg = domain.segments
    S = len(seg)
    on = np.flatnonzero(edge_id >= 0)
    keys_seg = np.concatenate([np.arange(S), edge_id[on], np.arange(S)])
    keys_t = np.concatenate([np.zeros(S), t[on], np.ones(S)])
    idx = np.concatenate([seg[:, 0], on, seg[:, 1]])
    order = np.lexsort((keys_t, keys_seg))
    keys_seg, idx = keys_seg[order], idx[order]
    same = keys_seg[1:] == keys_seg[:-1]
    return idx[:-1][same], idx[1:][same]


def _canonical_order(T: np.ndarray, twin: np.ndarray, rows: np.ndarray):
    """Triangles `rows` of T rotated to start at their smallest vertex and sorted, with their
    twins (edges to the other triangles become boundary edges): Qhull lists the triangles in an
    order that depends on the coordinates' round-off, the mesher's later choices on the order.
    The twins are carried over from `twin`, not found again by a sort; one column at a time,
    so that at 1e6 vertices no more than two (M, 3) arrays are made."""
    Tr = T[rows]
    m = len(Tr)
    r = np.argmin(Tr, axis=1) if m else np.zeros(0, np.int64)
    # corner j: the old corner r + j, chosen column by column (a fancy index of (row, corner)
    # pairs took several times as long at 1e6 vertices)
    c = [Tr[:, j] for j in range(3)]
    first, second = r == 0, r == 1
    cols = [np.where(first, c[j], np.where(second, c[(j + 1) % 3], c[(j + 2) % 3]))
            for j in range(3)]
    del Tr, c
    n = int(max(c.max() for c in cols)) + 1 if m else 0
    if n * n * n < 2 ** 63:        # one int64 key per triangle: a third of lexsort's time, same order
        key = (cols[0] * n + cols[1]) * n + cols[2]
        # distinct triangles have distinct keys, so any sort gives the stable order: NumPy's
        # default one is a quarter of its stable one's time; equal keys (never seen) take that
        order = np.argsort(key)
        ordered = key[order]
        if not np.all(ordered[1:] > ordered[:-1]):
            order = np.argsort(key, kind="stable")
        del key, ordered
    else:
        order = np.lexsort((cols[2], cols[1], cols[0]))
    out = np.empty((m, 3), np.int64)
    for j in range(3):
        out[:, j] = cols[j][order]
    del cols
    # new half-edge 3i + j runs from the new corner j: old half-edge 3 rows[o] + (r[o] + j) % 3
    base, r = 3 * rows[order], r[order]
    del order
    index = np.int32 if len(twin) < 2 ** 31 else np.int64
    new_id = np.full(len(twin), -1, index)
    old = [base + ((np.arange(3) + j) % 3)[r] for j in range(3)]   # (no % over the whole mesh)
    del base, r
    for j in range(3):
        new_id[old[j]] = np.arange(j, 3 * m, 3, dtype=index)
    new_twin = np.empty(3 * m, np.int64)
    for j in range(3):
        tw = twin[old[j]]
        new_twin[j::3] = np.where(tw >= 0, new_id[np.maximum(tw, 0)], -1)
    return out, new_twin


def inside_triangles(T: np.ndarray, twin: np.ndarray, h_in: np.ndarray) -> np.ndarray:
    """Mask of the triangles of Ω: components across non-boundary edges, labelled by the
    subsegment half-edges h_in (Ω on their left) and their twins (outside)."""
    try:
        return topology.left_of(T, twin, h_in)
    except ValueError:
        raise QmeshError("the boundary is not conforming: a region lies on both sides of it; "
                         "please report this domain") from None


class TooManySplits(QmeshError):
    """Keeping the boundary conforming needs more vertices than the run allows."""


def _too_many(n: int, limit: int):
    return TooManySplits(
        f"keeping every q_ij >= 0 on the boundary needs more than {limit} vertices here "
        f"(reached {n}): the domain is thinner, or its corners sharper, in the metric than the "
        "requested element size; ask for more vertices (a smaller size), or simplify the domain")


def _encroaching_free(domain, P, edge_id, anisotropy, h, far=None) -> np.ndarray:
    """Mask of the points to keep: interior points inside the diametral ellipse of a subsegment
    are dropped before the first Qhull run (constant Q: discs in metric coordinates, found with
    a k-d tree), so that run is usually the only one. `far`: points known to lie farther from
    the boundary than any disc reaches (the deep lattice points), left out of the tree."""
    from scipy.spatial import cKDTree
    n_seeds = len(domain.seeds)
    maybe = (np.arange(len(P)) >= n_seeds) & (edge_id < 0)
    free = np.flatnonzero(maybe if far is None else maybe & ~far)
    if not len(free):
        return np.ones(len(P), bool)
    A, B = domain.segment_ends
    on = edge_id >= 0
    t = np.zeros(len(P))
    E = B - A
    t[on] = np.einsum("ki,ki->k", P[on] - A[edge_id[on]], E[edge_id[on]]) / \
        np.einsum("ki,ki->k", E, E)[edge_id[on]]
    a, b = _subsegments(domain, n_seeds, edge_id, t)
    L = cholesky2(anisotropy.H)
    X = times2(P, L)
    M = 0.5 * (X[a] + X[b])
    r = 0.5 * np.hypot(*(X[b] - X[a]).T)
    M, r = M[r <= 0.5 * LONG * h], r[r <= 0.5 * LONG * h]     # long ones are split instead
    hits = cKDTree(X[free]).query_ball_point(M, r * (1 + 1e-9))
    inside = np.unique(np.fromiter(chain.from_iterable(hits), np.int64))
    keep = np.ones(len(P), bool)
    keep[free[inside]] = False
    return keep


def _in_ellipses(X, a, b, tree, ids, anisotropy, P):
    """Pairs (k, j): point ids[j'] (a point of `tree`, built on X[ids]) on the left of
    a[k]→b[k] encroaches it, by the exact test `encroached` on the k-d tree's candidates
    (metric discs in X = P L, which keeps orientation)."""
    if not len(a) or tree is None:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    M = 0.5 * (X[a] + X[b])
    # `encroached` asks |C − M| < r(1 − 4e-9): the ends (at r) stay out of a disc this wide,
    # so most discs are empty; they are counted first and listed only where a point lies
    r = 0.5 * np.hypot(*(X[b] - X[a]).T) * (1 - 1e-9)
    some = np.flatnonzero(tree.query_ball_point(M, r, return_length=True) > 0)
    hits = tree.query_ball_point(M[some], r[some])
    count = np.fromiter((len(h) for h in hits), np.int64, len(hits))
    k = np.repeat(some, count)
    j = ids[np.fromiter(chain.from_iterable(hits), np.int64, int(count.sum()))]
    # on the side of Ω only (on the left of a→b), as the rounds test the apex on that side
    E, C = X[b[k]] - X[a[k]], X[j] - X[a[k]]
    other = (j != a[k]) & (j != b[k]) & (E[:, 0] * C[:, 1] - E[:, 1] * C[:, 0] > 0)
    k, j = k[other], j[other]
    enc = encroached(P[a[k]], P[b[k]], P[j], anisotropy)
    return k[enc], j[enc]


def _in_ellipses_since(X, a, b, first, n_old, anisotropy, P):
    """The subsegments a→b whose ellipse holds a boundary point on the side of Ω, after a round
    that tested every subsegment then standing against every boundary point then, and split in
    the points n_old, … (all on the boundary): those points encroach the subsegments that
    stood (both ends before n_old), and every boundary point the new ones. Boundary points are
    never dropped, so these are the subsegments a test of all against all finds."""
    from scipy.spatial import cKDTree
    bnd0, tree0, n_first = first
    added = np.arange(n_first, len(X))                       # split in since the first round
    recent = added[added >= n_old]
    fresh = (a >= n_old) | (b >= n_old)
    old, new = np.flatnonzero(~fresh), np.flatnonzero(fresh)
    k_old, _ = _in_ellipses(X, a[old], b[old], cKDTree(X[recent]) if len(recent) else None,
                            recent, anisotropy, P)
    k_new, _ = _in_ellipses(X, a[new], b[new], tree0, bnd0, anisotropy, P)
    k_add, _ = _in_ellipses(X, a[new], b[new], cKDTree(X[added]) if len(added) else None,
                            added, anisotropy, P)
    return np.concatenate([old[k_old], new[k_new], new[k_add]])


def _mirrors_of_boundary_points(domain, P, X, a, b, edge_id, sharp, anisotropy, new):
    """`new`, the split points of the subsegments a→b, with the mirror (corners.mirrored) of the
    first boundary point (lowest index) in the ellipse of each subsegment on a side of a sharp
    corner: all boundary points are tested for those, so the choice does not depend on which
    of them a round's test looked at (X = P L, metric coordinates)."""
    from scipy.spatial import cKDTree
    n_seeds = len(domain.seeds)
    seg = domain.segments[np.where(a < n_seeds, a, edge_id[a])]
    near = np.flatnonzero(sharp[seg[:, 0]] | sharp[seg[:, 1]])
    if not len(near):
        return new
    bnd = np.flatnonzero((np.arange(len(P)) < n_seeds) | (edge_id >= 0))
    k, j = _in_ellipses(X, a[near], b[near], cKDTree(X[bnd]), bnd, anisotropy, P)
    first = np.full(len(near), len(P), np.int64)
    np.minimum.at(first, k, j)
    hit = first < len(P)
    k = near[hit]
    out = np.array(new)
    out[k] = corners.mirrored(P, a[k], b[k], first[hit], edge_id, np.arange(len(P)) < n_seeds,
                              new[k], domain, sharp, anisotropy)[0]
    return out


def _split_crowded(domain, P, edge_id, pinned, place, anisotropy, size, max_points, deep=None):
    """Constant Q, before a Qhull build: subsegments whose diametral ellipse holds another
    boundary point (or, longer than LONG·h, any point) on the side of Ω split, and the free
    interior points in the ellipse of a shorter one dropped, until no ellipse holds a point.

    A subsegment's apex on the side of Ω (the one the rounds test) lies in its diametral
    ellipse whenever any point of that side does, so this is the fixed point `_conforming`'s
    rounds reach, found with a k-d tree
    instead of one Qhull build per step: across a part thin in the metric each split encroaches
    the opposite side's subsegments in turn, one Qhull build per step before. The points split
    in for another boundary point are pinned, as the rounds pin them. None when the splits
    would pass `max_points` (a corner too sharp for the run): the rounds then find the cause
    (round-off crowding at the corner, or too many points) as they did.
    `deep` (mask, reach): points farther than `reach` (metric) from every segment; when every
    subsegment's disc is narrower, they are left out of the interior points' k-d tree (its
    build was most of this function's time at 1e6 vertices), which cannot change a result."""
    from scipy.spatial import cKDTree
    n_seeds = len(domain.seeds)
    A, Bend = domain.segment_ends
    seg_len2 = np.einsum("ki,ki->k", Bend - A, Bend - A)
    sharp = corners.sharp_seeds(domain, anisotropy)
    L = cholesky2(anisotropy.H)
    X = times2(P, L)
    inner = np.flatnonzero((np.arange(len(P)) >= n_seeds) & (edge_id < 0))
    itree = None
    alive = np.ones(len(P), bool)
    n_old = len(P)           # subsegments with an end at or past n_old are new
    first = None             # the boundary points of the first round and their k-d tree
    for _ in range(MAX_ROUNDS):
        on = edge_id >= 0
        t = np.zeros(len(P))
        t[on] = np.einsum("ki,ki->k", P[on] - A[edge_id[on]], Bend[edge_id[on]] - A[edge_id[on]]) \
            / seg_len2[edge_id[on]]
        a, b = _subsegments(domain, n_seeds, edge_id, t)
        L2 = metric_lengths2(P[a], P[b], anisotropy)
        short = L2 <= (LONG * size) ** 2
        if first is None:          # subsegments only get shorter: the first round's are the longest
            if deep is not None and len(L2) and 0.5 * np.sqrt(L2.max()) < (1 - 1e-6) * deep[1]:
                inner = inner[~deep[0][inner]]
            itree = cKDTree(X[inner]) if len(inner) else None
            bnd = np.flatnonzero((np.arange(len(P)) < n_seeds) | on)
            first = (bnd, cKDTree(X[bnd]), len(P))
            kb, _ = _in_ellipses(X, a, b, first[1], bnd, anisotropy, P)
        else:
            kb = _in_ellipses_since(X, a, b, first, n_old, anisotropy, P)
        # interior points: every long subsegment, and the new ones (short ones were cleared)
        look = np.flatnonzero(~short | (a >= n_old) | (b >= n_old))
        ki, ji = _in_ellipses(X, a[look], b[look], itree, inner, anisotropy, P)
        live = alive[ji]
        ki, ji = look[ki][live], ji[live]
        drop = np.unique(ji[short[ki]])
        split = np.zeros(len(a), bool)
        split[kb] = True
        split[ki[~short[ki]]] = True
        split &= L2 > SHORTEST ** 2
        if not len(drop) and not split.any():
            break
        alive[drop] = False
        a, b = a[split], b[split]
        n = int(alive.sum())
        if max_points is not None and n + len(a) > max_points:
            return None
        new = split_points(P[a], P[b], a < n_seeds, b < n_seeds, anisotropy)
        if sharp.any():
            new = _mirrors_of_boundary_points(domain, P, X, a, b, edge_id, sharp, anisotropy, new)
        n_old = len(P)
        P = np.concatenate([P, new])
        X = np.concatenate([X, times2(new, L)])
        edge_id = np.concatenate([edge_id, np.where(a < n_seeds, a, edge_id[a])])
        pinned = np.concatenate([pinned, np.ones(len(a), bool)])
        place = np.concatenate([place, np.full(len(a), -1, np.int64)])
        alive = np.concatenate([alive, np.ones(len(a), bool)])
    return P[alive], edge_id[alive], pinned[alive], place[alive]


def conforming_delaunay(domain, P: np.ndarray, edge_id: np.ndarray, anisotropy, h: float,
                        max_points: int | None = None, pinned: np.ndarray | None = None,
                        target: int | None = None, rng=None, lattice=None) -> Conforming:
    """The conforming Q-Delaunay triangulation of Ω from scratch (Qhull), restricted to Ω.

    P holds the seeds first (as `domain.seeds`), then points on segments (`edge_id` ≥ 0), then
    interior points. Free interior points that encroach a subsegment of metric length at most
    LONG·h (h the target metric edge length) are dropped (the mesher's insertion stage puts points back where they are missing);
    subsegments that are not edges, are longer, or are encroached by a boundary point are
    split; Qhull runs again until neither happens.
    More than `max_points` points raises TooManySplits (a QmeshError). With a `target` vertex
    count, the splits take the place of as many interior points (drawn with `rng`), and the
    triangulation is built once more without them.
    `lattice` (seeding.Lattice): the last len(lattice) points of P are its points; their
    triangles away from the boundary are then known in closed form (lattice_delaunay.py).
    """
    place = np.full(len(P), -1, np.int64)
    if lattice is not None and len(lattice):
        place[len(P) - len(lattice):] = np.arange(len(lattice))
        lattice = (lattice, lattice_delaunay.deep_points(domain, lattice))
    else:
        lattice = None
    built, place = _conforming(domain, P, edge_id, anisotropy, h, max_points, pinned, place, lattice)
    excess = len(built.P) - target if target is not None else 0
    free = np.flatnonzero((np.arange(len(built.P)) >= len(domain.seeds)) & (built.edge_id < 0))
    if excess <= 0 or not len(free):
        return built
    keep = np.ones(len(built.P), bool)
    keep[rng.choice(free, size=min(excess, len(free)), replace=False)] = False
    return _conforming(domain, built.P[keep], built.edge_id[keep], anisotropy, h, max_points,
                       built.pinned[keep], place[keep], lattice)[0]


def _conforming(domain, P, edge_id, anisotropy, size, max_points, pinned, place, lattice):
    """One conforming build (see conforming_delaunay), and the lattice place of its points."""
    n_seeds = len(domain.seeds)
    A, Bend = domain.segment_ends
    seg_len2 = np.einsum("ki,ki->k", Bend - A, Bend - A)
    is_seed_pt = lambda i: i < n_seeds                                     # noqa: E731
    pinned = np.zeros(len(P), bool) if pinned is None else pinned
    sharp = corners.sharp_seeds(domain, anisotropy)
    if anisotropy.is_constant:
        # a disc (radius ≤ LONG·h/2, centred on the boundary) cannot reach a deep lattice point
        far = None
        if lattice is not None and lattice_delaunay.DEEP * lattice[0].h >= 0.5 * LONG * size:
            far = (place >= 0) & lattice[1][np.maximum(place, 0)]
        keep = _encroaching_free(domain, P, edge_id, anisotropy, size, far)
        P, edge_id, pinned, place = P[keep], edge_id[keep], pinned[keep], place[keep]
    presplit = anisotropy.is_constant
    kept = None          # a metric without s: the last round's triangulation, its splits made
    for _ in range(MAX_ROUNDS):
        deep = None if lattice is None else ((place >= 0) & lattice[1][np.maximum(place, 0)],
                                             lattice_delaunay.DEEP * lattice[0].h)
        crowded = _split_crowded(domain, P, edge_id, pinned, place, anisotropy, size,
                                 max_points, deep) if presplit else None
        if crowded is None:
            presplit = False          # past the run's points: the rounds name the cause
        else:
            P, edge_id, pinned, place = crowded
        n = len(P)
        t = np.zeros(n)
        on = edge_id >= 0
        t[on] = np.einsum("ki,ki->k", P[on] - A[edge_id[on]], Bend[edge_id[on]] - A[edge_id[on]]) \
            / seg_len2[edge_id[on]]
        a, b = _subsegments(domain, n_seeds, edge_id, t)
        closed = None if lattice is None else lattice_delaunay.closed_form(lattice[0], place, lattice[1])
        if kept is not None:
            T, twin = kept
        else:
            try:
                T, twin = first_triangulation(P, anisotropy,
                                              (np.arange(n) < n_seeds) | (edge_id >= 0), closed)
            except Crowded:
                raise SharpCorner(*sharpest_corner(domain, anisotropy), n) from None
        kept = None
        h = topology.find_half_edges(T, n, a, b)
        missing = h < 0
        apex = np.where(missing, 0, T.ravel()[np.where(missing, 0, (h - h % 3) + topology.PRV[h % 3])])
        enc = ~missing & encroached(P[a], P[b], P[apex], anisotropy)
        L2 = metric_lengths2(P[a], P[b], anisotropy)
        # an interior apex of a short subsegment is dropped; a long one (its ellipse would hold
        # many interior points) is split, as is one encroached by a boundary point
        free = (apex >= n_seeds) & (edge_id[apex] < 0) & (L2 <= (LONG * size) ** 2)
        drop = np.unique(apex[enc & free])
        split = missing | (enc & ~free)
        split &= L2 > SHORTEST ** 2
        if not len(drop) and not split.any():
            rows = np.flatnonzero(inside_triangles(T, twin, h))
            used = np.zeros(n, bool)
            used[T[rows].ravel()] = True
            if not used.all():
                raise QmeshError(f"{int((~used).sum())} points lie outside the domain; "
                                 "please report this domain")
            T, twin = _canonical_order(T, twin, rows)
            return Conforming(P, T, twin, edge_id, pinned), place
        incremental = not anisotropy.potential and not len(drop) and not missing[split].any()
        if incremental:      # only edges to split: split them in place (one per triangle)
            split &= _one_per_triangle(h, twin, split)
        hs = h[split]
        crowd = ~missing[split] & ~free[split]              # split for another boundary point
        a, b, by = a[split], b[split], apex[split]
        if max_points is not None and n + len(a) > max_points:
            raise _too_many(n + len(a), max_points)
        new = split_points(P[a], P[b], is_seed_pt(a), is_seed_pt(b), anisotropy)
        mirror = crowd & (is_seed_pt(by) | (edge_id[by] >= 0))
        if sharp.any() and mirror.any():
            new[mirror] = corners.mirrored(P, a[mirror], b[mirror], by[mirror], edge_id,
                                           np.arange(n) < n_seeds, new[mirror], domain, sharp,
                                           anisotropy)[0]
        new_seg = np.where(a < n_seeds, a, edge_id[a])        # seed k starts segment k
        keep = np.ones(n, bool)
        keep[drop] = False
        P = np.concatenate([P[keep], new])
        edge_id = np.concatenate([edge_id[keep], new_seg])
        pinned = np.concatenate([pinned[keep], crowd])
        place = np.concatenate([place[keep], np.full(len(new), -1, np.int64)])
        if incremental:
            kept = _split_in_place(P, T, twin, hs, n, anisotropy)
    raise QmeshError("the conforming triangulation did not settle; please report this domain")


def _one_per_triangle(h, twin, split):
    """Which of the half-edges h[split] to split now: each the first of those touching its
    triangles (the others wait for the next round, which finds them again)."""
    k = np.flatnonzero(split)
    g = twin[h[k]]
    t1, t2 = h[k] // 3, np.where(g >= 0, g // 3, h[k] // 3)
    first = np.full(int(max(t1.max(), t2.max())) + 1 if len(k) else 0, len(k))
    order = np.arange(len(k))
    np.minimum.at(first, t1, order)
    np.minimum.at(first, t2, order)
    out = np.zeros(len(h), bool)
    out[k[(first[t1] == order) & (first[t2] == order)]] = True
    return out


def _split_in_place(P, T, twin, hs, n, anisotropy):
    """The triangulation with the edges hs split at the points n, n + 1, … of P (one per
    triangle), made locally regular again around them by `restore`'s flips: a round that only
    splits encroached subsegments (a metric without s, whose boundary crowds itself across a
    part thin in the metric: a chain of splits) needs no Qhull build from scratch."""
    p = n + np.arange(len(hs))
    inner = twin[hs] >= 0
    if inner.any():
        T, twin = topology.split_edges(T, twin, hs[inner], p[inner])
    if (~inner).any():
        T, twin = topology.split_boundary_edges(T, twin, hs[~inner], p[~inner])
    mark = np.zeros(len(P), bool)
    mark[p] = True
    rows = np.flatnonzero(topology.touching(T, mark))
    T, twin, _ = restore(P, T, twin, anisotropy, candidates=(3 * rows[:, None] + np.arange(3)).ravel(),
                         owned=len(hs) > 0)          # the splits made T and twin anew
    return T, twin


# --------------------------------------------------------------------------- kept connectivity

@dataclass
class Conformed:
    P: np.ndarray
    T: np.ndarray
    twin: np.ndarray
    edge_id: np.ndarray
    fixed: np.ndarray
    pinned: np.ndarray      # boundary points that do not slide (see restore_conformity)
    added: np.ndarray       # indices of the boundary points split in
    flips: int


def _push_out(P, a, b, c, anisotropy):
    """Positions just outside the diametral ellipse of a→b for the apexes c (metric at the
    midpoint): along the metric ray from the midpoint, or along the inward normal."""
    A, B, C = P[a], P[b], P[c]
    M = 0.5 * (A + B)
    H = metric_at(anisotropy, M)
    E, D = B - A, C - M
    R = 0.5 * np.sqrt(np.einsum("ki,kij,kj->k", E, H, E))
    r = np.sqrt(np.einsum("ki,kij,kj->k", D, H, D))
    normal = np.column_stack([-E[:, 1], E[:, 0]])
    nlen = np.sqrt(np.einsum("ki,kij,kj->k", normal, H, normal))
    D = np.where((r > 1e-3 * R)[:, None], D / np.maximum(r, 1e-300)[:, None], normal / nlen[:, None])
    return M + (PUSH * R)[:, None] * D


def _kept_pushes(P, T, k, c, to):
    """The pushes k (apexes c[k] sent to `to`) that keep every triangle of their stars, P with
    them applied (a copy, where any is kept), and those stars (rows of T). Checked again after
    each refusal: a triangle with two pushed corners was judged with both moved, and may fold
    when only one of them moves."""
    while len(k):
        Pn = P.copy()
        Pn[c[k]] = to
        star = _stars(T, c[k], len(P))
        ok_t = signed_areas(Pn, T[star]) > MIN_KEPT * signed_areas(P, T[star])
        bad_v = np.zeros(len(P), bool)
        bad_v[T[star[~ok_t]].ravel()] = True
        keep = ~bad_v[c[k]]
        if keep.all():
            return k, Pn, star
        k, to = k[keep], to[keep]
    return k, P, np.empty(0, np.int64)


def _stars(T, v, n):
    """The triangles that have a vertex among v (n vertices in all), in order."""
    mark = np.zeros(n, bool)
    mark[v] = True
    return np.flatnonzero(topology.touching(T, mark))


def restore_conformity(P, T, twin, edge_id, fixed, pinned, anisotropy,
                       max_points: int | None = None, domain=None) -> Conformed:
    """Make no boundary half-edge of a constrained Q-Delaunay triangulation of Ω encroached.

    An interior vertex that encroaches the subsegment it faces is pushed just outside its
    diametral ellipse when that keeps every triangle of its star (it adds no vertex, and the
    boundary keeps its own spacing); otherwise the subsegment is split and the new point slides
    on its segment. Flips follow each round. A point split in because another boundary vertex
    encroached (two segments meeting at a small metric angle, or facing each other across a
    thin part) is pinned: it stays at its concentric-shell distance instead of sliding, which
    would undo the matching splits and start them again at every iteration. With the `domain`,
    a subsegment encroached by a boundary point across a corner sharp in the metric is split at
    that point's mirror (corners.py), and that point is pinned too.
    """
    n0, flips = len(P), 0
    sharp = None if domain is None else corners.sharp_seeds(domain, anisotropy)
    corner = edge_id.copy()
    corner[fixed] = np.flatnonzero(fixed)                   # seed k starts segment k
    check = None          # the boundary half-edges a round tests (None: all of them)
    for rounds in range(MAX_ROUNDS):
        hb = np.flatnonzero(twin < 0) if check is None else check[twin[check] < 0]
        tb, eb = np.divmod(hb, 3)
        a, b, c = T[tb, eb], T[tb, topology.NXT[eb]], T[tb, topology.PRV[eb]]
        enc = encroached(P[a], P[b], P[c], anisotropy)
        enc &= metric_lengths2(P[a], P[b], anisotropy) > SHORTEST ** 2
        if not enc.any():
            break
        hb, a, b, c, tb = hb[enc], a[enc], b[enc], c[enc], tb[enc]
        left = hb                 # what this round leaves encroached is tested again
        # interior apexes: pushed out when their star stays valid (one edge per vertex)
        free = (edge_id[c] < 0) & ~fixed[c] & (rounds < PUSH_ROUNDS)
        moved = np.zeros(len(hb), bool)
        if free.any():
            k = np.flatnonzero(free)
            _, first = np.unique(c[k], return_index=True)
            k = k[first]
            k, Pn, stars = _kept_pushes(P, T, k, c, _push_out(P, a[k], b[k], c[k], anisotropy))
            if len(k):
                P = Pn                           # a copy: the caller's P stays as it was
                moved[k] = True
                moved |= np.isin(c, c[k])
                cand = (3 * stars[:, None] + np.arange(3)).ravel()
                rows = [stars]
                T, twin, f = restore(P, T, twin, anisotropy, candidates=cand, rewritten=rows)
                flips += f
                check = _changed(rows, left)
                continue
        # the rest: split, at most one half-edge per triangle
        keep = ~moved
        hb, a, b, c, tb = hb[keep], a[keep], b[keep], c[keep], tb[keep]
        _, first = np.unique(tb, return_index=True)
        hb, a, b, c = hb[first], a[first], b[first], c[first]
        n = len(P)
        if max_points is not None and n + len(hb) > max_points:
            raise _too_many(n + len(hb), max_points)
        new = split_points(P[a], P[b], fixed[a], fixed[b], anisotropy)
        if sharp is not None and sharp.any():
            by = np.flatnonzero(fixed[c] | (edge_id[c] >= 0))     # split for a boundary point
            new[by], made = corners.mirrored(P, a[by], b[by], c[by], edge_id, fixed, new[by],
                                             domain, sharp, anisotropy)
            pinned = pinned.copy()
            pinned[c[by[made]]] = True                    # the point mirrored stays matched
        T, twin = topology.split_boundary_edges(T, twin, hb, n + np.arange(len(hb)))
        seg = corner[a]
        P = np.concatenate([P, new])
        edge_id = np.concatenate([edge_id, seg])
        corner = np.concatenate([corner, seg])
        fixed = np.concatenate([fixed, np.zeros(len(hb), bool)])
        pinned = np.concatenate([pinned, fixed[c] | (edge_id[c] >= 0)])
        touched = np.concatenate([hb // 3, len(T) - len(hb) + np.arange(len(hb))])
        cand = (3 * touched[:, None] + np.arange(3)).ravel()
        rows = [touched]
        T, twin, f = restore(P, T, twin, anisotropy, candidates=cand, rewritten=rows,
                             owned=len(hb) > 0)      # the splits made T and twin anew
        flips += f
        check = _changed(rows, left)
    return Conformed(P, T, twin, edge_id, fixed, pinned, np.arange(n0, len(P)), flips)


def _changed(rows, left):
    """The half-edges a round of `restore_conformity` must test after it: those of the triangles
    it split, added, moved a vertex of, or flipped (`rows`: arrays of rows of T, as the round
    and `restore(rewritten=…)` list them, not a comparison of every row), and the ones it left
    encroached (`left`). No other half-edge's triangle or apex changed, so the encroached ones
    found are those a test of every boundary half-edge finds, in the same order (a row flipped
    back as it was is tested again, and found as before)."""
    tri = np.concatenate(rows)
    return topology.sorted_unique(np.concatenate([(3 * tri[:, None] + np.arange(3)).ravel(), left]))
