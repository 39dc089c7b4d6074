"""The repair's vertex moves: the mesher's shape step, taken only where it mends a star's edges or
improves its worst quality and breaks nothing, and the polish, which also tries a pattern of
places around each vertex and takes the best (FIELDS.md §4).

Movers are chosen two triangles apart, so each edge's shares move with one vertex at most; a
boundary or interface vertex between two others in line slides along that line; a move refused
is tried again only once something it was judged on changed (`Judged`).
"""

from __future__ import annotations

import numpy as np

from qmesh.conductivity.anisotropy import Anisotropy, shape_metric
from qmesh.fields.shares import FLOOR, GAIN, KEEP, ROUND, deficit, shares
from qmesh.geometry import topology
from qmesh.geometry.portable import cholesky2, solve2
from qmesh.geometry.topology import touching
from qmesh.geometry.triangles import metric_quality, proper
from qmesh.mesher.adjust import limit_moves, shape_step

STEPS = (1.0, 0.5, 0.25)   # a refused shape move is tried at these shares of its step
IN_LINE = 1e-9      # a boundary vertex this near the line of its neighbours (sine) slides along it
PATTERN = 12        # directions of the polish's places around a vertex ...
REACH = (0.3, 0.1)  # ... at these shares of its height over its worst triangle's far edge
POLISH_MOVERS = 4096    # movers whose tries the polish judges at once (27 tries of a star
                        # each: the tries' arrays of a run are some tens of MB)


class Judged:
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


def ends(T, h):
    """The two ends of each half-edge h."""
    return np.concatenate([T[h // 3, h % 3], T[h // 3, topology.NXT[h % 3]]])


def corners(T, twin, h):
    """The corners of the triangles on either side of each half-edge h: its ends and the
    corners opposite it, whose angles decide its q_ij."""
    t = np.concatenate([h // 3, twin[h][twin[h] >= 0] // 3])
    return T[t].ravel()


def free(T, twin, fixed, v, tangent=None):
    """The vertices among v that may move: neither seeds nor on the boundary, except those
    that slide along it (`tangent` not 0, `tangents`)."""
    on = np.zeros(len(fixed), bool)
    on[ends(T, np.flatnonzero(twin < 0))] = True
    if tangent is not None:
        on &= ~np.any(tangent != 0, axis=1)
    v = topology.sorted_unique(np.asarray(v, np.int64))
    return v[~fixed[v] & ~on[v]]


def tangents(P, T, twin, fixed):
    """The unit tangent (n, 2) of each boundary vertex that may slide along the boundary: not a
    seed, and in line with its two neighbours along it (inside one straight segment, where
    the mesher or a split put it); 0 for every other vertex."""
    hb = np.flatnonzero(twin < 0)
    tb, kb = np.divmod(hb, 3)
    a, c = T[tb, kb], T[tb, topology.NXT[kb]]                  # boundary edges a → c
    nxt, prv = np.full(len(P), -1), np.full(len(P), -1)
    nxt[a], prv[c] = c, a
    return in_line(P, np.flatnonzero((nxt >= 0) & (prv >= 0) & ~fixed), prv, nxt)


def slides(P, T, cut, fixed):
    """`tangents` of a medium: a vertex on the boundary or an interface (the edges `cut` ends)
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
    return in_line(P, np.flatnonzero((count == 2) & ~fixed), lo, hi)


def in_line(P, v, before, after):
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


def movers(T, twin, candidates, rng):
    """Candidate vertices no two of which touch one triangle or two neighbouring triangles, so
    each edge's shares move with one vertex at most (random priorities, a Luby-style round).
    Only the candidates' stars and their neighbours are looked at: a round costs what the
    candidates touch, not the whole mesh."""
    n = max(int(T.max()) + 1, int(candidates.max()) + 1 if len(candidates) else 0)
    prio = np.zeros(n)
    prio[candidates] = 1.0 + rng.random(len(candidates))
    star = np.flatnonzero(touching(T, prio > 0))       # the only triangles with a priority
    tri = np.zeros(len(T))
    tri[star] = _max3(prio[T[star]])
    g = twin[(3 * star[:, None] + np.arange(3)).ravel()]
    nb = np.where(g >= 0, g // 3, np.repeat(star, 3)).reshape(-1, 3)
    wide = np.maximum(tri[star], _max3(tri[nb]))
    best = np.zeros(n)
    np.maximum.at(best, T[star].ravel(), np.repeat(wide, 3))
    return candidates[best[candidates] == prio[candidates]]


def _max3(x):
    """The largest of each row of x (k, 3) (max(axis=1), without its overhead on short rows)."""
    return np.maximum(np.maximum(x[:, 0], x[:, 1]), x[:, 2])


def relax(st, metric, movers, shape, tangent=None, refused=None):
    """Move the vertices `movers` (`movers`) of the state `st` (repair_state.RepairState) by the
    mesher's shape step in `metric` (`adjust.shape_step`, capped by `adjust.limit_moves`) where
    their star is better for it: no more failing edges and no higher deficit, and fewer or a lower
    deficit, and a worst quality kept above min(its worst before, KEEP · FLOOR) (shape=False: a
    repair that adds no vertex; a star already worse than that, such as a sharp corner's, gets no
    worse); no more failing edges, no higher deficit and a better worst metric quality of the star
    in its own means (shape=True). Moves `st.P` and returns the triangles that changed. Vertices
    with a `tangent` (`tangents`) move along it only. `refused` (a mask over the vertices, when
    given) is set on the movers not moved (`Judged`)."""
    P, T, Qbar = st.P, st.T, st.Qbar
    n = len(P)
    if not len(movers):
        return np.empty(0, np.int64)
    mask = np.zeros(n, bool)
    mask[movers] = True
    star = np.flatnonzero(touching(T, mask))   # the movers' stars: all a move can change, and
    near = T[star]                             # the only triangles the moves are looked for in
    if metric is None:                         # each triangle's own H_T = adj Q̄_T / √det Q̄_T
        metric = _own_metric(shape_metric(Qbar[star]))
    d = shape_step(P, near, metric, mask)
    if tangent is not None:                    # boundary vertices: the step's share along it
        d = _along(d, tangent)
    _, d = limit_moves(P, near, d)
    moving = mask & (np.hypot(d[:, 0], d[:, 1]) > 0)
    take = np.zeros(n, bool)
    for frac in (STEPS if shape else STEPS[:1]):   # a shape move refused is tried shorter
        if not moving.any():
            break
        ok = _accepted(st, frac * d, moving, shape, within=(star, near))
        d[ok] *= frac
        take |= ok
        moving &= ~ok
    if refused is not None:
        refused[movers] = ~take[movers]
    if not take.any():
        return np.empty(0, np.int64)
    st.P = P.copy()
    st.P[take] += d[take]
    return star[touching(near, take)]


def isosceles(st, h, tangent, rng, refused=None):
    """Mend failing boundary edges h of the state `st` from a corner by sliding the other end along
    its side: u→v with apex x fails where x's angle is obtuse in the triangle's metric; with v
    placed as far from u as x is (|uv'| = |ux|), the triangle is isosceles, both its base angles
    90° − ½∠u. Only where one end cannot slide (a corner, a seed, a junction) and the other can
    (`tangent`). At a corner sharp in the metric (a raster cell at 1000 : 1) nothing else passes on
    both sides: a split there leaves the corner's two edges failing in turn, each split nearer the
    corner. Judged as `relax` judges a mending move (`refused` as there); moves `st.P` and returns
    the triangles that changed."""
    P, T, twin, Qbar = st.P, st.T, st.cut, st.Qbar
    h = h[twin[h] < 0]
    t, k = np.divmod(h, 3)
    u, v, x = T[t, k], T[t, topology.NXT[k]], T[t, topology.PRV[k]]
    H = shape_metric(Qbar[t])
    length = lambda d: np.sqrt(np.einsum("ki,kij,kj->k", d, H, d))     # noqa: E731
    uv = length(P[v] - P[u])
    to_v = (length(P[x] - P[u]) / uv - 1.0)[:, None] * (P[v] - P[u])   # v slides towards u
    to_u = (length(P[x] - P[v]) / uv - 1.0)[:, None] * (P[u] - P[v])   # u slides towards v
    can_v, can_u = np.any(tangent[v] != 0, axis=1), np.any(tangent[u] != 0, axis=1)
    w = np.where(can_v, v, u)
    d = np.where(can_v[:, None], to_v, to_u)
    keep = (can_v != can_u) & (np.einsum("ki,ki->k", d, d) > 0)
    if refused is not None:
        keep &= ~refused[w]
    w, d = w[keep], d[keep]
    w, first = np.unique(w, return_index=True)                 # one slide per vertex
    d = d[first]
    if not len(w):
        return np.empty(0, np.int64)
    chosen = movers(T, twin, w, rng)
    d = d[np.searchsorted(w, chosen)]
    ok = _judged(st, chosen, d[None], False)[0][0]
    if refused is not None:
        refused[chosen] = ~ok
    if not ok.any():
        return np.empty(0, np.int64)
    return _moved(st, chosen[ok], d[ok])


def polish(st, movers, tangent=None, refused=None):
    """The polish's moves: each of the `movers` (`movers`) of the state `st` tries its shape step
    in its star's own means (at STEPS of it) and PATTERN places around it at REACH shares of its
    height over the far edge of its star's worst triangle, in that triangle's metric (a vertex with
    a `tangent`: their share along it), and takes the one that raises its star's worst quality
    (each triangle in its own means) most, with no more failing edges and no higher deficit. The
    shape step alone, which serves the star's mean shape, is often refused beside a triangle that
    needs one corner moved another way. All the tries are judged at once (`_judged`). Moves `st.P`
    and returns the triangles that changed."""
    P, T, Qbar = st.P, st.T, st.Qbar
    v = np.asarray(movers, np.int64)
    if not len(v):
        return np.empty(0, np.int64)
    n = len(P)
    mask = np.zeros(n, bool)
    mask[v] = True
    star = np.flatnonzero(touching(T, mask))
    near = T[star]
    H = shape_metric(Qbar[star])
    step = shape_step(P, near, _own_metric(H), mask)[v]
    # each mover's worst triangle (its corner there, the far edge a → c) and its metric
    quality = np.nan_to_num(metric_quality(P, near, H), nan=0.0)
    corner = np.argmax(mask[near], axis=1)
    owner = near[np.arange(len(near)), corner]
    order = np.lexsort((quality, owner))
    first = order[np.r_[True, owner[order][1:] != owner[order][:-1]]]   # by owner, ascending
    first = first[np.searchsorted(owner[first], v)]                       # in v's order
    k, L = corner[first], cholesky2(H[first])           # |x|_H = |Lᵀ x|
    a, c = P[near[first, (k + 1) % 3]], P[near[first, (k + 2) % 3]]
    ac = np.einsum("kji,kj->ki", L, c - a)
    av = np.einsum("kji,kj->ki", L, P[v] - a)
    height = np.abs(ac[:, 0] * av[:, 1] - ac[:, 1] * av[:, 0]) / np.hypot(ac[:, 0], ac[:, 1])
    angle = 2.0 * np.pi * np.arange(PATTERN) / PATTERN
    ring = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    around = (np.asarray(REACH)[:, None, None, None] * height[None, None, :, None]
              * ring[None, :, None, :]).reshape(-1, len(v), 2)
    back = solve2(np.swapaxes(L, 1, 2)[None], around)
    D = np.concatenate([np.asarray(STEPS)[:, None, None] * step[None], back])   # (K, k, 2)
    if tangent is not None:                    # a boundary vertex: the move's share along it
        D = _along(D, tangent[v])
    # every try judged on rough means (the degree-5 rule alone, `ElementMeans.rough`), the one
    # each mover would take judged again on the means it is kept with: the field's adaptive
    # means for one try a mover, not for all of them (a raster's rough means are its kept ones)
    best, take = np.zeros(len(v), np.int64), np.zeros(len(v), bool)
    for c in range(0, len(v), POLISH_MOVERS):  # the same verdicts: each on its own star
        at = slice(c, c + POLISH_MOVERS)
        ok, q1 = _judged(st, v[at], D[:, at], True, how="rough", within=(star, near))
        q1 = np.where(ok, q1, -np.inf)
        best[at] = np.argmax(q1, axis=0)
        take[at] = np.isfinite(q1[best[at], np.arange(q1.shape[1])])
        if _rough_exact(st):                   # judged on the means it is kept with
            kept = np.zeros(q1.shape, bool)
            kept[best[at][take[at]], np.flatnonzero(take[at])] = True
            _keep(st, kept)
    if take.any() and not _rough_exact(st):
        chosen = np.flatnonzero(take)
        take[chosen] = _judged(st, v[chosen], D[best[chosen], chosen][None], True,
                               within=(star, near))[0][0]
    if refused is not None:
        refused[v] = ~take
    if not take.any():
        return np.empty(0, np.int64)
    return _moved(st, v[take], D[best[take], np.flatnonzero(take)], within=(star, near))


def _moved(st, v, d, within=None):
    """Move the vertices v of `st.P` by d; the triangles that changed (their stars, looked for
    among the triangles `within` when given, `_star`'s)."""
    P = st.P.copy()
    P[v] += d
    st.P = P
    moved = np.zeros(len(P), bool)
    moved[v] = True
    return _star(st.T, moved, within)


def _star(T, mask, within=None):
    """The triangles (sorted) with a corner in the vertex `mask`, looked for among `within`
    when given — (star, T[star]): sorted triangles holding all of them, a caller's star of more
    vertices, and their corners — else in the whole mesh: a round's moves judged in chunks and
    kept look at their stars, not at every triangle each time (at 1e6 vertices a pass over the
    mesh is 20 ms; the 512² raster's repair there asks for some 300 stars)."""
    if within is None:
        return np.flatnonzero(touching(T, mask))
    star, near = within
    return star[touching(near, mask)]


def _along(d, t):
    """Moves d (..., k, 2) of k vertices whose unit tangents are t (k, 2) (`tangents`): a vertex
    with a tangent moves by its move's share along it, the others by their move."""
    slide = np.any(t != 0, axis=-1)[..., None]
    return t * np.einsum("...i,...i->...", d, t)[..., None] + np.where(slide, 0.0, d)


def _accepted(st, d, moving, shape, within=None):
    """Which `moving` vertices (two triangles apart) `relax` takes moved by d: their stars'
    edges and shapes judged first on rough means (`ElementMeans.rough`, 7 points a triangle),
    and the moves that pass judged again on the means at the new places (each mover is judged
    on its own star: the same verdict among fewer movers) unless the rough means are those
    (a raster's: the moves taken keep them, `_keep`). `within`: as `_judged`'s."""
    v = np.flatnonzero(moving)
    out = np.zeros(len(st.P), bool)
    ok = _judged(st, v, d[v][None], shape, how="rough", within=within)[0][0]
    maybe = v[ok]
    if _rough_exact(st):                       # judged on the means it is kept with
        _keep(st, ok[None])
        out[maybe] = True
    elif len(maybe):
        out[maybe] = _judged(st, maybe, d[maybe][None], shape, within=within)[0][0]
    return out


def _rough_exact(st):
    """The state's rough means are its kept ones (a raster's): a try judged on them is judged."""
    return bool(getattr(st.field, "rough_exact", False))


def _keep(st, kept):
    """Keep the means of the tries `kept` ((K, k): try, mover) of the last rough `_judged` of a
    field whose rough means are exact (computed, not kept, by `ElementMeans.rough`): the moves
    taken find them when the mesh takes them, with the bits they were judged on."""
    tried, st.tried = st.tried, None
    if tried is None or not kept.any():
        return
    pts, tri, Qn, en, tags, mover = tried
    K, m = len(kept), len(mover)
    rows = np.flatnonzero(kept[np.repeat(np.arange(K), m), np.tile(mover, K)])
    if tags is None:
        st.field.keep(pts, tri[rows], Qn[rows], en[rows])
    else:
        st.field.keep(pts, tri[rows], Qn[rows], en[rows], tags[rows])


def _judged(st, v, D, shape, how="means_with_error", within=None):
    """K tries D (K, k, 2) at moving the vertices v (k,) of the state `st`, two triangles apart,
    judged at once (one call for the means of all their stars, `how`: see `shares.means_of`;
    the shares from beyond the stars as `st.cut` has them): which each takes ((K, k):
    `_accepted`'s rule) and the worst quality of its star after the move, each triangle in its
    own means. The stars are looked for among the triangles `within` (`_star`) when given."""
    P, T, twin, Qbar, s, b, reg = st.P, st.T, st.cut, st.Qbar, st.s, st.b, st.reg
    n, (K, k) = len(P), D.shape[:2]
    st.tried = None
    mask = np.zeros(n, bool)
    mask[v] = True
    star = _star(T, mask, within)
    if not len(star):
        return np.zeros((K, k), bool), np.full((K, k), -np.inf)
    Ts, m = T[star], len(star)
    corner = np.argmax(mask[Ts], axis=1)                      # each star triangle's one mover
    local_v = np.full(n, -1, np.int64)
    local_v[v] = np.arange(k)
    mover = local_v[Ts[np.arange(m), corner]]
    X = np.repeat(P[Ts][None], K, axis=0)                     # (K, m, 3, 2): the stars
    moved = X.copy()
    moved[:, np.arange(m), corner] += D[:, mover]
    tri = np.arange(3 * K * m).reshape(-1, 3)
    # a try that flattens or turns over a triangle of its star leaves it (and Ω) and is not
    # taken: its star is judged unmoved, so the field is never asked outside its domain
    dead = ~proper(moved.reshape(-1, 2), tri).reshape(K, m)
    flat = np.zeros((K, k), bool)
    flat[np.nonzero(dead)[0], mover[np.nonzero(dead)[1]]] = True
    X = np.where(flat[:, mover, None, None], X, moved)
    pts = X.reshape(-1, 2)
    tags = None if reg is None else np.tile(reg[star], K)
    Qn, en = _try_means(st, how, pts, tri, tags, star, mover,
                        flat | (np.hypot(D[..., 0], D[..., 1]) == 0), corner)
    st.tried = (pts, tri, Qn, en, tags, mover) if how == "rough" and _rough_exact(st) else None
    sn, bn = (x.reshape(K, 3 * m) for x in shares(pts, tri, Qn, en))
    he = (3 * star[:, None] + np.arange(3)).ravel()
    local = np.full(len(T), -1, np.int64)
    local[star] = np.arange(m)
    tw = twin[he]
    tw_local = np.where(tw >= 0, local[tw // 3], -1)
    inside = tw_local >= 0
    tw_he_local = np.where(inside, 3 * tw_local + tw % 3, 0)
    once = ~inside | (he < tw)                     # each edge of the stars once
    old_q = s[he] + np.where(tw >= 0, s[np.maximum(tw, 0)], 0.0)
    old_b = b[he] + np.where(tw >= 0, b[np.maximum(tw, 0)], 0.0)
    old_c = np.abs(s[he]) + np.where(tw >= 0, np.abs(s[np.maximum(tw, 0)]), 0.0)
    other = np.where(inside, sn[:, tw_he_local], np.where(tw >= 0, s[np.maximum(tw, 0)], 0.0))
    other_b = np.where(inside, bn[:, tw_he_local], np.where(tw >= 0, b[np.maximum(tw, 0)], 0.0))
    new_q, new_b = sn + other, bn + other_b
    new_c = np.abs(sn) + np.abs(other)
    owner = np.repeat(mover, 3)[once]
    row = (np.arange(K)[:, None] * k + owner).ravel()        # (try, mover) of each edge, flat

    def per_vertex(q, bound, scale):
        q, bound, scale = (np.broadcast_to(x, (K, 3 * m))[:, once].ravel()
                           for x in (q, bound, scale))
        fail = np.bincount(row, ~(q - bound >= -ROUND * scale), minlength=K * k)
        short = np.bincount(row, deficit(q, bound), minlength=K * k)
        return fail.reshape(K, k), short.reshape(K, k)
    f0, d0 = per_vertex(old_q, old_b, old_c)
    f1, d1 = per_vertex(new_q, new_b, new_c)
    q0, q1 = np.full(k, np.inf), np.full((K, k), np.inf)
    np.minimum.at(q0, mover,
                  np.nan_to_num(metric_quality(P, Ts, shape_metric(Qbar[star])), nan=0.0))
    np.minimum.at(q1, (np.repeat(np.arange(K), m), np.tile(mover, K)),
                  np.nan_to_num(metric_quality(pts, tri, shape_metric(Qn)), nan=0.0))
    if shape:
        take = (f1 <= f0) & (d1 <= d0) & (q1 > q0)
    else:
        take = ((f1 <= f0) & (d1 <= d0) & ((f1 < f0) | (d1 < (1.0 - GAIN) * d0))
                & (q1 >= np.minimum(q0, KEEP * FLOOR)))
    return take & (np.hypot(D[..., 0], D[..., 1]) > 0) & ~flat, q1


def _try_means(st, how, pts, tri, tags, star, mover, still, corner):
    """The means and error bounds of the K tries' stars (K m triangles `tri` over `pts`, the
    mover at `corner` of each star triangle), the stars of the tries `still` ((K, k): refused
    on geometry alone, a triangle flattened or no move) left unmoved. Rough means are asked
    for the moved stars only, and the unmoved ones take the state's own: a refused try's means
    decide nothing (stars two triangles apart share no edge), and each other triangle's rough
    mean is its own, whatever the batch. Other means come from the cache
    (`cache.ElementMeans`), where an unmoved star is already kept."""
    if how != "rough" or not still.any():
        if how == "rough" and _rough_exact(st):
            pts, tri = _far_sides_shared(pts, len(still), corner)
        Qn, en = st.means(how, pts, tri, tags)
        return np.asarray(Qn, dtype=float), np.asarray(en, dtype=float)
    K, m = len(still), len(star)
    if _rough_exact(st):
        pts, tri = _far_sides_shared(pts, K, corner)
    kept = still[:, mover].ravel()                           # (K m,): unmoved triangles
    Qn, en = np.empty((K * m, 2, 2)), np.empty(K * m)
    Qn[kept], en[kept] = np.tile(st.Qbar[star], (K, 1, 1))[kept], np.tile(st.err[star], K)[kept]
    ask = np.flatnonzero(~kept)
    if len(ask):
        Qa, ea = st.means(how, pts, tri[ask], None if tags is None else tags[ask])
        Qn[ask], en[ask] = Qa, ea
    return Qn, en


def _far_sides_shared(pts, K, corner):
    """The K tries' star triangles (K m, 3) over points of their own (`pts`, three a triangle)
    renumbered so that the corners a try does not move are one point in every try: a raster's
    means (`means.raster_means`) integrate each side two triangles share once, so a star
    triangle's far side, the same in every try, is integrated once instead of K times. Each
    triangle's corners keep their order of numbers (the mover's number lies between those of
    the corners before and after it), so each side is integrated in the same direction and
    every mean comes out as over points of its own, bit for bit."""
    m = len(corner)
    j = np.arange(3)[None, None, :]
    c = corner[None, :, None]
    base = (K + 2) * np.arange(m)[None, :, None]
    idx = np.where(j < c, base + j, np.where(j == c, base + c + np.arange(K)[:, None, None],
                                             base + K + j - 1))
    idx = np.broadcast_to(idx, (K, m, 3)).reshape(-1, 3)
    shared = np.empty(((K + 2) * m, 2))
    shared[idx.ravel()] = pts
    return shared, idx


def _own_metric(H):
    """The metric of the triangles of a star, each its own H (in the order `shape_step` asks for
    them: its triangles are the star's, in order, block after block of `triangles.chunks`, so
    each call is served the next rows): what the quality (2.94) is measured in."""
    served = [0]

    def hessian(X):
        start = served[0]
        assert start + len(X) <= len(H)
        served[0] = (start + len(X)) % len(H)  # the last block served: the star's start again
        return H[start:start + len(X)]
    return Anisotropy.metric_only(hessian, "element means")
