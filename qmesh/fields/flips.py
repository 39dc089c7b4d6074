"""The repair's flips: of failing edges where that lowers their quadrilateral's deficit, and of
poorly shaped triangles' edges where that raises their worst quality and breaks no edge.

FIELDS.md §4. A flip judged on its own edge alone mends it by breaking a side, and such flips
cycle without end: a flip is taken only when the deficit of the quadrilateral's five edges (its
diagonal and its four sides, their shares from outside it kept) falls, so the total only falls
and the flips end. The new triangles' means are computed (`shares.means_of`).
"""

from __future__ import annotations

import numpy as np

from qmesh.conductivity.anisotropy import shape_metric
from qmesh.fields.shares import GAIN, deficit, independent, shares
from qmesh.geometry import topology
from qmesh.geometry.triangles import metric_quality, proper


def mending_flips(st, h, refused=None):
    """Flips of failing interior half-edges h of the state `st` (repair_state.RepairState) that
    lower the deficit Σ max(0, bound − q_ij) over the five edges of their quadrilateral (its
    diagonal and its four sides, whose shares from outside it stay): a flip that mends its own edge
    by breaking a side is not taken, so the total deficit only falls and the flips end. No two
    chosen flips touch one edge. `refused` (a mask over the half-edges, when given) is set on the h
    whose flip is not better (`Judged`)."""
    if refused is not None:
        refused[h] = True
    c = _flip_candidates(st, h)
    if c is None:
        return h[:0]
    inner, before, after, _, _, tris = c
    gain = before - after
    better = gain > GAIN * before
    if refused is not None:
        refused[inner[better]] = False
    return _chosen(inner, gain, better, tris)


def quality_flips(st, h):
    """Flips of the interior edges h of the state `st` that raise the worst metric quality
    (2.94) of their two triangles, each in its own means, and raise no deficit of their
    quadrilateral's five edges (an edge that passes keeps passing)."""
    c = _flip_candidates(st, h)
    if c is None:
        return h[:0]
    inner, before, after, new, Qn, tris = c
    P, T, twin, Qbar = st.P, st.T, st.cut, st.Qbar
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
    pick = independent(cand, -gain[better], tuple(t[better] for t in tris))
    return cand[pick]


def _flip_candidates(st, h):
    """For the interior half-edges h (interfaces cut: `st.cut`) whose quadrilateral is convex:
    the half-edges, the deficit of the five edges before and after the flip, the new triangles
    (2k, 3) and their means, and the triangles each flip touches (None when there are none)."""
    P, T, twin, s, b, reg = st.P, st.T, st.cut, st.s, st.b, st.reg
    inner = h[twin[h] >= 0]
    if not len(inner):
        return None
    g = twin[inner]
    t1, e1 = np.divmod(inner, 3)
    t2, e2 = np.divmod(g, 3)
    u, v, a = T[t1, e1], T[t1, topology.NXT[e1]], T[t1, topology.PRV[e1]]
    bb = T[t2, topology.PRV[e2]]
    new = np.concatenate([np.column_stack([u, bb, a]), np.column_stack([bb, v, a])])
    ok = proper(P, new).reshape(2, -1).all(axis=0)     # a convex quadrilateral, not flat
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
    before = (deficit(s[inner] + s[g], b[inner] + b[g])
              + deficit(s[sides] + out_s, b[sides] + out_b).sum(axis=1))
    Qn, en = st.means("means_with_error", P, new, None if reg is None else np.tile(reg[t1], 2))
    Qn = np.asarray(Qn, dtype=float)
    sn, bn = shares(P, new, Qn, np.asarray(en, dtype=float))
    sn, bn = sn.reshape(2, k, 3), bn.reshape(2, k, 3)
    # (u, b, a) holds u→b, b→a, a→u; (b, v, a) holds b→v, v→a, a→b
    pick_t, pick_e = np.array([1, 0, 0, 1]), np.array([1, 2, 0, 0])   # v→a, a→u, u→b, b→v
    side_s, side_b = sn[pick_t, :, pick_e].T, bn[pick_t, :, pick_e].T
    after = (deficit(sn[0, :, 1] + sn[1, :, 2], bn[0, :, 1] + bn[1, :, 2])
             + deficit(side_s + out_s, side_b + out_b).sum(axis=1))
    M = len(T)
    near = np.where(across >= 0, across // 3, M + 4 * np.arange(k)[:, None] + np.arange(4))
    tris = (t1, t2) + tuple(near.T)
    return inner, before, after, new, Qn, tris
