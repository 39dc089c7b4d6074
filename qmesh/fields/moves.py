"""The repair's vertex moves: the mesher's shape step, taken only where it mends a star's edges or
improves its worst quality and breaks nothing (FIELDS.md §4).

Movers are chosen two triangles apart, so each edge's shares move with one vertex at most; a
boundary or interface vertex between two others in line slides along that line; a move refused
is tried again only once something it was judged on changed (`Judged`).
"""

from __future__ import annotations

import numpy as np

from qmesh.conductivity.anisotropy import Anisotropy, shape_metric
from qmesh.fields.shares import FLOOR, GAIN, KEEP, ROUND, deficit, means_of, shares
from qmesh.geometry import topology
from qmesh.geometry.topology import touching
from qmesh.geometry.triangles import metric_quality, signed_areas
from qmesh.mesher.adjust import limit_moves, shape_step

STEPS = (1.0, 0.5, 0.25)   # a refused shape move is tried at these shares of its step
IN_LINE = 1e-9      # a boundary vertex this near the line of its neighbours (sine) slides along it


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


def relax(P, T, twin, Qbar, err, s, b, field, metric, movers, shape, tangent=None,
           refused=None, reg=None):
    """Move the vertices `movers` (`movers`) by the mesher's shape step in `metric`
    (`adjust.shape_step`, capped by `adjust.limit_moves`) where their star is better for it:
    no more failing edges and no higher deficit, and fewer or a lower deficit, and a worst
    quality kept above min(its worst before, KEEP · FLOOR) (shape=False: a repair that adds no
    vertex; a star already worse than that, such as a sharp corner's, gets no worse); no more
    failing edges, no higher deficit and a better worst metric quality of the star in its own
    means (shape=True). Returns the new P and the
    triangles that changed. Vertices with a `tangent` (`tangents`) move along it only.
    `refused` (a mask over the vertices, when given) is set on the movers not moved
    (`Judged`)."""
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
    """Which `moving` vertices (two triangles apart) `relax` takes moved by d: their stars'
    edges and shapes judged on the means at the new places."""
    n = len(P)
    star = np.flatnonzero(touching(T, moving))
    if not len(star):
        return np.zeros(n, bool)
    Pn = P + np.where(moving[:, None], d, 0.0)
    Ts = T[star]
    Qn, en = means_of(field, "means_with_error", Pn, Ts, None if reg is None else reg[star])
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
        short = np.bincount(owner, deficit(q, bound)[once], minlength=n)
        return fail, short
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
