"""The polish's merges: a side vertex whose two triangles fan out from one inner vertex removed,
the two made one, where that raises their worst quality and breaks no edge (FIELDS.md §4).

Where a field line touches a side of the domain, the side's metric changes fast along it and the
mesher places the side's vertices closer than the inner ones: a row of thin triangles fans out
from one inner vertex, each with a small angle there. No flip mends a fan (the flip of an edge
between two of its triangles would join two vertices in line on the side) and no move of one
vertex widens every angle of it; removing every other side vertex doubles them. A vertex v on a
straight piece of a side (not a seed) whose star is the two triangles (a, v, c) and (v, b, c)
becomes the triangle (a, b, c), judged as a quality flip is: the deficit of its three edges no
higher than that of the five edges it replaces, and its quality above the worse of the two.
The vertex is left unused until `compact` drops it.
"""

from __future__ import annotations

import numpy as np

from qmesh.conductivity.anisotropy import shape_metric
from qmesh.fields.shares import GAIN, deficit, independent, shares
from qmesh.geometry import topology
from qmesh.geometry.triangles import metric_quality, proper


def side_merges(st, v, tangent):
    """Merge the side vertices among v of the state `st` (repair_state.RepairState, no regions)
    that may go: in line on a side (`tangent` not 0), two triangles in their star, the merged
    triangle proper, better and no edge worse; no two merges touching one triangle or its
    neighbours. Changes the state's mesh, means and shares; returns how many merged."""
    P, T, twin = st.P, st.T, st.twin
    v = topology.sorted_unique(np.asarray(v, np.int64))
    count = np.bincount(T.ravel(), minlength=len(P))
    v = v[np.any(tangent[v] != 0, axis=1) & ~st.fixed[v] & (count[v] == 2)]
    if not len(v):
        return 0
    hb = np.flatnonzero(twin < 0)
    start = np.full(len(P), -1, np.int64)      # the boundary half-edge leaving each vertex
    end = np.full(len(P), -1, np.int64)        # ... and the one arriving at it
    start[T[hb // 3, hb % 3]] = hb
    end[T[hb // 3, topology.NXT[hb % 3]]] = hb
    h_in, h_out = end[v], start[v]             # a → v in (a, v, c), v → b in (v, b, c)
    t_in, t_out = h_in // 3, h_out // 3
    ok = (h_in >= 0) & (h_out >= 0) & (t_in != t_out)
    v, h_in, h_out, t_in, t_out = v[ok], h_in[ok], h_out[ok], t_in[ok], t_out[ok]
    a = T[t_in, h_in % 3]
    c = T[t_in, topology.PRV[h_in % 3]]
    b = T[t_out, topology.NXT[h_out % 3]]
    ok = T[t_out, topology.PRV[h_out % 3]] == c
    v, h_in, h_out, t_in, t_out, a, b, c = (x[ok] for x in (v, h_in, h_out, t_in, t_out, a, b, c))
    new = np.column_stack([a, b, c])
    ok = proper(P, new)
    if not ok.any():
        return 0
    v, h_in, h_out, t_in, t_out, new = (x[ok] for x in (v, h_in, h_out, t_in, t_out, new))
    ca = 3 * t_in + topology.PRV[h_in % 3]     # c → a, kept by the merged triangle
    bc = 3 * t_out + topology.NXT[h_out % 3]   # b → c
    vc = 3 * t_out + topology.PRV[h_out % 3]   # c → v ... and its twin v → c in t_in
    s, bnd = st.s, st.b
    out_ca, out_bc = twin[ca], twin[bc]

    def outside(x, g):
        return np.where(g >= 0, x[np.maximum(g, 0)], 0.0)

    before = (deficit(s[h_in], bnd[h_in]) + deficit(s[h_out], bnd[h_out])
              + deficit(s[vc] + s[twin[vc]], bnd[vc] + bnd[twin[vc]])
              + deficit(s[ca] + outside(s, out_ca), bnd[ca] + outside(bnd, out_ca))
              + deficit(s[bc] + outside(s, out_bc), bnd[bc] + outside(bnd, out_bc)))
    Qn, en = st.means("means_with_error", P, new, None)
    Qn, en = np.asarray(Qn, dtype=float), np.asarray(en, dtype=float)
    sn, bn = (x.reshape(-1, 3) for x in shares(P, new, Qn, en))   # a→b, b→c, c→a
    after = (deficit(sn[:, 0], bn[:, 0])
             + deficit(sn[:, 1] + outside(s, out_bc), bn[:, 1] + outside(bnd, out_bc))
             + deficit(sn[:, 2] + outside(s, out_ca), bn[:, 2] + outside(bnd, out_ca)))
    Qbar = st.Qbar
    was = np.minimum(metric_quality(P, T[t_in], shape_metric(Qbar[t_in])),
                     metric_quality(P, T[t_out], shape_metric(Qbar[t_out])))
    now = np.nan_to_num(metric_quality(P, new, shape_metric(Qn)), nan=-1.0)
    gain = now - np.nan_to_num(was, nan=0.0)
    better = (after <= before) & (gain > GAIN)
    if not better.any():
        return 0
    M = len(T)
    near_ca = np.where(out_ca >= 0, out_ca // 3, M + 2 * np.arange(len(v)))
    near_bc = np.where(out_bc >= 0, out_bc // 3, M + 2 * np.arange(len(v)) + 1)
    cand = np.flatnonzero(better)
    pick = cand[independent(cand, -gain[cand], (t_in[cand], t_out[cand], near_ca[cand],
                                                near_bc[cand]))]
    _merge(st, t_in[pick], t_out[pick], new[pick], ca[pick], bc[pick])
    return len(pick)


def _merge(st, t_in, t_out, new, ca, bc):
    """Make rows t_in the merged triangles `new` (a, b, c), their sides' twins those of c → a
    (`ca`) and b → c (`bc`), delete rows t_out (`topology.remove_triangles`, whose row moves the
    state's per-triangle arrays follow), and bring the merged triangles' means up to date."""
    T, twin = st.T, st.twin                                 # the state's own: rewritten
    g_bc, g_ca = twin[bc], twin[ca]
    T[t_in] = new
    twin[3 * t_out[:, None] + np.arange(3)] = -1           # t_out leaves no link behind
    twin[3 * t_in] = -1                                     # a → b: the side
    twin[3 * t_in + 1], twin[3 * t_in + 2] = g_bc, g_ca
    for h, g in ((3 * t_in + 1, g_bc), (3 * t_in + 2, g_ca)):
        inner = g >= 0
        twin[g[inner]] = h[inner]
    M = len(T)
    row = np.arange(M)                                      # where each row goes
    gone = np.zeros(M, bool)
    gone[t_out] = True
    tail = np.arange(M - len(t_out), M)
    tail = tail[~gone[tail]]
    holes = np.sort(t_out[t_out < M - len(t_out)])
    row[tail] = holes
    st.T, st.twin = topology.remove_triangles(T, twin, t_out)
    keep = np.arange(M - len(t_out))
    keep[holes] = tail
    half = (3 * keep[:, None] + np.arange(3)).ravel()
    st.Qbar, st.err, st.tight = st.Qbar[keep], st.err[keep], st.tight[keep]
    st.s, st.b = st.s[half], st.b[half]
    st.seen.edges = st.seen.edges[half]
    if st.quality is not None:
        st.quality = st.quality[keep]
    st.renumber(half)
    st.cut = st.twin if st.reg is None else st.cut         # merges are made without regions
    st.refresh(row[t_in])


def compact(st) -> None:
    """Drop the vertices no triangle uses (those `side_merges` removed), renumbering the rest."""
    used = np.zeros(len(st.P), bool)
    used[st.T.ravel()] = True
    if used.all():
        return
    new = np.cumsum(used) - 1
    st.P, st.T = st.P[used], new[st.T]
    st.fixed, st.out = st.fixed[used], st.out[used]
    st.seen.vertices = st.seen.vertices[used]
