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
    index is `place` (-1 for the others), `deep` from deep_points."""
    def build(hull_of):
        D = _deep_triangles(lattice, place, deep)
        if not len(D):
            return None
        n = len(place)
        twin = topology.twins(D)
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
        keep = _outside(TS, n, a, b)
        return None if keep is None else np.concatenate([D, TS[keep]])
    return build


def _deep_triangles(lattice, place: np.ndarray, deep: np.ndarray) -> np.ndarray:
    """D: the up and down lattice triangles whose three vertices are deep (point indices, ccw)."""
    on = np.flatnonzero(place >= 0)
    on = on[deep[place[on]]]
    u, row = lattice.u[place[on]], lattice.row[place[on]]
    if not len(on):
        return np.empty((0, 3), np.int64)
    u0, width = u.min() - 4, int(u.max() - u.min()) + 8
    key = (row - row.min() + 1) * width + (u - u0)
    size = int(key.max()) + 2 * width + 4
    if size <= TABLE_FILL * len(key):               # a table of every place: one gather each
        table = np.full(size, -1, np.int64)
        table[key] = on

        def find(du, dr):
            return table[key + (dr * width + du)]
    else:                                           # a long thin lattice: by a sort
        order = np.argsort(key)
        sorted_key = key[order]

        def find(du, dr):
            want = key + dr * width + du
            pos = np.minimum(np.searchsorted(sorted_key, want), len(sorted_key) - 1)
            return np.where(sorted_key[pos] == want, on[order[pos]], -1)

    right, above, above_right = find(2, 0), find(1, 1), find(3, 1)
    up = np.column_stack([on, right, above])
    down = np.column_stack([right, above_right, above])
    T = np.concatenate([up, down])
    T = T[(T[:, 0] >= 0) & (T[:, 1] >= 0) & (T[:, 2] >= 0)]
    if det2(lattice.frame) < 0:       # the frame maps the domain reversed
        T = T[:, [0, 2, 1]]
    return T


def _outside(TS: np.ndarray, n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """Mask of S's triangles outside D's region, whose border half-edges are a→b (D on their
    left); None where S's triangulation does not hold every border edge on both sides."""
    h_in, h_out = topology.find_half_edges(TS, n, a, b), topology.find_half_edges(TS, n, b, a)
    if np.any(h_in < 0) or np.any(h_out < 0):
        return None
    try:
        return ~topology.left_of(TS, topology.twins(TS), h_in)
    except ValueError:
        return None
