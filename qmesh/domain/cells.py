"""A zoned or layered model given as per-cell arrays: the zones behind `Domain.from_cells`.

A structured grid of nx × ny cells (edges `x` (nx+1,), `y` (ny+1,)), each with principal
conductivities `k1` (along the angle), `k2` (across it) and `angle` in degrees counter-clockwise
from the x axis (MODFLOW's K, K22 and ANGLEX, with K22 given as a conductivity, not as a ratio).
Cells of equal (k1, k2, angle) that share an edge are merged into one region (4-connected
components), whose outline is traced along the cell edges and stripped of the points where it
runs straight on; the corners where three zones meet come back as splits (partition.py).

Cost: every region is meshed on its own (a call of Algorithm 2.1 each), and every corner where
zones meet is a fixed vertex. A model whose cells all differ is nx·ny regions: at least
(nx+1)(ny+1) vertices and nx·ny mesher calls, so zone it first.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from qmesh import checks
from qmesh.errors import QmeshError


def _grid_axis(v, name: str) -> np.ndarray:
    a = checks.real_values(v, name)
    if a.ndim != 1 or len(a) < 2 or not np.all(np.isfinite(a)) or not np.all(np.diff(a) > 0):
        raise QmeshError(f"{name} must be at least two increasing finite cell edges, got {v!r:.80}")
    return a


def _field(v, shape, name: str) -> np.ndarray:
    a = checks.real_values(v, name)
    try:
        a = np.broadcast_to(a, shape)
    except ValueError:
        raise QmeshError(f"{name} must be a number or an array of shape {shape} (ny, nx)") from None
    if not np.all(np.isfinite(a)):
        raise QmeshError(f"{name} has values that are not finite numbers")
    return a


def zones(x, y, k1, k2, angle=0.0):
    """The regions of a grid of cells with per-cell k1, k2, angle (arrays of shape (ny, nx), row
    j between y[j] and y[j+1]): (outline, [(outer ring, [hole rings]) per region],
    [(k1, k2, angle) per region, region 0 first]). The zone of the first cell (lowest row,
    leftmost) is region 0 where it is one piece, other pieces are regions 1, 2, …
    `Domain.from_cells` builds the domain and the conductivities from them."""
    x, y = _grid_axis(x, "x"), _grid_axis(y, "y")
    shape = (len(y) - 1, len(x) - 1)
    K1, K2, ANG = (_field(v, shape, n) for v, n in ((k1, "k1"), (k2, "k2"), (angle, "angle")))
    if np.any(K1 <= 0) or np.any(K2 <= 0):
        raise QmeshError("k1 and k2 must be > 0 in every cell")
    ny, nx = shape
    triple = np.stack([K1.ravel(), K2.ravel(), np.mod(ANG.ravel(), 180.0)], axis=1)
    values, zone = np.unique(triple, axis=0, return_inverse=True)
    zone = zone.reshape(shape)
    # 4-connected components of equal zone
    idx = np.arange(nx * ny).reshape(shape)
    same_x = zone[:, 1:] == zone[:, :-1]
    same_y = zone[1:, :] == zone[:-1, :]
    a = np.concatenate([idx[:, 1:][same_x], idx[1:, :][same_y]])
    b = np.concatenate([idx[:, :-1][same_x], idx[:-1, :][same_y]])
    n_comp, comp = connected_components(sp.coo_matrix((np.ones(len(a)), (a, b)),
                                                      shape=(nx * ny,) * 2), directed=False)
    comp = comp.reshape(shape)
    outline = [(x[0], y[0]), (x[-1], y[0]), (x[-1], y[-1]), (x[0], y[-1])]
    zone_of = np.zeros(n_comp, np.int64)
    zone_of[comp.ravel()] = zone.ravel()
    rings = _component_rings(x, y, comp, n_comp)
    base = comp[0, 0]
    regions, params = [], [tuple(float(v) for v in values[zone_of[base]])]
    for c in range(n_comp):
        if c == base:
            continue
        regions.append(rings[c])
        params.append(tuple(float(v) for v in values[zone_of[c]]))
    return outline, regions, params


def cell_of_zone(x, y, k1, k2, angle, params) -> str:
    """Where the zone of conductivity `params` (k1, k2, angle) lies, for a message: its first
    cell (row j, column i) and that cell's corner."""
    x, y = _grid_axis(x, "x"), _grid_axis(y, "y")
    shape = (len(y) - 1, len(x) - 1)
    K1, K2, ANG = (_field(v, shape, n) for v, n in ((k1, "k1"), (k2, "k2"), (angle, "angle")))
    hit = (K1 == params[0]) & (K2 == params[1]) & (np.mod(ANG, 180.0) == params[2])
    j, i = (int(v[0]) for v in np.nonzero(hit))
    return f"cell (row {j}, column {i}) at x = {x[i]:g}, y = {y[j]:g}"


def _component_rings(x, y, comp, n_comp):
    """Per component: (outer ring, [hole rings]) traced along cell edges, straight runs merged."""
    ny, nx = comp.shape
    vid = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    V = np.stack(np.meshgrid(x, y), axis=-1).reshape(-1, 2)
    pad = np.full((ny + 2, nx + 2), -1)
    pad[1:-1, 1:-1] = comp
    # directed boundary edges, the component on the left: (from, to, component)
    j, i = np.mgrid[0:ny, 0:nx]
    c = comp
    pieces = []
    for (dj, di), (fa, fb) in (((-1, 0), (vid[:-1, :-1], vid[:-1, 1:])),      # bottom: → east
                               ((0, 1), (vid[:-1, 1:], vid[1:, 1:])),         # right: → north
                               ((1, 0), (vid[1:, 1:], vid[1:, :-1])),         # top: → west
                               ((0, -1), (vid[1:, :-1], vid[:-1, :-1]))):     # left: → south
        other = pad[1 + j + dj, 1 + i + di]
        on = other != c
        pieces.append(np.stack([fa[on], fb[on], c[on]], axis=1))
    E = np.concatenate(pieces)
    # next edge: the one of the same component leaving this edge's end
    key_from = E[:, 0] * n_comp + E[:, 2]
    key_to = E[:, 1] * n_comp + E[:, 2]
    order = np.argsort(key_from, kind="stable")
    ks = key_from[order]
    pos = np.searchsorted(ks, key_to)
    dup = np.r_[ks[1:] == ks[:-1], False]
    if dup.any():
        v = V[E[order[np.flatnonzero(dup)[0]], 0]]
        raise QmeshError(f"cells of one zone touch only at the corner {v.tolist()}: such a zone "
                         "pinches; give the two cells different values or join them by an edge")
    nxt = order[pos]
    n = len(E)
    _, cyc = connected_components(sp.coo_matrix((np.ones(n), (np.arange(n), nxt)), shape=(n, n)),
                                  connection="weak")
    first = np.full(cyc.max() + 1, -1)
    first[cyc[::-1]] = np.arange(n)[::-1]
    # every cycle walked from its first edge, all at once: steps from each edge to its cycle's
    # first one by pointer doubling (a walk edge by edge is a Python step per cell edge)
    is_first = np.zeros(n, bool)
    is_first[first] = True
    succ, dist = np.where(is_first, np.arange(n), nxt), (~is_first).astype(np.int64)
    while not np.array_equal(succ[succ], succ):
        dist += dist[succ]
        succ = succ[succ]
    size = np.bincount(cyc, minlength=len(first))
    walk = np.lexsort(((size[cyc] - dist) % size[cyc], cyc))
    P = V[E[walk, 0]]
    ring = cyc[walk]
    start = np.cumsum(size) - size
    prev = np.arange(n) - 1
    prev[start] = start + size - 1
    after = np.arange(1, n + 1)
    after[start + size - 1] = start
    d_in, d_out = P - P[prev], P[after] - P
    turn = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    P, ring = P[turn != 0], ring[turn != 0]                # straight runs: their ends only
    size = np.bincount(ring, minlength=len(first))
    start = np.cumsum(size) - size
    after = np.arange(1, len(P) + 1)
    after[start + size - 1] = start
    P0 = P[start][ring]
    R = (P - P0) / np.maximum.reduceat(np.abs(P - P0).max(axis=1), start)[ring][:, None]   # the sign survives
    area = np.bincount(ring, R[:, 0] * R[after, 1] - R[:, 1] * R[after, 0], minlength=len(first))
    owners = E[first, 2].tolist()
    out = [[None, []] for _ in range(n_comp)]
    for k, (a, b) in enumerate(zip(start.tolist(), (start + size).tolist())):
        if area[k] > 0:
            out[owners[k]][0] = P[a:b]
        else:
            out[owners[k]][1].append(P[a:b])
    return out
