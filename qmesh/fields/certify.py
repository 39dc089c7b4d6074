"""Certify and repair: every q_ij ≥ 0 with the stiffness matrix assembled from the element means.

FIELDS.md §2–4. For P1 elements only the element means Q̄_T = (1/|T|)∫_T Q enter the stiffness
matrix, and the share of triangle T in the off-diagonal of its edge ij (k the opposite corner) is

    q_ij^T = −K_ij^T = −e_iᵀ adj(Q̄_T) e_j / (4|T|) = ½ √det Q̄_T · cot θ_k(adj Q̄_T),

e_i the edge vector opposite corner i (∇φ_i = J e_i / 2|T|, Jᵀ Q J = adj Q). An edge passes when
q_ij = Σ_T q_ij^T (two triangles inside, one on the boundary) is ≥ 0 by more than the error the
means carry (their quadrature's bound, ‖δQ̄‖·|e_i||e_j|/4|T| per share) and round-off. Each
round assembles the shares of the triangles that changed; an edge that fails is flipped when
its quadrilateral is convex and the flip lowers the deficit of the quadrilateral's five edges
(a flip judged on its own edge alone mends it by breaking a side, and such flips cycle without
end), else split at the first of a few points along it that leaves the fewest failing edges
around it (the midpoint first: smaller triangles see a more nearly constant Q); until none
fails or the rounds run out, which is then said, never passed over. Given the metric the mesh
was made in, the corners of the triangles beside failing edges first take the mesher's shape
step where that mends their star without a vertex (a boundary vertex between two corners slides
along its side), and once every edge passes the added vertices take it where that improves
their star's worst quality and breaks no edge; then the corners of the triangles below FLOOR
take it in each triangle's own metric adj Q̄_T / √det Q̄_T (the metric quality 2.94 is measured
in: a full, half or quarter step), and their edges flip where that raises the worse of the two
and raises no deficit. The means come from `cache.ElementMeans`: each triangle's computed once.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from qmesh.conductivity.anisotropy import Anisotropy, adj2, shape_metric
from qmesh.fields.cache import ElementMeans
from qmesh.fields.piecewise import RegionMeans
from qmesh.geometry import topology
from qmesh.geometry.topology import touching
from qmesh.geometry.triangles import metric_quality, signed_areas
from qmesh.mesher.adjust import limit_moves, shape_step
from qmesh.triangle_mesh import Mesh

ROUND = 1e-12       # q_ij may fall below 0 by this share of Σ|q_ij^T| (round-off of the assembly)
MAX_ROUNDS = 400    # rounds of flips and splits before the remaining edges are reported
STALL = 30          # ... or rounds without fewer failing edges than the best so far
GAIN = 1e-9         # a flip must lower its quadrilateral's deficit by this share at least
SPLIT_AT = 0.1      # an edge is split no nearer its ends than this share of it
RELAX = 3           # rounds of shape steps mending edges before the next split
SMOOTH = 4          # shape steps of the vertices the splits added, once every edge passes
POLISH = 6          # then shape steps, in the element means' metric, of the corners of triangles
                    # below FLOOR
FLOOR = 0.3         # a split or a repairing move keeps the worst metric quality (2.94) of what it
KEEP = 0.75         # changes above KEEP · min(FLOOR, the worst before) where it can (a repairing
                    # move: above min(the worst before, KEEP · FLOOR))
SHORTEST = 1e-9     # edges shorter than this share of the domain's extent are not split
STEPS = (1.0, 0.5, 0.25)   # a refused shape move is tried at these shares of its step
IN_LINE = 1e-9      # a boundary vertex this near the line of its neighbours (sine) slides along it


@dataclass(frozen=True)
class Certificate:
    """What the repair did and what is left: `remaining` edges still fail (0: certified)."""

    rounds: int
    flips: int
    added: int
    remaining: int
    worst: float        # the smallest q_ij / Σ|q_ij^T| over the edges (≥ −ROUND when certified)


class _Judged:
    """What the repair judged and refused since nothing around it changed: the flip of each
    half-edge (`edges`) and the move of each vertex (`vertices`). A flip is judged on its two
    triangles and the shares from the four beyond its sides; a move on its vertex's star and
    the shares from the triangles beyond it: both on the triangles a changed triangle touches
    or is. The same inputs refuse again, so a refused one is tried again only once something
    it is judged on changed (`forget`)."""

    def __init__(self, n: int, m: int):
        self.vertices = np.zeros(n, bool)
        self.edges = np.zeros(3 * m, bool)

    def forget(self, T, twin, t):
        """Triangles `t` changed (and T, twin may have grown): forget what touched them."""
        n, m = int(T.max()) + 1, len(T)
        if n > len(self.vertices):
            self.vertices = np.concatenate([self.vertices, np.zeros(n - len(self.vertices), bool)])
        if 3 * m > len(self.edges):
            self.edges = np.concatenate([self.edges, np.zeros(3 * m - len(self.edges), bool)])
        if not len(t):
            return
        across = twin[(3 * np.asarray(t)[:, None] + np.arange(3)).ravel()]
        near = np.concatenate([t, across[across >= 0] // 3])
        self.vertices[T[near].ravel()] = False
        self.edges[(3 * near[:, None] + np.arange(3)).ravel()] = False
        tw = twin[(3 * near[:, None] + np.arange(3)).ravel()]
        self.edges[tw[tw >= 0]] = False


def shares(P: NDArray[np.float64], T: NDArray[np.int64], Qbar: NDArray[np.float64],
           err: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """q_ij^T of the edge of every half-edge 3t + j (corner j → j + 1) and a bound on its error
    from the means' error `err` (M,): FIELDS.md §3."""
    X = P[T]
    E = X[:, [2, 0, 1]] - X[:, [1, 2, 0]]                    # edge opposite each corner
    area = 0.5 * signed_areas(P, T)
    A = adj2(Qbar)
    Ej, Ek = E, E[:, [1, 2, 0]]                              # opposite corners j and j + 1
    s = -np.einsum("mki,mij,mkj->mk", Ej, A, Ek) / (4.0 * area[:, None])
    bound = (err[:, None] * np.linalg.norm(Ej, axis=2) * np.linalg.norm(Ek, axis=2)
             / (4.0 * area[:, None]))
    return s.ravel(), bound.ravel()


def certify(mesh: Mesh, field, max_rounds: int = MAX_ROUNDS,
            metric=None) -> tuple[Mesh, Certificate]:
    """`mesh` made to pass on every interior and boundary edge with `field`'s element means,
    and what that took; the Mesh carries the means (`Mesh.conductivity`). With the `metric`
    the mesh was made in, vertices are also moved by its shape step where that mends edges
    without a split, and the vertices the splits added are smoothed where that keeps every
    edge passing.

    A medium: `field` a mapping {region tag: Anisotropy | TensorField} over `mesh.region_tags`
    (piecewise.py: each triangle's means from its own region). An edge between two regions is
    an interface (MEDIA.md §2): never flipped, each side's share checked ≥ 0 on its own (what
    a medium guarantees, stricter than their sum), split on both sides at once (each child
    keeps its parent's tag), its vertices fixed or sliding along it; shapes are judged in each
    triangle's own means, and the mesh keeps its region tags."""
    P, T = np.array(mesh.points), np.array(mesh.triangles)
    twin = topology.twins(T)
    reg = np.array(mesh.region_tags) if isinstance(field, Mapping) else None
    tc = _cut(twin, reg)                       # twin, less the interfaces (= twin without regions)
    shaping = metric is not None or reg is not None
    moves = None if reg is not None else metric   # a medium's shapes: each triangle's own means
    fixed = np.array(mesh.fixed)
    out = np.full(len(P), -1, np.int64)        # the tag of the boundary edge leaving each vertex
    out[mesh.boundary_edges[:, 0]] = mesh.boundary_tags
    field = ElementMeans(field) if reg is None else RegionMeans(field)   # each computed once
    Qbar, err = _means(field, "means_with_error", P, T, reg)
    Qbar, err = np.array(Qbar, dtype=float), np.array(err, dtype=float)
    flips = added = 0
    shortest = SHORTEST * float(np.ptp(P, axis=0).max())
    fewest, since = np.inf, 0
    rng = np.random.default_rng(0)
    tries = 0                                  # shape steps since the last split
    s, b = shares(P, T, Qbar, err)
    tight = np.zeros(len(T), bool)             # means at the field's own tolerance
    seen = _Judged(len(P), len(T))             # flips and moves refused, nothing changed since
    for rounds in range(max_rounds + 1):
        h, q, slack = _failing(s, b, tc)
        t = _by_bound(s, b, tc, h, tight)
        if len(t):                             # failing by the bound only: tighter means
            Qbar, err, s, b = _refresh(field, P, T, Qbar, err, s, b, t, tighten=True, reg=reg)
            tight[t] = True
            seen.forget(T, twin, t)
            h, q, slack = _failing(s, b, tc)
        if len(h) < fewest:
            fewest, since = len(h), 0
        since += 1
        if not len(h) or rounds == max_rounds or since > STALL:
            break
        done = _flips(P, T, tc, h[~seen.edges[h]], s, b, field, refused=seen.edges, reg=reg)
        t = done[:0]
        if len(done):
            t = np.concatenate([done // 3, twin[done] // 3])
            T, twin = topology.flip(T, twin, done)
            tc = _cut(twin, reg)
            flips += len(done)
        elif shaping and tries < RELAX:
            tries += 1
            tan = _tangents(P, T, twin, fixed) if reg is None else _slides(P, T, tc, fixed)
            ends = _free(T, tc, fixed, _corners(T, tc, h), tan)
            if len(ends):
                movers = _movers(T, twin, ends, rng)
                P, t = _relax(P, T, tc, Qbar, err, s, b, field, moves,
                              movers[~seen.vertices[movers]], shape=False, tangent=tan,
                              refused=seen.vertices, reg=reg)
        if not len(t):
            keep = _longer(P, T, h, shortest)
            if not keep.any():
                break
            if reg is None:
                P, T, twin, fixed, out, t = _splits(P, T, twin, fixed, out, h[keep], q[keep],
                                                    s, b, Qbar, field)
                tc = twin
            else:
                P, T, twin, fixed, out, reg, t = _medium_splits(P, T, twin, tc, reg, fixed, out,
                                                                h[keep], q[keep], s, b, Qbar, field)
                tc = _cut(twin, reg)
            added = len(P) - mesh.n_vertices
            tries = 0
        Qbar, err, s, b = _refresh(field, P, T, Qbar, err, s, b, t, reg=reg)
        tight = np.concatenate([tight, np.zeros(len(T) - len(tight), bool)])
        tight[t] = False
        seen.forget(T, twin, t)
    if shaping and not len(h) and added:
        tan = _tangents(P, T, twin, fixed) if reg is None else _slides(P, T, tc, fixed)
        seen.vertices[:] = False               # judged otherwise than the repair's moves
        new = _free(T, tc, fixed, np.arange(mesh.n_vertices, len(P)), tan)
        for _ in range(SMOOTH):
            movers = _movers(T, twin, new, rng)
            P, t = _relax(P, T, tc, Qbar, err, s, b, field, moves,
                          movers[~seen.vertices[movers]], shape=True, tangent=tan,
                          refused=seen.vertices, reg=reg)
            Qbar, err, s, b = _refresh(field, P, T, Qbar, err, s, b, t, reg=reg)
            seen.forget(T, twin, t)
    if shaping and not len(h):
        tan = _tangents(P, T, twin, fixed) if reg is None else _slides(P, T, tc, fixed)
        seen = _Judged(len(P), len(T))         # judged afresh: the moves are judged otherwise
        for _ in range(POLISH):                # the worst shapes, each in its own means
            low = metric_quality(P, T, shape_metric(Qbar)) < FLOOR
            poor = _free(T, tc, fixed, T[low].ravel(), tan)
            if not len(poor):
                break
            movers = _movers(T, twin, poor, rng)
            P, t = _relax(P, T, tc, Qbar, err, s, b, field, None,
                          movers[~seen.vertices[movers]], shape=True, tangent=tan,
                          refused=seen.vertices, reg=reg)
            Qbar, err, s, b = _refresh(field, P, T, Qbar, err, s, b, t, reg=reg)
            seen.forget(T, twin, t)
            low = np.flatnonzero(metric_quality(P, T, shape_metric(Qbar)) < FLOOR)
            done = _quality_flips(P, T, tc, (3 * low[:, None] + np.arange(3)).ravel(), s, b,
                                  Qbar, field, reg=reg)
            if len(done):
                t = np.concatenate([done // 3, twin[done] // 3])
                T, twin = topology.flip(T, twin, done)
                tc = _cut(twin, reg)
                flips += len(done)
                Qbar, err, s, b = _refresh(field, P, T, Qbar, err, s, b, t, reg=reg)
                seen.forget(T, twin, t)
    s, b = shares(P, T, Qbar, err)             # what is said is assembled afresh
    h, q, slack = _failing(s, b, tc, slack=True)
    worst = float(slack.min()) if len(slack) else 0.0
    hb = np.flatnonzero(twin < 0)
    tb, kb = np.divmod(hb, 3)
    E = np.column_stack([T[tb, kb], T[tb, topology.NXT[kb]]])
    regions = {} if reg is None else {"region_tags": reg, "region_names": mesh.region_names}
    done_mesh = Mesh(P, T, fixed, E, out[E[:, 0]], mesh.tag_names, conductivity=Qbar, **regions)
    return done_mesh, Certificate(rounds, flips, added, len(h), worst)


def _ends(T, h):
    """The two ends of each half-edge h."""
    return np.concatenate([T[h // 3, h % 3], T[h // 3, topology.NXT[h % 3]]])


def _corners(T, twin, h):
    """The corners of the triangles on either side of each half-edge h: its ends and the
    corners opposite it, whose angles decide its q_ij."""
    t = np.concatenate([h // 3, twin[h][twin[h] >= 0] // 3])
    return T[t].ravel()


def _free(T, twin, fixed, v, tangent=None):
    """The vertices among v that may move: neither seeds nor on the boundary, except those
    that slide along it (`tangent` not 0, `_tangents`)."""
    on = np.zeros(len(fixed), bool)
    on[_ends(T, np.flatnonzero(twin < 0))] = True
    if tangent is not None:
        on &= ~np.any(tangent != 0, axis=1)
    v = topology.sorted_unique(np.asarray(v, np.int64))
    return v[~fixed[v] & ~on[v]]


def _tangents(P, T, twin, fixed):
    """The unit tangent (n, 2) of each boundary vertex that may slide along the boundary: not a
    seed, and in line with its two neighbours along it (inside one straight segment, where
    the mesher or a split put it); 0 for every other vertex."""
    hb = np.flatnonzero(twin < 0)
    tb, kb = np.divmod(hb, 3)
    a, c = T[tb, kb], T[tb, topology.NXT[kb]]                  # boundary edges a → c
    nxt, prv = np.full(len(P), -1), np.full(len(P), -1)
    nxt[a], prv[c] = c, a
    return _in_line(P, np.flatnonzero((nxt >= 0) & (prv >= 0) & ~fixed), prv, nxt)


def _in_line(P, v, before, after):
    """The unit tangents (n, 2) of the vertices v lying between their neighbours before[v] and
    after[v] in line with them (to IN_LINE); 0 for every other vertex."""
    e1, e2 = P[v] - P[before[v]], P[after[v]] - P[v]
    l1, l2 = np.hypot(*e1.T), np.hypot(*e2.T)
    line = (np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) <= IN_LINE * l1 * l2) & \
        (np.einsum("ki,ki->k", e1, e2) > 0)
    v = v[line]
    t = P[after[v]] - P[before[v]]
    out = np.zeros((len(P), 2))
    out[v] = t / np.hypot(*t.T)[:, None]
    return out


def _failing(s, b, twin, slack=False):
    """The failing edges (one half-edge each), their q_ij, and (`slack`) every edge's relative
    slack (else None). An edge both of whose shares pass their own bounds passes (rounding is
    monotone): only the others are summed."""
    maybe = np.flatnonzero(~(s >= b))                   # NaN too
    g = twin[maybe]
    mark = np.zeros(len(s), bool)
    mark[np.where((g >= 0) & (g < maybe), g, maybe)] = True          # each edge once
    h = np.flatnonzero(mark)
    g = twin[h]
    inner = g >= 0
    gg = np.where(inner, g, 0)
    q = s[h] + np.where(inner, s[gg], 0.0)
    bound = b[h] + np.where(inner, b[gg], 0.0)
    scale = np.abs(s[h]) + np.where(inner, np.abs(s[gg]), 0.0)
    bad = ~(q - bound >= -ROUND * scale)                # NaN fails too
    return h[bad], q[bad], (_slack(s, b, twin) if slack else None)


def _slack(s, b, twin):
    """Every edge's q_ij − bound over Σ|q_ij^T| (each edge once)."""
    g = np.where(twin >= 0, twin, np.arange(len(twin)))
    inner = twin >= 0
    q = s + np.where(inner, s[g], 0.0)
    bound = b + np.where(inner, b[g], 0.0)
    scale = np.abs(s) + np.where(inner, np.abs(s[g]), 0.0)
    one = ~inner | (np.arange(len(twin)) < twin)            # each edge once
    return (q - bound)[one] / np.where(scale[one] > 0, scale[one], 1.0)


def _by_bound(s, b, twin, h, tight):
    """The triangles beside the failing half-edges h whose q_ij ≥ 0 fails only by the means'
    error bound, and whose means are not yet at the field's own tolerance."""
    g = twin[h]
    inner = g >= 0
    gg = np.maximum(g, 0)
    q = s[h] + np.where(inner, s[gg], 0.0)
    scale = np.abs(s[h]) + np.where(inner, np.abs(s[gg]), 0.0)
    only = q >= -ROUND * scale
    t = np.concatenate([h[only] // 3, g[only & inner] // 3])
    return np.unique(t[~tight[t]])


def _longer(P, T, h, shortest: float) -> np.ndarray:
    """Which half-edges h are longer than `shortest` (split no further: no flat triangles)."""
    a, b = T[h // 3, h % 3], T[h // 3, topology.NXT[h % 3]]
    return np.hypot(*(P[b] - P[a]).T) > shortest


def _independent(h, q, tris):
    """The failing edges that are the worst in each triangle they touch (no two share one)."""
    rank = np.empty(len(h))
    rank[np.argsort(-q, kind="stable")] = np.arange(1, len(h) + 1)     # most negative: highest
    cols = np.column_stack(tris)
    u, at = np.unique(cols.ravel(), return_inverse=True)
    best = np.zeros(len(u))
    np.maximum.at(best, at, np.repeat(rank, cols.shape[1]))
    return (best[at].reshape(cols.shape) == rank[:, None]).all(axis=1)


def _flips(P, T, twin, h, s, b, field, refused=None, reg=None):
    """Flips of failing interior edges that lower the deficit Σ max(0, bound − q_ij) over the
    five edges of their quadrilateral (its diagonal and its four sides, whose shares from
    outside it stay): a flip that mends its own edge by breaking a side is not taken, so the
    total deficit only falls and the flips end. No two chosen flips touch one edge.
    `refused` (a mask over the half-edges, when given) is set on the h whose flip is not
    better (`_Judged`)."""
    if refused is not None:
        refused[h] = True
    c = _flip_candidates(P, T, twin, h, s, b, field, reg)
    if c is None:
        return h[:0]
    inner, before, after, _, _, tris = c
    gain = before - after
    better = gain > GAIN * before
    if refused is not None:
        refused[inner[better]] = False
    return _chosen(inner, gain, better, tris)


def _quality_flips(P, T, twin, h, s, b, Qbar, field, reg=None):
    """Flips of the interior edges h that raise the worst metric quality (2.94) of their two
    triangles, each in its own means, and raise no deficit of their quadrilateral's five edges
    (an edge that passes keeps passing)."""
    c = _flip_candidates(P, T, twin, h, s, b, field, reg)
    if c is None:
        return h[:0]
    inner, before, after, new, Qn, tris = c
    k = len(inner)
    t1, t2 = inner // 3, twin[inner] // 3
    was = np.minimum(metric_quality(P, T[t1], shape_metric(Qbar[t1])),
                     metric_quality(P, T[t2], shape_metric(Qbar[t2])))
    now = np.nan_to_num(metric_quality(P, new, shape_metric(Qn)), nan=-1.0).reshape(2, k).min(axis=0)
    gain = now - np.nan_to_num(was, nan=0.0)
    better = (after <= before) & (gain > GAIN)
    return _chosen(inner, gain, better, tris)


def _chosen(inner, gain, better, tris):
    """The candidates `better`, the largest gain first, no two touching one triangle."""
    cand = inner[better]
    if not len(cand):
        return cand
    pick = _independent(cand, -gain[better], tuple(t[better] for t in tris))
    return cand[pick]


def _flip_candidates(P, T, twin, h, s, b, field, reg=None):
    """For the interior half-edges h whose quadrilateral is convex: the half-edges, the deficit
    of the five edges before and after the flip, the new triangles (2k, 3) and their means, and
    the triangles each flip touches (None when there are none)."""
    inner = h[twin[h] >= 0]
    if not len(inner):
        return None
    g = twin[inner]
    t1, e1 = np.divmod(inner, 3)
    t2, e2 = np.divmod(g, 3)
    u, v, a = T[t1, e1], T[t1, topology.NXT[e1]], T[t1, topology.PRV[e1]]
    bb = T[t2, topology.PRV[e2]]
    new = np.concatenate([np.column_stack([u, bb, a]), np.column_stack([bb, v, a])])
    ok = (signed_areas(P, new) > 0).reshape(2, -1).all(axis=0)     # a convex quadrilateral
    if not ok.any():
        return None
    inner, g, t1, e1, t2, e2 = inner[ok], g[ok], t1[ok], e1[ok], t2[ok], e2[ok]
    new = new.reshape(2, -1, 3)[:, ok].reshape(-1, 3)
    k = len(inner)
    # the sides v→a, a→u (in t1) and u→b, b→v (in t2), and their shares from outside
    sides = np.stack([3 * t1 + topology.NXT[e1], 3 * t1 + topology.PRV[e1],
                      3 * t2 + topology.NXT[e2], 3 * t2 + topology.PRV[e2]], axis=1)
    across = twin[sides]
    out_s = np.where(across >= 0, s[np.maximum(across, 0)], 0.0)
    out_b = np.where(across >= 0, b[np.maximum(across, 0)], 0.0)
    before = (_deficit(s[inner] + s[g], b[inner] + b[g])
              + _deficit(s[sides] + out_s, b[sides] + out_b).sum(axis=1))
    Qn, en = _means(field, "means_with_error", P, new, None if reg is None else np.tile(reg[t1], 2))
    Qn = np.asarray(Qn, dtype=float)
    sn, bn = shares(P, new, Qn, np.asarray(en, dtype=float))
    sn, bn = sn.reshape(2, k, 3), bn.reshape(2, k, 3)
    # (u, b, a) holds u→b, b→a, a→u; (b, v, a) holds b→v, v→a, a→b
    pick_t, pick_e = np.array([1, 0, 0, 1]), np.array([1, 2, 0, 0])   # v→a, a→u, u→b, b→v
    side_s, side_b = sn[pick_t, :, pick_e].T, bn[pick_t, :, pick_e].T
    after = (_deficit(sn[0, :, 1] + sn[1, :, 2], bn[0, :, 1] + bn[1, :, 2])
             + _deficit(side_s + out_s, side_b + out_b).sum(axis=1))
    M = len(T)
    near = np.where(across >= 0, across // 3, M + 4 * np.arange(k)[:, None] + np.arange(4))
    tris = (t1, t2) + tuple(near.T)
    return inner, before, after, new, Qn, tris


def _deficit(q, bound):
    """How far q_ij falls short of its error bound (0 for an edge that passes)."""
    return np.maximum(bound - q, 0.0)


def _splits(P, T, twin, fixed, out, h, q, s, b, Qbar, field):
    """Split failing edges, boundary ones first (one per triangle), each at the best of a few
    points along it (`_split_points`)."""
    boundary = twin[h] < 0
    if boundary.any():
        hb, qb = h[boundary], q[boundary]
        hb = hb[_independent(hb, qb, (hb // 3,))]
        n = len(P)
        u = T[hb // 3, hb % 3]
        X = _split_points(P, T, twin, hb, s, b, Qbar, field)
        T, twin = topology.split_boundary_edges(T, twin, hb, n + np.arange(len(hb)))
        t = np.concatenate([hb // 3, len(T) - len(hb) + np.arange(len(hb))])
        new_out = out[u]
    else:
        hi = h[_independent(h, q, (h // 3, twin[h] // 3))]
        n = len(P)
        X = _split_points(P, T, twin, hi, s, b, Qbar, field)
        t = np.concatenate([hi // 3, twin[hi] // 3, len(T) + np.arange(2 * len(hi))])
        T, twin = topology.split_edges(T, twin, hi, n + np.arange(len(hi)))
        new_out = np.full(len(hi), -1, np.int64)
    P = np.concatenate([P, X])
    fixed = np.concatenate([fixed, np.zeros(len(X), bool)])
    out = np.concatenate([out, new_out])
    return P, T, twin, fixed, out, t


def _right_angles(P, u, v, a, H):
    """Where along u→v (0 at u, 1 at v) a point p makes a right angle, in the metric H, at p
    in (u, p, a) (the foot of the altitude from a), at a in (u, p, a), and at a in (p, v, a).
    Between the first and the second (the third) the triangle (u, p, a) ((p, v, a)) has no
    obtuse angle at p or a."""
    e, du, dv = P[v] - P[u], P[u] - P[a], P[v] - P[a]
    Hu, Hv = np.einsum("kij,kj->ki", H, du), np.einsum("kij,kj->ki", H, dv)
    with np.errstate(divide="ignore", invalid="ignore"):
        foot = -np.einsum("ki,ki->k", e, Hu) / np.einsum("ki,ki->k", e, np.einsum("kij,kj->ki", H, e))
        at_a_first = -np.einsum("ki,ki->k", du, Hu) / np.einsum("ki,ki->k", e, Hu)
        at_a_second = -np.einsum("ki,ki->k", du, Hv) / np.einsum("ki,ki->k", e, Hv)
    return foot, at_a_first, at_a_second


def _split_points(P, T, twin, h, s, b, Qbar, field, reg=None, cut=None):
    """For each edge u→v of the half-edges h (all interior or all on the boundary), the first
    of a few candidate points whose split keeps the shapes (KEEP, FLOOR) and leaves the fewest
    failing edges among those it makes and the sides of the triangles it splits, their means
    recomputed (a split that mends one more edge with a sliver costs the minimum quality more
    than the vertex a later split takes): the midpoint, the
    quarter points, then for each opposite corner a (in its own triangle's metric adj Q̄_T)
    the foot of its altitude and the middles of the spans where (u, p, a) or (p, v, a) has no
    obtuse angle at p or a. A midpoint leaves an obtuse angle at a obtuse in one of the halves,
    whose edges then fail in turn; a point in such a span mends it in one step.
    A medium's (`reg`, the tags; `cut`, the twins less the interfaces): the shares from
    beyond the sides as `cut` has them, and the halves of an interface edge judged side by
    side."""
    k = len(h)
    t1, e1 = np.divmod(h, 3)
    u, v, a = T[t1, e1], T[t1, topology.NXT[e1]], T[t1, topology.PRV[e1]]
    inner = bool(k) and bool(twin[h[0]] >= 0)
    H = shape_metric(Qbar)
    apexes = [(a, t1)]
    sides = [3 * t1 + topology.NXT[e1], 3 * t1 + topology.PRV[e1]]            # v→a, a→u
    if inner:
        g = twin[h]
        t2, e2 = np.divmod(g, 3)
        bb = T[t2, topology.PRV[e2]]
        apexes.append((bb, t2))
        sides += [3 * t2 + topology.NXT[e2], 3 * t2 + topology.PRV[e2]]       # u→b, b→v
    cols = [np.full(k, 0.5), np.full(k, 0.25), np.full(k, 0.75)]
    for corner, t in apexes:
        foot, first, second = _right_angles(P, u, v, corner, H[t])
        cols += [foot, 0.5 * (foot + first), 0.5 * (foot + second)]
    where = np.column_stack(cols)
    where = np.clip(np.where(np.isfinite(where), where, 0.5), SPLIT_AT, 1.0 - SPLIT_AT)
    c = where.shape[1]
    X = P[u][:, None] + where[..., None] * (P[v] - P[u])[:, None]              # (k, c, 2)
    Pc = np.concatenate([P, X.reshape(-1, 2)])
    p = len(P) + np.arange(k * c)
    U, V, A = (np.repeat(z, c) for z in (u, v, a))
    if inner:
        B = np.repeat(bb, c)
        new = np.concatenate([np.column_stack(z) for z in
                              ((U, p, A), (p, V, A), (V, p, B), (p, U, B))])
    else:
        new = np.concatenate([np.column_stack(z) for z in ((U, p, A), (p, V, A))])
    tags = None if reg is None else np.concatenate([np.tile(np.repeat(reg[t], c), 2) for _, t in apexes])
    Qn, en = _means(field, "rough", Pc, new, tags)                       # compared, not kept
    sn, bn = shares(Pc, new, np.asarray(Qn, dtype=float), np.asarray(en, dtype=float))
    sn, bn = sn.reshape(-1, k * c, 3), bn.reshape(-1, k * c, 3)
    across = (twin if cut is None else cut)[np.stack(sides, axis=1)]
    out_s = np.repeat(np.where(across >= 0, s[np.maximum(across, 0)], 0.0), c, axis=0)
    out_b = np.repeat(np.where(across >= 0, b[np.maximum(across, 0)], 0.0), c, axis=0)
    # (u, p, a): u→p, p→a, a→u; (p, v, a): p→v, v→a, a→p; (v, p, b): v→p, p→b, b→v;
    # (p, u, b): p→u, u→b, b→p (triangle, corner) of each made edge and each side
    if inner and cut is not None and cut[h[0]] < 0:          # an interface: side by side
        made = [((0, 0),), ((3, 0),), ((1, 0),), ((2, 0),), ((0, 1), (1, 2)), ((2, 1), (3, 2))]
        kept = [(1, 1), (0, 2), (3, 1), (2, 2)]
    elif inner:
        made = [((0, 0), (3, 0)), ((1, 0), (2, 0)), ((0, 1), (1, 2)), ((2, 1), (3, 2))]
        kept = [(1, 1), (0, 2), (3, 1), (2, 2)]                 # v→a, a→u, u→b, b→v
    else:
        made = [((0, 0),), ((1, 0),), ((0, 1), (1, 2))]
        kept = [(1, 1), (0, 2)]
    failing = np.zeros((k, c), np.int64)
    for parts, extra, extra_b in ([(pairs, 0.0, 0.0) for pairs in made]
                                  + [(((i, j),), out_s[:, m], out_b[:, m])
                                     for m, (i, j) in enumerate(kept)]):
        q = sum(sn[i, :, j] for i, j in parts) + extra
        bound = sum(bn[i, :, j] for i, j in parts) + extra_b
        scale = sum(np.abs(sn[i, :, j]) for i, j in parts) + np.abs(extra)
        failing += (~(q - bound >= -ROUND * scale)).reshape(k, c)
    # no triangle worse shaped than KEEP · min(FLOOR, the ones split), then the fewest failing
    # edges, then the first (the midpoint first)
    quality = np.nan_to_num(metric_quality(Pc, new, shape_metric(np.asarray(Qn, dtype=float)))
                            .reshape(-1, k, c).min(axis=0), nan=-1.0)
    split = [t for _, t in apexes]
    was = np.minimum.reduce([metric_quality(P, T[t], H[t]) for t in split])
    worse = quality < KEEP * np.minimum(FLOOR, np.nan_to_num(was, nan=0.0))[:, None]
    order = np.argmin(failing + 1000 * worse, axis=1)
    return X[np.arange(k), order]


def _movers(T, twin, candidates, rng):
    """Candidate vertices no two of which touch one triangle or two neighbouring triangles, so
    each edge's shares move with one vertex at most (random priorities, a Luby-style round)."""
    prio = np.zeros(int(T.max()) + 1)
    prio[candidates] = 1.0 + rng.random(len(candidates))
    tri = _max3(prio[T])
    nb = np.where(twin >= 0, twin // 3, np.repeat(np.arange(len(T)), 3)).reshape(-1, 3)
    wide = np.maximum(tri, _max3(tri[nb]))
    best = np.zeros(len(prio))
    np.maximum.at(best, T.ravel(), np.repeat(wide, 3))
    return candidates[best[candidates] == prio[candidates]]


def _max3(x):
    """The largest of each row of x (k, 3) (max(axis=1), without its overhead on short rows)."""
    return np.maximum(np.maximum(x[:, 0], x[:, 1]), x[:, 2])


def _relax(P, T, twin, Qbar, err, s, b, field, metric, movers, shape, tangent=None,
           refused=None, reg=None):
    """Move the vertices `movers` (`_movers`) by the mesher's shape step in `metric`
    (`adjust.shape_step`, capped by `adjust.limit_moves`) where their star is better for it:
    no more failing edges and no higher deficit, and fewer or a lower deficit, and a worst
    quality kept above min(its worst before, KEEP · FLOOR) (shape=False: a repair that adds no
    vertex; a star already worse than that, such as a sharp corner's, gets no worse); no more failing edges, no higher deficit and a better worst
    metric quality of the star in its own means (shape=True). Returns the new P and the
    triangles that changed. Vertices with a `tangent` (`_tangents`) move along it only.
    `refused` (a mask over the vertices, when given) is set on the movers not moved
    (`_Judged`)."""
    n = len(P)
    if not len(movers):
        return P, np.empty(0, np.int64)
    mask = np.zeros(n, bool)
    mask[movers] = True
    star0 = touching(T, mask)
    near = T[star0]                            # the movers' stars: all a move can change
    if metric is None:                         # each triangle's own H_T = adj Q̄_T / √det Q̄_T
        metric = _own_metric(shape_metric(Qbar[star0]))
    d = shape_step(P, near, metric, mask)
    if tangent is not None:                    # boundary vertices: the step's share along it
        d = tangent * np.einsum("ki,ki->k", d, tangent)[:, None] + np.where(
            np.any(tangent != 0, axis=1)[:, None], 0.0, d)
    _, d = limit_moves(P, near, d)
    moving = mask & (np.hypot(d[:, 0], d[:, 1]) > 0)
    take = np.zeros(n, bool)
    for frac in (STEPS if shape else STEPS[:1]):   # a shape move refused is tried shorter
        if not moving.any():
            break
        ok = _accepted(P, T, twin, Qbar, s, b, field, frac * d, moving, shape, reg)
        d[ok] *= frac
        take |= ok
        moving &= ~ok
    if refused is not None:
        refused[movers] = ~take[movers]
    if not take.any():
        return P, np.empty(0, np.int64)
    P = P.copy()
    P[take] += d[take]
    return P, np.flatnonzero(touching(T, take))


def _accepted(P, T, twin, Qbar, s, b, field, d, moving, shape, reg=None):
    """Which `moving` vertices (two triangles apart) `_relax` takes moved by d: their stars'
    edges and shapes judged on the means at the new places."""
    n = len(P)
    star = np.flatnonzero(touching(T, moving))
    if not len(star):
        return np.zeros(n, bool)
    Pn = P + np.where(moving[:, None], d, 0.0)
    Ts = T[star]
    Qn, en = _means(field, "means_with_error", Pn, Ts, None if reg is None else reg[star])
    Qn, en = np.asarray(Qn, dtype=float), np.asarray(en, dtype=float)
    sn, bn = shares(Pn, Ts, Qn, en)
    he = (3 * star[:, None] + np.arange(3)).ravel()
    local = np.full(len(T), -1, np.int64)
    local[star] = np.arange(len(star))
    tw = twin[he]
    tw_local = np.where(tw >= 0, local[tw // 3], -1)
    inside = tw_local >= 0
    tw_he_local = np.where(inside, 3 * tw_local + tw % 3, 0)
    once = ~inside | (he < tw)                     # each edge of the stars once
    old_q = s[he] + np.where(tw >= 0, s[np.maximum(tw, 0)], 0.0)
    old_b = b[he] + np.where(tw >= 0, b[np.maximum(tw, 0)], 0.0)
    old_c = np.abs(s[he]) + np.where(tw >= 0, np.abs(s[np.maximum(tw, 0)]), 0.0)
    other = np.where(inside, sn[tw_he_local], np.where(tw >= 0, s[np.maximum(tw, 0)], 0.0))
    other_b = np.where(inside, bn[tw_he_local], np.where(tw >= 0, b[np.maximum(tw, 0)], 0.0))
    new_q, new_b = sn + other, bn + other_b
    new_c = np.abs(sn) + np.abs(other)
    tri_owner = Ts[np.arange(len(star)), np.argmax(moving[Ts], axis=1)]   # its one mover
    owner = np.repeat(tri_owner, 3)[once]

    def per_vertex(q, bound, scale):
        fail = np.bincount(owner, ~(q[once] - bound[once] >= -ROUND * scale[once]), minlength=n)
        deficit = np.bincount(owner, _deficit(q, bound)[once], minlength=n)
        return fail, deficit
    f0, d0 = per_vertex(old_q, old_b, old_c)
    f1, d1 = per_vertex(new_q, new_b, new_c)
    flat = np.zeros(n, bool)
    flat[tri_owner[~(signed_areas(Pn, Ts) > 0)]] = True
    if shape:
        q0, q1 = _star_quality(P, Pn, Ts, Qbar[star], Qn, tri_owner, n)
        take = (f1 <= f0) & (d1 <= d0) & (q1 > q0)
    else:
        q0, q1 = _star_quality(P, Pn, Ts, Qbar[star], Qn, tri_owner, n)
        take = ((f1 <= f0) & (d1 <= d0) & ((f1 < f0) | (d1 < (1.0 - GAIN) * d0))
                & (q1 >= np.minimum(q0, KEEP * FLOOR)))
    return take & moving & ~flat




def _own_metric(H):
    """The metric of the triangles of a star, each its own H (in the order `shape_step` asks for
    them: its triangles are the star's, in order): what the quality (2.94) is measured in."""
    def hessian(X):
        assert len(X) == len(H)
        return H
    return Anisotropy.metric_only(hessian, "element means")


def _star_quality(P, Pn, Ts, Q0, Q1, owner, n):
    """The worst metric quality (2.94), each triangle in its own means, of the stars before and
    after their moves, per vertex (inf where it owns none)."""
    q0, q1 = np.full(n, np.inf), np.full(n, np.inf)
    np.minimum.at(q0, owner, np.nan_to_num(metric_quality(P, Ts, shape_metric(Q0)), nan=0.0))
    np.minimum.at(q1, owner, np.nan_to_num(metric_quality(Pn, Ts, shape_metric(Q1)), nan=0.0))
    return q0, q1


def _refresh(field, P, T, Qbar, err, s, b, t, tighten=False, reg=None):
    """The means of the triangles `t` (changed rows, and rows past the old end) recomputed
    (`tighten`: at the field's own tolerance, `ElementMeans.tighten`), and their shares (each
    round assembles only what changed)."""
    M = len(T)
    if len(Qbar) < M:
        Qbar = np.concatenate([Qbar, np.zeros((M - len(Qbar), 2, 2))])
        err = np.concatenate([err, np.zeros(M - len(err))])
        s = np.concatenate([s, np.zeros(3 * M - len(s))])
        b = np.concatenate([b, np.zeros(3 * M - len(b))])
    t = np.unique(t)
    Qn, en = _means(field, "tighten" if tighten else "means_with_error", P, T[t],
                    None if reg is None else reg[t])
    Qbar[t], err[t] = Qn, en
    st, bt = shares(P, T[t], Qbar[t], err[t])
    rows = (3 * t[:, None] + np.arange(3)).ravel()
    s[rows], b[rows] = st, bt
    return Qbar, err, s, b


def _means(field, how, P, T, tags):
    """`field`'s means and error bounds of the triangles T (`how`: means_with_error, tighten, or
    rough where the field has it); a medium's (`tags` given) from each triangle's region."""
    f = getattr(field, how, field.means_with_error)
    return f(P, T) if tags is None else f(P, T, tags)


def _cut(twin, reg):
    """The twins with the interfaces cut (−1 on both sides of an edge between two regions, as on
    the boundary): each side's share is then judged on its own, and never flipped. `twin`
    itself without regions."""
    if reg is None:
        return twin
    across = twin >= 0
    other = np.where(across, twin // 3, 0)
    return np.where(across & (reg[other] == np.repeat(reg, 3)), twin, -1)


def _slides(P, T, cut, fixed):
    """`_tangents` of a medium: a vertex on the boundary or an interface (the edges `cut` ends)
    slides along the line of its two neighbours there when it is not a seed, has exactly two
    (one line: not a junction) and lies between them in line; 0 for every other vertex."""
    hb = np.flatnonzero(cut < 0)
    tb, kb = np.divmod(hb, 3)
    E = np.sort(np.column_stack([T[tb, kb], T[tb, topology.NXT[kb]]]), axis=1)
    E = np.unique(E, axis=0)                   # an interface edge is cut on both sides: once
    count = np.bincount(E.ravel(), minlength=len(P))
    lo, hi = np.full(len(P), len(P)), np.full(len(P), -1)
    for a, c in ((E[:, 0], E[:, 1]), (E[:, 1], E[:, 0])):
        np.minimum.at(lo, a, c)
        np.maximum.at(hi, a, c)
    return _in_line(P, np.flatnonzero((count == 2) & ~fixed), lo, hi)


def _medium_splits(P, T, twin, cut, reg, fixed, out, h, q, s, b, Qbar, field):
    """`_splits` of a medium: the failing sides on the boundary or an interface first, else the
    interior edges, no two in one triangle (an interface edge touches both of its). A boundary
    edge splits its triangle; an interface or interior edge both (`topology.split_edges`), each
    child keeping its parent's region tag. Returns P, T, twin, fixed, out, the tags and the
    triangles that changed."""
    side = cut[h] < 0
    if side.any():
        h, q = h[side], q[side]
    other = np.where(twin[h] >= 0, twin[h] // 3, h // 3)
    h = h[_independent(h, q, (h // 3, other))]
    hb, hi = h[twin[h] < 0], h[twin[h] >= 0]          # one triangle; two (interior or interface)
    none = np.zeros((0, 2))
    Xb = _split_points(P, T, cut, hb, s, b, Qbar, field, reg) if len(hb) else none
    Xi = _split_points(P, T, twin, hi, s, b, Qbar, field, reg, cut) if len(hi) else none
    n, M = len(P), len(T)
    u = T[hb // 3, hb % 3]
    T, twin = topology.split_boundary_edges(T, twin, hb, n + np.arange(len(hb)))
    reg = np.concatenate([reg, reg[hb // 3]])
    t1, t2, M2 = hi // 3, twin[hi] // 3, len(T)
    T, twin = topology.split_edges(T, twin, hi, n + len(hb) + np.arange(len(hi)))
    reg = np.concatenate([reg, reg[t1], reg[t2]])
    t = np.concatenate([hb // 3, M + np.arange(len(hb)), t1, t2, M2 + np.arange(2 * len(hi))])
    P = np.concatenate([P, Xb, Xi])
    fixed = np.concatenate([fixed, np.zeros(len(Xb) + len(Xi), bool)])
    out = np.concatenate([out, out[u], np.full(len(hi), -1, np.int64)])
    return P, T, twin, fixed, out, reg, t
