"""The repair's splits: each failing edge that no flip or move mends is split at the best of a few
points along it, no two in one triangle (FIELDS.md §4).

The midpoint is tried first (smaller triangles see a more nearly constant Q), then points that
leave no obtuse angle in either half; the one leaving the fewest failing edges around it, its
shapes kept (FLOOR, KEEP), is taken. A medium's interface edge is split on both sides at once,
each child keeping its parent's region tag.
"""

from __future__ import annotations

import numpy as np

from qmesh.conductivity.anisotropy import shape_metric
from qmesh.fields.shares import FLOOR, KEEP, ROUND, cut_interfaces, independent, shares
from qmesh.geometry import topology
from qmesh.geometry.triangles import metric_quality

SPLIT_AT = 0.1      # an edge is split no nearer its ends than this share of it


def split_failing(st, h, q):
    """Split failing edges h (their q_ij q) of the state `st` (repair_state.RepairState),
    boundary ones first (one per triangle), each at the best of a few points along it
    (`split_points`). Returns the triangles that changed."""
    P, T, twin = st.P, st.T, st.twin
    boundary = twin[h] < 0
    if boundary.any():
        hb, qb = h[boundary], q[boundary]
        hb = hb[independent(hb, qb, (hb // 3,))]
        n = len(P)
        u = T[hb // 3, hb % 3]
        X = split_points(st, hb)
        T, twin = topology.split_boundary_edges(T, twin, hb, n + np.arange(len(hb)))
        t = np.concatenate([hb // 3, len(T) - len(hb) + np.arange(len(hb))])
        new_out = st.out[u]
    else:
        hi = h[independent(h, q, (h // 3, twin[h] // 3))]
        n = len(P)
        X = split_points(st, hi)
        t = np.concatenate([hi // 3, twin[hi] // 3, len(T) + np.arange(2 * len(hi))])
        T, twin = topology.split_edges(T, twin, hi, n + np.arange(len(hi)))
        new_out = np.full(len(hi), -1, np.int64)
    st.P, st.T, st.twin = np.concatenate([P, X]), T, twin
    st.cut = cut_interfaces(twin, st.reg)
    st.fixed = np.concatenate([st.fixed, np.zeros(len(X), bool)])
    st.out = np.concatenate([st.out, new_out])
    return t


def split_failing_medium(st, h, q):
    """`split_failing` of a medium: the failing sides on the boundary or an interface first,
    else the interior edges, no two in one triangle (an interface edge touches both of its). A
    boundary edge splits its triangle; an interface or interior edge both
    (`topology.split_edges`), each child keeping its parent's region tag (`st.reg`). Returns
    the triangles that changed."""
    P, T, twin, cut, reg, out = st.P, st.T, st.twin, st.cut, st.reg, st.out
    side = cut[h] < 0
    if side.any():
        h, q = h[side], q[side]
    other = np.where(twin[h] >= 0, twin[h] // 3, h // 3)
    h = h[independent(h, q, (h // 3, other))]
    hb, hi = h[twin[h] < 0], h[twin[h] >= 0]          # one triangle; two (interior or interface)
    none = np.zeros((0, 2))
    Xb = split_points(st, hb) if len(hb) else none
    Xi = split_points(st, hi) if len(hi) else none
    n, M = len(P), len(T)
    u = T[hb // 3, hb % 3]
    T, twin = topology.split_boundary_edges(T, twin, hb, n + np.arange(len(hb)))
    reg = np.concatenate([reg, reg[hb // 3]])
    t1, t2, M2 = hi // 3, twin[hi] // 3, len(T)
    T, twin = topology.split_edges(T, twin, hi, n + len(hb) + np.arange(len(hi)))
    reg = np.concatenate([reg, reg[t1], reg[t2]])
    t = np.concatenate([hb // 3, M + np.arange(len(hb)), t1, t2, M2 + np.arange(2 * len(hi))])
    st.P, st.T, st.twin, st.reg = np.concatenate([P, Xb, Xi]), T, twin, reg
    st.cut = cut_interfaces(twin, reg)
    st.fixed = np.concatenate([st.fixed, np.zeros(len(Xb) + len(Xi), bool)])
    st.out = np.concatenate([out, out[u], np.full(len(hi), -1, np.int64)])
    return t


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


def split_points(st, h):
    """For each edge u→v of the half-edges h of the state `st` (all interior or all on the
    boundary), the first of a few candidate points whose split keeps the shapes (KEEP, FLOOR) and
    leaves the fewest failing edges among those it makes and the sides of the triangles it splits,
    their means recomputed (a split that mends one more edge with a sliver costs the minimum
    quality more than the vertex a later split takes): the midpoint, the quarter points, then for
    each opposite corner a (in its own triangle's metric adj Q̄_T) the foot of its altitude and the
    middles of the spans where (u, p, a) or (p, v, a) has no obtuse angle at p or a. A midpoint
    leaves an obtuse angle at a obtuse in one of the halves, whose edges then fail in turn; a point
    in such a span mends it in one step. A medium's (`st.reg`, the tags; `st.cut`, the twins less
    the interfaces): the shares from beyond the sides as `st.cut` has them, and the halves of an
    interface edge judged side by side."""
    P, T, twin, cut, s, b, Qbar, reg = st.P, st.T, st.twin, st.cut, st.s, st.b, st.Qbar, st.reg
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
    Qn, en = st.means("rough", Pc, new, tags)                              # compared, not kept
    sn, bn = shares(Pc, new, np.asarray(Qn, dtype=float), np.asarray(en, dtype=float))
    sn, bn = sn.reshape(-1, k * c, 3), bn.reshape(-1, k * c, 3)
    across = cut[np.stack(sides, axis=1)]
    out_s = np.repeat(np.where(across >= 0, s[np.maximum(across, 0)], 0.0), c, axis=0)
    out_b = np.repeat(np.where(across >= 0, b[np.maximum(across, 0)], 0.0), c, axis=0)
    # (u, p, a): u→p, p→a, a→u; (p, v, a): p→v, v→a, a→p; (v, p, b): v→p, p→b, b→v;
    # (p, u, b): p→u, u→b, b→p (triangle, corner) of each made edge and each side
    if inner and cut[h[0]] < 0:                              # an interface: side by side
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


def longer(P, T, h, shortest: float) -> np.ndarray:
    """Which half-edges h are longer than `shortest` (split no further: no flat triangles)."""
    a, b = T[h // 3, h % 3], T[h // 3, topology.NXT[h % 3]]
    return np.hypot(*(P[b] - P[a]).T) > shortest
