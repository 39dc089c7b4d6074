"""The first triangulation of a constant-Q run in closed form where its points are a lattice.

For a constant Q almost every initial point is a point of the hexagonal lattice of the metric
frame (seeding.metric_lattice), and the Q-Delaunay triangulation (2.74)–(2.75) of such points is
known: each lattice point (u, row) with its right neighbour (u + 2, row) and the point above
between them (u + 1, row + 1) makes an "up" triangle, and (u + 2, row), (u + 3, row + 1),
(u + 1, row + 1) a "down" one. Only the layer next to the boundary needs Qhull:

- D, the lattice triangles whose three vertices lie farther than DEEP·h (metric) from every
  boundary segment. Their circumcircles (radius h/√3; the jitter is 1e-3·h) hold no other
  lattice point (the nearest lies 2h/√3 from the centre) and no boundary point, so every
  triangle of D is Q-Delaunay in the whole point set, perturbed as `_perturbed_hull` perturbs
  it (only boundary heights are raised). DEEP also keeps D's vertices out of every diametral
  ellipse from which conform._conforming drops points (subsegments up to LONG·h = 2h long).
- S, the points not strictly inside the region D covers (a vertex of D is inside when no
  border edge of D ends at it). A triangle of the whole triangulation that is not in D has no
  vertex inside (the star of such a vertex is D's fan around it), so it is a triangle of the
  triangulation of S; the triangles of S's triangulation that lie inside D's region are told
  apart by D's border edges, which are edges of both (connected components across the other
  edges, labelled by the side of a border edge they lie on).

The result is the perturbed hull of all the points, built with Qhull on S only: at 1e6
vertices S is a few percent of them. Wherever a step cannot be trusted (a border edge missing
from S's triangulation, a component on both sides, Qhull failing on S) it returns None and the
caller builds the whole hull, as before.
"""

from __future__ import annotations

import numpy as np

from qmesh.errors import QmeshError
from qmesh.geometry import rings, topology
from qmesh.geometry.portable import det2, times2

DEEP = 3.0     # metric edge lengths between a vertex of D and the boundary (≥ 1.5 + 2/√3)
TABLE_FILL = 8     # the deep points are looked up in a table of their places up to this many per point


def deep_points(domain, lattice) -> np.ndarray:
    """Mask of the lattice's points farther than DEEP·h (metric) from every boundary segment."""
    A, B = domain.segment_ends
    M = lattice.frame
    return ~np.isfinite(rings.distance(times2(lattice.points, M), times2(A, M), times2(B, M),
                                       DEEP * lattice.h))


def closed_form(lattice, place: np.ndarray, deep: np.ndarray):
    """The `closed_form` hook of triangulate.first_triangulation for points whose lattice
    index is `place` (-1 for the others), `deep` from deep_points: (triangles, twins), or None."""
    def build(hull_of):
        D, twin = _deep_triangles(lattice, place, deep)
        if not len(D):
            return None
        n = len(place)
        border = np.flatnonzero(twin < 0)
        a, b = D.ravel()[border], D[:, topology.NXT].ravel()[border]
        inside = np.zeros(n, bool)
        inside[D.ravel()] = True
        inside[a] = False
        inside[b] = False
        try:
            TS = hull_of(~inside)
        except QmeshError:
            return None
        return _glued(D, twin, border, TS, n, a, b)
    return build


def _deep_triangles(lattice, place: np.ndarray, deep: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """D: the up and down lattice triangles whose three vertices are deep (point indices, ccw),
    and their twins, in closed form (each lattice triangle's neighbours are the lattice's)."""
    on = np.flatnonzero(place >= 0)
    on = on[deep[place[on]]]
    u, row = lattice.u[place[on]], lattice.row[place[on]]
    if not len(on):
        return np.empty((0, 3), np.int64), np.empty(0, np.int64)
    u0, width = u.min() - 4, int(u.max() - u.min()) + 8
    key = (row - row.min() + 1) * width + (u - u0)
    size = int(key.max()) + 2 * width + 4
    if size <= TABLE_FILL * len(key):               # a table of every place: one gather each
        table = np.full(size, -1, np.int64)
        table[key] = np.arange(len(on))

        def find(du, dr, at=None):
            """Position in `on` of the point (du, dr) from each anchor (those `at`), or -1."""
            return table[(key if at is None else key[at]) + (dr * width + du)]
    else:                                           # a long thin lattice: by a sort
        order = np.argsort(key)
        sorted_key = key[order]

        def find(du, dr, at=None):
            want = (key if at is None else key[at]) + dr * width + du
            pos = np.minimum(np.searchsorted(sorted_key, want), len(sorted_key) - 1)
            return np.where(sorted_key[pos] == want, order[pos], -1)

    # the anchor (u, row) of every triangle is a deep point: "up" (u, row), (u + 2, row),
    # (u + 1, row + 1); "down" (u + 2, row), (u + 3, row + 1), (u + 1, row + 1); by position in `on`
    right, above = find(2, 0), find(1, 1)
    is_up = (right >= 0) & (above >= 0)
    ups = np.flatnonzero(is_up)                                        # the up triangles' anchors
    above_right = find(3, 1, ups)
    downs = ups[above_right >= 0]                                      # the down ones'
    above_right = above_right[above_right >= 0]
    up_id = np.full(len(on) + 1, -1, np.int64)                         # each anchor's row in D
    up_id[ups] = np.arange(len(ups))                                   # (position -1 reads -1)
    down_id = np.full(len(on) + 1, -1, np.int64)
    down_id[downs] = len(ups) + np.arange(len(downs))
    T = np.empty((len(ups) + len(downs), 3), np.int64)                 # up rows, then down rows
    T[:len(ups), 0] = on[ups]
    T[:len(ups), 1] = on[right[ups]]
    T[:len(ups), 2] = on[above[ups]]
    T[len(ups):, 0] = on[right[downs]]
    T[len(ups):, 1] = on[above_right]
    T[len(ups):, 2] = on[above[downs]]
    # the neighbours: up's edges 0, 1, 2 face the down triangles anchored at (u − 1, row − 1)
    # (its edge 1), (u, row) (edge 2) and (u − 2, row) (edge 0); down's face the up ones
    # anchored at (u + 2, row) (edge 2), (u + 1, row + 1) (edge 0) and (u, row) (edge 1)

    def half(rows, e):
        return np.where(rows >= 0, 3 * rows + e, -1)
    twin = np.empty((len(T), 3), np.int64)
    twin[:len(ups), 0] = half(down_id[find(-1, -1, ups)], 1)
    twin[:len(ups), 1] = half(down_id[ups], 2)
    twin[:len(ups), 2] = half(down_id[find(-2, 0, ups)], 0)
    twin[len(ups):, 0] = half(up_id[right[downs]], 2)
    twin[len(ups):, 1] = half(up_id[above[downs]], 0)
    twin[len(ups):, 2] = half(up_id[downs], 1)
    twin = twin.ravel()
    if det2(lattice.frame) < 0:       # the frame maps the domain reversed: (a, c, b)
        T = T[:, [0, 2, 1]]
        swap = np.array([2, 1, 0])          # edge e of (a, b, c) is edge 2 − e of (a, c, b)
        twin = twin.reshape(-1, 3)[:, ::-1].ravel()
        twin = np.where(twin >= 0, twin - twin % 3 + swap[twin % 3], -1)
    return T, twin


def _glued(D, twin, border, TS, n, a, b):
    """D and S's triangles outside D's region, and their twins: D's, S's own among the kept
    ones, and across D's border half-edges a→b, S's b→a. None where S's triangulation does not
    hold every border edge on both sides, or meets D's region elsewhere."""
    keep = _outside(TS, n, a, b)
    if keep is None:
        return None
    keep, tw_s, h_out = keep
    rows = np.cumsum(keep) - 1 + len(D)                # S's row t → its row in the result
    kept_h = (3 * np.flatnonzero(keep)[:, None] + np.arange(3)).ravel()
    tw = tw_s[kept_h]
    inner = tw >= 0
    across = np.zeros(len(tw), bool)
    across[inner] = ~keep[tw[inner] // 3]              # a kept triangle's neighbour in D's region
    new = np.where(inner, 3 * rows[np.maximum(tw, 0) // 3] + tw % 3, -1)
    out_h = 3 * rows[h_out // 3] + h_out % 3           # h_out in the result
    if np.count_nonzero(across) != len(h_out) or not keep[h_out // 3].all():
        return None
    new[across] = -1
    full = np.concatenate([twin, new])
    full[border] = out_h
    full[out_h] = border
    return np.concatenate([D, TS[keep]]), full


def _outside(TS: np.ndarray, n: int, a: np.ndarray, b: np.ndarray):
    """(mask of S's triangles outside D's region, S's twins, S's half-edges b→a), D's border
    half-edges being a→b (D on their left); None where S's triangulation does not hold every
    border edge on both sides."""
    h_in, h_out = topology.find_half_edges(TS, n, a, b), topology.find_half_edges(TS, n, b, a)
    if np.any(h_in < 0) or np.any(h_out < 0):
        return None
    try:
        tw = topology.twins(TS)
        return ~topology.left_of(TS, tw, h_in), tw, h_out
    except ValueError:
        return None
