"""Initial interior points for a varying s: hexagonal lattices in the local metric, patch by patch.

For a constant Q the start is the metric lattice (seeding.py): the optimal mesh is equilateral
in the metric, and a random start freezes lattice defects that the vertex step cannot anneal.
A varying s has no global lattice, but the metric ∇²s changes slowly on the scale of a few
edges, so a lattice per patch is nearly optimal inside the patch:

1. patches tile the seeds' bounding box in y = x L̄ (L̄L̄ᵀ the mean Hessian over Ω), PATCH
   lattice spacings wide; each carries the hexagonal lattice of metric spacing h in the metric
   at its centre (basis H_c^{-1/2}, so neighbouring lattices have nearly the same orientation),
   reaching past the patch so that neighbours overlap; points outside Ω or closer than MARGIN·h
   (metric) to its boundary are dropped;
2. two points conflict when closer than CONFLICT·h in the metric ½(H_i + H_j) (a KD-tree in
   y-coordinates, binned by search reach);
3. a maximal independent set of the conflict graph (Luby's rounds, vectorised) keeps every
   patch's core and fills the seams from whichever lattice fits;
4. h comes from the metric area ∫√det ∇²s (Monte Carlo) and is rescaled from the count; a
   tensor field's first draw expects the seams to cost a share of it (`initial_points`), a
   large field's share foretold from a draw of some of its patches (`_pilot`).
It uses only `domain.contains`, `domain.seeds` and the seeds' bounds.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from qmesh.errors import QmeshError

from qmesh.geometry import rings
from qmesh.geometry.portable import (arctan2, ceil_pow2_steps, cholesky2, eigh2, floor_log2,
                                     floor_log2_steps, inv2, log, round_log2, times2)
from qmesh.mesher import seeding
from qmesh.mesher import sizing

PATCH = 6.0           # lattice patches span this many lattice spacings (in the mean metric)
OVERLAP = 0.75        # each patch's lattice reaches this share of a patch size from its centre
CONFLICT = 0.9        # points closer than this many spacings (metric) conflict
MARGIN = 0.5          # points keep this many spacings (metric) inside Ω
PASSES = 3            # draws to land the count
KEPT = 0.87           # a tensor field's first draw expects the merge to keep this share of the
                      # lattices' count (0.66-0.89 on the fields benchmark at 2e4, above 1 for
                      # some at 2e3: a draw too many is drawn again)
AIM = 0.985           # a field's later draw aims this far below n: its share kept drifts with h
SHORT = 0.04          # a field's draw short of n by at most this share is kept (one 22% short,
                      # left for the insertions to fill, doubled the repair's vertices on fvca5
                      # at 2e3 and lowered its mean quality)
RESCALE = 2.0         # a field's later draw changes h by at most this factor
OVER = 0.015          # a field's draw over n by at most this share is kept (thinned at random)
PILOT_SHARE = 0.25    # a large field's first spacing is foretold from a draw of this share of
                      # its patches: all those near the boundary (windows alone, their share
                      # of boundary patches left to chance, foretold the 512² raster's count
                      # 3-5% low) and windows of PILOT_SIDE² patches at random among the rest,
PILOT_WINDOWS = 12    # at least this many of them, their inner patches PILOT_MARGIN inside
PILOT_SIDE = 7        # (25 each); plasma's, the spiral's and FVCA5's counts come within 3-11%
PILOT_MARGIN = 1      # at 2e5 (their seams change across Ω), the raster's within 1%
PILOT_FROM = 50_000   # from this many points on (below, the draws are as cheap as the foretelling)
MAX_LATTICE = 2e7     # at most about this many lattice points before filtering
LATTICE_CHUNK = 500_000   # lattice points made at once (bounds the memory)
PAIR_CHUNK = 1_000_000    # candidate pairs tested at once (bounds the memory)
FOLLOW = 4.0          # the metric may change this much across one element ...
UNFOLLOWED = 0.08     # ... over at most this share of the metric area


def _sym_eig_min(H: np.ndarray) -> np.ndarray:
    """Smallest eigenvalue of symmetric 2×2 matrices (…, 2, 2)."""
    a, b, c = H[..., 0, 0], H[..., 0, 1], H[..., 1, 1]
    return 0.5 * (a + c) - np.hypot(0.5 * (a - c), b)


def _inv_sqrt_spd(H: np.ndarray) -> np.ndarray:
    """H^{-1/2} of symmetric positive definite 2×2 matrices (n, 2, 2)."""
    w, V = eigh2(H)
    return np.einsum("nij,nj,nkj->nik", V, 1.0 / np.sqrt(w), V)


def _conflicts(X: np.ndarray, H: np.ndarray, r: float, Lbar: np.ndarray):
    """Pairs (i < j) closer than r in the metric ½(H_i + H_j).

    Searched in y = x L̄ (L̄L̄ᵀ the mean metric). With G = H in y-coordinates, λ_min of the
    pair's mean metric is at least ½ max(λ_min(G_i), λ_min(G_j)), so a conflicting pair is
    at most √2·min(reach_i, reach_j) apart in y, reach = r/√λ_min(G): the denser point of a
    pair finds it. Points are binned by reach (factors of 2); each bin searches, with √2 times
    its largest reach, only the points of its own or a sparser bin. Every ball then holds a
    bounded number of points, so the work and memory follow the number of points even where
    the metric changes by orders of magnitude across Ω (searching with the sparser point's reach
    does not: for exp(20x) + exp(20y) on Disk(32) its work and memory grow far faster than N).
    """
    if len(X) < 2:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    Y = times2(X, Lbar)
    Linv = inv2(Lbar)
    G = np.einsum("ji,njk,kl->nil", Linv, H, Linv)
    reach = r / np.sqrt(np.clip(_sym_eig_min(G), 1e-300, None))
    level = floor_log2(reach / reach.min())
    found = []
    for b in np.unique(level):
        src = np.flatnonzero(level == b)
        dst = np.flatnonzero(level >= b)
        radius = float(np.sqrt(2.0) * reach.min() * np.ldexp(1.0, int(b) + 1))
        tree = cKDTree(Y[dst])
        # searchers in chunks of at most PAIR_CHUNK candidates (a strongly anisotropic metric
        # puts whole rows of points in one ball), each chunk filtered at once: bounded memory
        count = np.cumsum(tree.query_ball_point(Y[src], radius, return_length=True))
        cuts = np.searchsorted(count, np.arange(PAIR_CHUNK, count[-1], PAIR_CHUNK))
        for chunk in np.split(src, np.unique(cuts[cuts > 0])):
            p = cKDTree(Y[chunk]).sparse_distance_matrix(tree, radius, output_type="ndarray")
            i, j = chunk[p["i"]], dst[p["j"]]
            keep = (level[j] > b) | (i < j)                 # each pair once
            i, j = np.minimum(i, j)[keep], np.maximum(i, j)[keep]
            E = X[j] - X[i]
            d2 = np.einsum("ni,nij,nj->n", E, 0.5 * (H[i] + H[j]), E)
            found.append(np.column_stack([i, j])[d2 < r * r])
    i, j = np.concatenate(found).T
    return i, j


ORIENTATIONS = 64     # groups of major-axis direction in the oriented conflict search, at most:
                      # about 2 n^¼ for n points (a power of 2, at least 8): fewer groups hold
                      # more candidates, more cost a tree each (16 best at 2.5e3-3.5e3 points:
                      # FVCA5 test 5 27 ms against 49 ms with 8; 32 at 4e4 for it and plasma)
ROUND_METRIC = 16.0   # metrics less anisotropic than this share one group (a tree per group
                      # over all points costs more than their balls holding up to ~4x more)
TREE = dict(leafsize=32, balanced_tree=False, compact_nodes=False)   # one tree per group: fast builds
REACH = 1.01          # search balls this much wider than the ellipse they hold (round-off of λ_min)
COUNT_EVERY = 8       # searchers counted to cut a group's search into parts (one in this many)


def _quadratic(E: np.ndarray, H: np.ndarray) -> np.ndarray:
    """Eᵀ H E for rows E (n, 2) and symmetric H (n, 2, 2)."""
    return H[:, 0, 0] * E[:, 0] ** 2 + 2.0 * H[:, 0, 1] * E[:, 0] * E[:, 1] + H[:, 1, 1] * E[:, 1] ** 2


def _conflicts_oriented(X: np.ndarray, H: np.ndarray, r: float):
    """The pairs of `_conflicts` for a metric whose direction turns across Ω (a tensor field),
    each once as (i < j), in no particular order (the merge does not depend on it).

    A pair conflicts when ½(q_i + q_j) < r², q_k = Eᵀ H_k E, so the point of the smaller q (the
    lower index on a tie) has q < r²: it alone reports the pair, having found it inside its
    own ellipse Eᵀ H E < r², searched in the coordinates of the mean metric of the points whose
    major axis points the same way (up to ORIENTATIONS groups), among every point within that
    ellipse's reach: a ball there is as narrow as the point's own ellipse, where the mean metric
    of a turning field is nearly round and its balls hold a thousand points. Each pair is found
    by the point that reports it (a ball of the ellipse's radius, half the area of one that must
    hold the partner's ellipse too), with no sort or hash of all pairs; the search costs a tree
    per group."""
    a, b, c = H[:, 0, 0], H[:, 0, 1], H[:, 1, 1]
    theta = 0.5 * arctan2(2.0 * b, a - c)                      # the larger eigenvalue's axis
    lmin = np.clip(_sym_eig_min(H), 1e-300, None)
    ratio = (a + c - lmin) / lmin
    k = int(np.clip(np.ldexp(1.0, round_log2(2.0 * np.sqrt(np.sqrt(max(len(X), 1))))), 8, ORIENTATIONS))
    group = np.floor((theta / np.pi + 0.5) * k).astype(np.int64) % k
    group[ratio < ROUND_METRIC] = -1
    n = len(X)
    keys: list = []
    cells: dict = {}
    x, y, h11, h12, h22 = X[:, 0].copy(), X[:, 1].copy(), a.copy(), b.copy(), c.copy()
    by_group = np.argsort(group, kind="stable")          # each group's points, ascending
    names = np.unique(group)
    for g, src in zip(names, np.split(by_group, np.searchsorted(group[by_group], names)[1:])):
        L = cholesky2(H[src].mean(axis=0))
        Linv = inv2(L)
        G = np.einsum("ij,njk,lk->nil", Linv, H[src], Linv)        # L⁻¹ H L⁻ᵀ: H where y = x L
        # the ellipse Eᵀ H_i E < r² lies in the ball of this radius in y (REACH: round-off of
        # λ_min), and within this distance of x_i: the cells of the points it can reach
        radius = REACH * r / np.sqrt(np.clip(_sym_eig_min(G), 1e-300, None))
        cell = REACH * r / np.sqrt(float(lmin[src].min()))
        pool = _near_cells(X, src, cell, cells)
        Yp = times2(X[pool], L)            # the pool only: a group costs its points, not all
        Ys = Yp[np.searchsorted(pool, src)]                   # the searchers are in the pool
        tree = cKDTree(Yp, **TREE)
        # searchers binned by reach (factors of √2), each bin one array-valued search with
        # its largest reach, filtered by each searcher's own: no per-point lists
        level = floor_log2_steps(radius / radius.min(), 2)
        for lev in np.unique(level):
            s, reach, Yb = src[level == lev], radius[level == lev], Ys[level == lev]
            for part in _parts(tree, Yb, reach):
                p = cKDTree(Yb[part], **TREE).sparse_distance_matrix(
                    tree, float(reach[part].max()), output_type="ndarray")
                pi = p["i"]
                ok = p["v"] <= reach[part][pi]
                i, j = s[part][pi[ok]], pool[p["j"][ok]]
                ex, ey = x[j] - x[i], y[j] - y[i]           # `_quadratic`, on columns
                qi = h11[i] * ex ** 2 + 2.0 * h12[i] * ex * ey + h22[i] * ey ** 2
                qj = h11[j] * ex ** 2 + 2.0 * h12[j] * ex * ey + h22[j] * ey ** 2
                mine = (qi < qj) | ((qi == qj) & (i < j))   # the same on j's side, bit for bit
                near = (0.5 * (qi + qj) < r * r) & mine & (i != j)
                i, j = i[near], j[near]
                keys.append(np.column_stack([np.minimum(i, j), np.maximum(i, j)]))
    return tuple(np.concatenate([np.empty((0, 2), np.int64), *keys]).T)


def _parts(tree, Y: np.ndarray, reach: np.ndarray) -> list:
    """The searchers Y (reach each) in consecutive parts of about PAIR_CHUNK candidates in the
    k-d tree: every COUNT_EVERY-th searcher's candidates counted stand for its neighbours' (the
    searchers come patch by patch, neighbours alike), a fraction of a count of them all."""
    every = COUNT_EVERY if len(Y) >= 8 * COUNT_EVERY else 1     # a few: count them all
    count = tree.query_ball_point(Y[::every], reach[::every], return_length=True)
    total = np.cumsum(np.repeat(count, every)[:len(Y)])
    cuts = np.searchsorted(total, np.arange(PAIR_CHUNK, total[-1], PAIR_CHUNK))
    return np.split(np.arange(len(Y)), np.unique(cuts[cuts > 0]))


def _near_cells(X: np.ndarray, src: np.ndarray, cell: float, cache: dict | None = None) -> np.ndarray:
    """The points of X (sorted indices) in the cells of side `cell` next to (or holding) a point
    of X[src]: every point within `cell` of one of them, and a few more. With a `cache` (one per
    X) the side is rounded up to a power of 2^(1/4) and each side's cells are sorted once, so each
    group of the conflict search costs its searchers and its pool, not all of X."""
    if cache is not None:
        cell = ceil_pow2_steps(cell, 4)
    index = None if cache is None else cache.get(cell)
    if index is None:
        lo = X.min(axis=0)
        span = np.floor((X.max(axis=0) - lo) / cell).astype(np.int64) + 3
        if not np.all(np.isfinite(span)) or float(span[0]) * float(span[1]) > 2.0 ** 62:
            return np.arange(len(X))
        c = np.floor((X - lo) / cell).astype(np.int64) + 1
        key = c[:, 0] * span[1] + c[:, 1]
        order = np.argsort(key, kind="stable")
        index = (key, span, order, key[order])
        if cache is not None:
            cache[cell] = index
    key, span, order, sorted_key = index
    around = (np.arange(-1, 2)[:, None] * span[1] + np.arange(-1, 2)[None, :]).ravel()
    wanted = np.unique((np.unique(key[src])[:, None] + around).ravel())
    a, b = np.searchsorted(sorted_key, wanted, "left"), np.searchsorted(sorted_key, wanted, "right")
    count = b - a
    at = np.repeat(a - np.cumsum(count) + count, count) + np.arange(int(count.sum()))
    return np.sort(order[at])


def _luby(n: int, i: np.ndarray, j: np.ndarray, rng, priority=None) -> np.ndarray:
    """A maximal independent set of the graph on n nodes with edges (i, j): boolean mask.

    Lower `priority` wins a conflict (random when None)."""
    order = rng.permutation(n) if priority is None else np.lexsort((rng.random(n), priority))
    prio = np.empty(n, np.int64)
    prio[order] = np.arange(n)
    state = np.zeros(n, np.int8)                  # 0 undecided, 1 kept, −1 dropped
    while True:
        live = (state[i] == 0) & (state[j] == 0)
        a, b = i[live], j[live]
        best = prio.copy()                          # lowest priority among undecided neighbours
        np.minimum.at(best, a, prio[b])
        np.minimum.at(best, b, prio[a])
        undecided = state == 0
        if not undecided.any():
            return state == 1
        win = undecided & (best == prio)
        state[win] = 1
        drop = np.zeros(n, bool)
        drop[a[win[b]]] = True
        drop[b[win[a]]] = True
        state[drop & (state == 0)] = -1


def _mean_metric(domain, anisotropy, rng) -> np.ndarray:
    """L̄ with L̄L̄ᵀ the mean Hessian over random points of Ω (the coordinates of the search)."""
    X = seeding.random_interior(domain, 512, rng)
    return cholesky2(np.asarray(anisotropy.hessian(X), dtype=float).mean(axis=0))


def _inside_with_margin(domain, X, H, margin: float) -> np.ndarray:
    """Points whose six probes at metric distance `margin` (x + margin·H^{-1/2} u) are inside Ω.
    A point inside Ω and farther from its boundary than its longest probe (margin / √λ_min(H))
    has them all inside: only the points nearer the boundary are probed."""
    out = domain.contains(X, tol=0.0)
    longest = margin / np.sqrt(np.clip(_sym_eig_min(H), 1e-300, None))
    A, Bs = domain.segment_ends
    reach = 2.0 * float(longest.max(initial=0.0))
    near = np.flatnonzero(out & ~(rings.distance(X, A, Bs, reach) > 1.01 * longest))
    t = np.pi * np.arange(6) / 3
    U = np.column_stack([np.cos(t), np.sin(t)])
    probes = X[near, None, :] + margin * np.einsum("nij,kj->nki", _inv_sqrt_spd(H[near]), U)
    out[near] = domain.contains(probes.reshape(-1, 2), tol=0.0).reshape(len(near), 6).all(axis=1)
    return out


def _patch_lattices(domain, anisotropy, h: float, Lbar: np.ndarray, select=None):
    """Hexagonal lattices of metric spacing h, one per patch, each in the metric at its centre.

    Patches tile the seeds' bounding box in y = x L̄; each lattice reaches OVERLAP·PATCH·h from
    its centre so neighbours overlap. Returns the points, their Hessians and their priority
    (distance from their own patch centre in patch half-sizes: the core of a patch wins).
    `select(ok, deep, shape)`: the patches to build, a mask of the grid (shape: patches along
    y₁, y₂) given the masks of those that reach Ω (`ok`) and of those whose lattice and its
    neighbours' lie inside it (`deep`) (`_pilot`); the lattices are those of the whole.
    """
    S = PATCH * h
    Y0 = times2(domain.seeds, Lbar)
    lo, hi = Y0.min(axis=0), Y0.max(axis=0)
    gx = lo[0] + S * (np.arange(int(np.ceil((hi[0] - lo[0]) / S)) + 1)) - 0.5 * S
    gy = lo[1] + S * (np.arange(int(np.ceil((hi[1] - lo[1]) / S)) + 1)) - 0.5 * S
    Yc = np.stack(np.meshgrid(gx, gy, indexing="ij"), axis=-1).reshape(-1, 2)
    Linv = inv2(Lbar)
    Xc = times2(Yc, Linv)
    with np.errstate(all="ignore"):
        Hc = np.asarray(anisotropy.hessian(Xc), dtype=float)
    ok = np.all(np.isfinite(Hc), axis=(1, 2)) & (Hc[:, 0, 0] > 0) & \
        (Hc[:, 0, 0] * Hc[:, 1, 1] - Hc[:, 0, 1] ** 2 > 0)
    # only patches that reach Ω: the cost follows Ω's area, not its bounding box's
    A, Bs = domain.segment_ends
    reach = float(np.abs(Linv).sum(axis=0).max()) * S
    near = np.isfinite(rings.distance(Xc, A, Bs, reach))
    deep = domain.contains(Xc, tol=0.0)
    ok &= deep | near
    deep &= ok & ~near                     # farther inside Ω than a patch is wide
    Yc, Xc, Hc = Yc[ok], Xc[ok], Hc[ok]
    B = _inv_sqrt_spd(Hc)                                          # lattice basis: H^{-1/2}
    # lattice steps needed to reach OVERLAP·S in y: the shortest y-length of a unit metric step
    YB = np.einsum("kij,jl->kil", np.transpose(B, (0, 2, 1)), Lbar)  # rows: y-image of the metric axes
    shortest = np.sqrt(np.clip(_sym_eig_min(np.einsum("kij,klj->kil", YB, YB)), 1e-300, None))
    rho = OVERLAP * S * np.sqrt(2.0) / (h * shortest)           # the box's reach, in steps
    m = int(np.ceil(rho.max()) + 1)
    m = max(2, min(m, 60, int(np.sqrt(MAX_LATTICE / len(Xc)) / 2)))   # bounded work
    if select is not None:     # some patches only, each lattice as in the whole set's
        some = select(ok, deep, (len(gx), len(gy)))[ok]
        Yc, Xc, B, rho = Yc[some], Xc[some], B[some], rho[some]
    # each patch only as many steps as cover its own box (a lattice of |i|, |j| ≤ m holds the
    # metric disc of radius m·√3/2 steps): the same points as m everywhere, in the same order,
    # at a cost that follows the points kept where the metric varies by orders of magnitude
    mk = np.minimum(m, np.maximum(2, np.ceil(rho * 2.0 / np.sqrt(3.0)).astype(np.int64) + 1))
    side = 2 * m + 1
    # only the lattice points in each patch's box: point (i, j) lies i·u + j·v from the centre in
    # y, so each row i of patch k holds the j of an interval (a strongly anisotropic local metric
    # against a nearly round mean one keeps a thin strip of the (2m + 1)² square)
    u = h * times2(B[:, :, 0], Lbar)
    v = 0.5 * u + (np.sqrt(3.0) / 2.0) * h * times2(B[:, :, 1], Lbar)
    k, i = _rows(mk)
    slack = 1e-6 * OVERLAP * S + 1e-12 * float(np.abs(Yc).max(initial=0.0))   # round-off of y
    lo, hi = _strip(i, u[k], v[k], OVERLAP * S + slack)
    lo, hi = np.maximum(lo, -mk[k]), np.minimum(hi, mk[k])
    count = np.maximum(hi - lo + 1, 0)
    parts = []
    ends = np.cumsum(count)
    cuts = np.searchsorted(ends, np.arange(LATTICE_CHUNK, ends[-1] if len(ends) else 0, LATTICE_CHUNK))
    for rows in np.split(np.arange(len(k)), np.unique(cuts[cuts > 0])):   # bounded memory
        c = count[rows]
        r = np.repeat(rows, c)
        j = lo[r] + np.arange(len(r)) - np.repeat(np.cumsum(c) - c, c)
        kc, ic = k[r], i[r]
        Z0, Z1 = h * (ic + 0.5 * j), h * (np.sqrt(3.0) / 2.0 * j)
        X = np.empty((len(r), 2))
        for a in (0, 1):          # Xc + B Z, the two products summed as einsum does
            X[:, a] = Xc[kc, a] + (B[kc, a, 0] * Z0 + B[kc, a, 1] * Z1)
        d = np.abs(times2(X, Lbar) - Yc[kc]).max(axis=1) / (0.5 * S)
        keep = d <= 2.0 * OVERLAP
        key = kc * side * side + (ic + m) * side + (j + m)
        parts.append((X[keep], d[keep], key[keep]))
    X, d, key = (np.concatenate(a) for a in zip(*parts))
    order = np.argsort(key, kind="stable")
    X, d = X[order], d[order]
    inside = domain.contains(X, tol=0.0)
    X, d = X[inside], d[inside]
    H = np.asarray(anisotropy.hessian(X), dtype=float)
    return X, H, d


def _rows(mk: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every row (patch k, i) of the patches' lattices, |i| ≤ mk[k], k then i ascending."""
    n = 2 * mk + 1
    k = np.repeat(np.arange(len(mk)), n)
    return k, np.arange(len(k)) - np.repeat(np.cumsum(n) - n, n) - mk[k]


def _strip(i: np.ndarray, u: np.ndarray, v: np.ndarray, R: float) -> tuple[np.ndarray, np.ndarray]:
    """The integers j (an interval lo..hi, empty when lo > hi) with |i u + j v|_∞ ≤ R, per row
    (i (n,), u and v (n, 2))."""
    lo, hi = np.full(len(i), -np.inf), np.full(len(i), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        for c in (0, 1):
            a = (-R - i * u[:, c]) / v[:, c]
            b = (R - i * u[:, c]) / v[:, c]
            flat = v[:, c] == 0                      # no j reaches, or every j does
            out = flat & (np.abs(i * u[:, c]) > R)
            a = np.where(flat, np.where(out, np.inf, -np.inf), a)
            b = np.where(flat, np.where(out, -np.inf, np.inf), b)
            lo, hi = np.maximum(lo, np.minimum(a, b)), np.minimum(hi, np.maximum(a, b))
    big = float(2 ** 40)
    return (np.ceil(np.clip(lo, -big, big)).astype(np.int64),
            np.floor(np.clip(hi, -big, big)).astype(np.int64))


def _variation(domain, anisotropy, h: float, rng, samples: int = 2048):
    """How much the metric changes across one element of metric size h, where the points go.

    At random points of Ω (weighted by their metric area √det ∇²s: the share of the mesh's
    vertices near them), along each principal direction v of H(x), the metric length of that
    direction is compared at x ± ½ℓv, ℓ = h/√λ the element's Euclidean extent that way.
    Returns (the largest factor per sample, the sample points, their weights).
    """
    X = seeding.random_interior(domain, samples, rng)
    with np.errstate(all="ignore"):
        H = np.asarray(anisotropy.hessian(X), dtype=float)
        lam, V = eigh2(np.where(np.isfinite(H), H, 0.0))
        w = np.sqrt(np.clip(lam[:, 0] * lam[:, 1], 0.0, None))
        factor = np.ones(len(X))
        for k in (0, 1):
            v = V[:, :, k]
            ell = h / np.sqrt(np.clip(lam[:, k], 1e-300, None))
            for sign in (-0.5, 0.5):
                Hp = np.asarray(anisotropy.hessian(X + sign * ell[:, None] * v), dtype=float)
                ratio = np.einsum("ni,nij,nj->n", v, Hp, v) / np.clip(lam[:, k], 1e-300, None)
                ratio = np.where(np.isfinite(ratio) & (ratio > 0), ratio, np.inf)
                factor = np.maximum(factor, np.sqrt(np.maximum(ratio, 1.0 / ratio)))
    return factor, X, w


def _check_followable(domain, anisotropy, h: float, n: int) -> None:
    """QmeshError, in well under a second, when the metric changes more than FOLLOW× across one
    element over more than UNFOLLOWED of Ω's metric area (where the vertices go), and following
    it would take more than twice the vertices (elements shrink as 1/√N): no mesh of this
    size can follow s there (s = exp(20x) + exp(20y) on Disk(32) at N = 3000: 10%; the
    smooth cases of the tests stay below 6% even at N = 30)."""
    factor, _, w = _variation(domain, anisotropy, h, np.random.default_rng(0))
    if not w.sum() > 0:
        return
    share = float((w * (factor > FOLLOW)).sum() / w.sum())
    if share <= UNFOLLOWED:
        return
    order = np.argsort(factor)
    cum = np.cumsum(w[order]) / w.sum()
    f = float(factor[order][min(np.searchsorted(cum, 1.0 - UNFOLLOWED), len(order) - 1)])
    more = n * float(log(f) / log(FOLLOW)) ** 2 if np.isfinite(f) else np.inf
    if more <= 2 * n:       # nearly followable: the insertions and the vertex step will cope
        return
    advice = (f"about {more:.2g} interior vertices would follow it" if np.isfinite(more)
              and more < sizing.MAX_VERTICES else "no mesh of a usable size would follow it")
    raise QmeshError(f"s varies faster than a mesh of {n} interior vertices can follow: over "
                     f"{100 * share:.0f}% of the domain's metric area its Hessian changes more than "
                     f"{FOLLOW:g}× across one element; {advice} (ask for more vertices: a larger "
                     f"target_vertices or a smaller size; or a gentler s)")


def _draw(domain, anisotropy, h: float, Lbar: np.ndarray, rng, field: bool, select=None):
    """The patch lattices at spacing h merged: their points inside Ω kept by the maximal
    independent set of their conflicts."""
    X, H, prio = _patch_lattices(domain, anisotropy, h, Lbar, select)
    inside = _inside_with_margin(domain, X, H, MARGIN * h)
    X, H, prio = X[inside], H[inside], prio[inside]
    i, j = (_conflicts_oriented(X, H, CONFLICT * h) if field
            else _conflicts(X, H, CONFLICT * h, Lbar))
    return X[_luby(len(X), i, j, rng, prio)]


def _pilot(domain, anisotropy, h: float, Lbar: np.ndarray) -> float | None:
    """The count a tensor field's draw at spacing h would keep, foretold from a draw of some
    of its patches (its own generator): every patch near the boundary (kept points counted
    there) and windows of PILOT_SIDE² patches at random among the deep ones (the points kept
    per inner patch, whose neighbours are all drawn, times the deep patches), PILOT_SHARE of
    the patches in all. None when that leaves room for fewer than PILOT_WINDOWS windows.

    The share of the lattices a draw keeps depends on the field (0.65-0.9 of the metric area's
    count: the seams between patches), so a large field's first draw missed its count and was
    drawn again, the whole cost of a first triangulation twice (the 512² raster at 1e6)."""
    chosen: dict = {}
    S = PATCH * h

    def grow(mask, by):
        """`mask` and its neighbours up to `by` patches away (Chebyshev), on the grid."""
        out = np.zeros_like(mask)
        padded = np.pad(mask, by)
        for dx in range(2 * by + 1):
            for dy in range(2 * by + 1):
                out |= padded[dx:dx + mask.shape[0], dy:dy + mask.shape[1]]
        return out

    def windows(ok, deep, shape):
        grid, deep = ok.reshape(shape), deep.reshape(shape)
        edge = grid & ~deep
        build = grow(edge, PILOT_MARGIN) & grid
        count = int((PILOT_SHARE * ok.sum() - build.sum()) // PILOT_SIDE ** 2)
        if count < PILOT_WINDOWS or count > deep.sum():
            return np.zeros_like(ok)
        cells = np.column_stack(np.nonzero(deep))
        at = cells[np.random.default_rng(0).choice(len(cells), count, replace=False)]
        centre = np.zeros(shape, bool)
        centre[at[:, 0], at[:, 1]] = True
        inner = grow(centre, PILOT_SIDE // 2 - PILOT_MARGIN) & deep
        build |= grow(inner, PILOT_MARGIN) & grid
        chosen.update(inner=inner, edge=edge, deep=int(deep.sum()))
        return build.ravel()

    P = _draw(domain, anisotropy, h, Lbar, np.random.default_rng(0), True, windows)
    if not chosen:
        return None
    # the patch of each kept point: its square of side S in y, centred at lo − S/2 + S·index
    lo = times2(domain.seeds, Lbar).min(axis=0)
    at = np.floor((times2(P, Lbar) - lo) / S).astype(np.int64) + 1
    inner, edge = chosen["inner"], chosen["edge"]
    fits = np.all((at >= 0) & (at < np.array(inner.shape)), axis=1)
    at = at[fits]
    per_inner = inner[at[:, 0], at[:, 1]].sum() / inner.sum()
    return float(edge[at[:, 0], at[:, 1]].sum() + per_inner * chosen["deep"])


def initial_points(domain, anisotropy, n: int, rng) -> np.ndarray:
    """About n (never more) interior points: patch lattices in the local metric, merged by a
    maximal independent set that prefers each patch's core.

    For a varying s the draws land within 3% of n. A tensor field's draws (no s) land between
    SHORT below and OVER above n: the first expects the merge to keep KEPT of the lattices'
    count (from PILOT_FROM points on, the share foretold by `_pilot`), a later one the share
    the last draw kept (each draw is most of the cost of a field's first triangulation: one
    where KEPT holds, two for most fields, instead of two or three)."""
    n = int(n)
    if n < 1:
        return np.empty((0, 2))
    Lbar = _mean_metric(domain, anisotropy, rng)
    area_m = sizing.metric_area(domain, anisotropy)
    cell = np.sqrt(3.0) / 2.0                         # lattice area per point is cell·h²
    field = not anisotropy.potential
    h = np.sqrt((KEPT if field else 1.0) * area_m / (cell * n))
    if not field:                # a tensor field's mesh is certified on its means instead
        _check_followable(domain, anisotropy, h, n)
    low, high = ((1.0 - SHORT) * n, (1.0 + OVER) * n) if field else (0.97 * n, 1.03 * n)
    if field and n >= PILOT_FROM:        # a large field's count foretold on some of its patches
        foretold = _pilot(domain, anisotropy, h, Lbar)
        if foretold is not None:
            h *= np.clip(np.sqrt(max(foretold, 1.0) / (AIM * n)), 1.0 / RESCALE, RESCALE)
    best = np.empty((0, 2))
    for _ in range(PASSES):
        P = _draw(domain, anisotropy, h, Lbar, rng, field)
        if abs(len(P) - n) < abs(len(best) - n):
            best = P
        if low <= len(P) <= high:
            break
        if field:    # the seams lose a share of the count that changes slowly with h (the
            # patches are PATCH·h wide): the next h keeps this draw's share, aimed AIM low, by
            # at most a factor RESCALE (a raster cell of 1e14 : 1 holds nearly all the metric
            # area and the merge kept 4 of 182 points: h / 6.7 made 50 000 lattice points
            # whose conflicts took 19 s, for a field the repair then refuses)
            h *= np.clip(np.sqrt(max(len(P), 1) / (AIM * n)), 1.0 / RESCALE, RESCALE)
            continue
        # the count is (area_m − band·h) / (cell·h²): the margin and the seams lose a band whose
        # metric length this pass measures; solve cell·n·h² + band·h = area_m for the next h
        band = max((area_m - len(P) * cell * h * h) / h, 0.0)
        h = (-band + np.sqrt(band * band + 4.0 * cell * n * area_m)) / (2.0 * cell * n)
    if len(best) > n:
        best = best[rng.choice(len(best), n, replace=False)]
    return best
