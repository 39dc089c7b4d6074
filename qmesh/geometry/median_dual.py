"""The median dual of a triangle mesh: one polygon per vertex, and one face per edge.

Vertex a's cell is bounded, inside each triangle T at a, by the segments from the midpoints of
T's two edges at a to T's centroid (a boundary vertex's cell also has the vertex itself as a
corner). Each triangle is cut into three cells of |T|/3, so a cell's area is the P1 lumped mass
Σ_T |T|/3 and the cells tile the mesh exactly. The face between the cells of i and j is the
polyline from the centroid of one triangle at edge ij through the edge's midpoint to the
centroid of the other (on a boundary edge: from the centroid to the midpoint).

Everything is vectorised: a cell's corners are ordered by sorting the centroids of the triangles
at its vertex by their angle about it (each centroid lies inside its triangle's wedge of angles),
measured from the vertex's outgoing boundary edge on the boundary.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from qmesh.geometry.portable import arctan2
from qmesh.geometry.topology import edge_keys
from qmesh.geometry.triangles import centroids, signed_areas


class MedianDual(NamedTuple):
    """The cells as polygons over a shared list of points.

    `points` (V, 2): the boundary vertices, then the edge midpoints, then the triangle centroids;
    cell k's corners are `corners[offsets[k]:offsets[k + 1]]`, counter-clockwise; `areas` (N,)."""

    points: NDArray[np.float64]
    corners: NDArray[np.int64]
    offsets: NDArray[np.int64]
    areas: NDArray[np.float64]


def median_dual(P: NDArray[np.float64], T: NDArray[np.int64], edges: NDArray[np.int64],
                boundary: NDArray[np.int64]) -> MedianDual:
    """The median dual cells of the mesh (P, T): `edges` (E, 2) every edge (i < j, sorted as
    `qmesh.measure.edge_q` gives them), `boundary` (k, 2) the boundary edges with the mesh on
    their left. A vertex of no triangle has an empty cell."""
    n, m = len(P), len(T)
    keys = edge_keys(edges[:, 0], edges[:, 1], n)                        # sorted: i < j, sorted rows
    is_boundary = np.zeros(n, bool)
    is_boundary[boundary[:, 0]] = True
    bnd_index = np.cumsum(is_boundary) - 1                               # boundary vertex → its point
    n_bnd = int(is_boundary.sum())
    mid0, cen0 = n_bnd, n_bnd + len(edges)
    points = np.concatenate([P[is_boundary], 0.5 * (P[edges[:, 0]] + P[edges[:, 1]]), centroids(P, T)])

    # each corner a of triangle t gives its cell the wedge [midpoint of a→next, centroid of t]
    a = T.ravel()
    b = T[:, [1, 2, 0]].ravel()
    t = np.repeat(np.arange(m), 3)
    mid = mid0 + np.searchsorted(keys, edge_keys(a, b, n))
    # CCW order about a, from the direction of a's outgoing boundary edge (0 inside)
    ref = np.zeros(n)
    d = P[boundary[:, 1]] - P[boundary[:, 0]]
    ref[boundary[:, 0]] = arctan2(d[:, 1], d[:, 0])
    c = points[cen0 + t] - P[a]
    angle = np.mod(arctan2(c[:, 1], c[:, 0]) - ref[a], 2 * np.pi)
    order = np.lexsort((angle, a))
    wedges = np.stack([mid[order], cen0 + t[order]], axis=1)             # (3M, 2), grouped by vertex

    count = 2 * np.bincount(a, minlength=n) + 2 * is_boundary            # + [last midpoint, vertex]
    offsets = np.concatenate([[0], np.cumsum(count)])
    corners = np.empty(offsets[-1], np.int64)
    start = offsets[:-1][a[order]]
    rank = np.arange(len(order)) - np.concatenate([[0], np.cumsum(np.bincount(a, minlength=n))])[a[order]]
    corners[start + 2 * rank] = wedges[:, 0]
    corners[start + 2 * rank + 1] = wedges[:, 1]
    # a boundary vertex closes its cell with the midpoint of its incoming boundary edge and itself
    c_in, v_in = boundary[:, 0], boundary[:, 1]
    end = offsets[v_in + 1]
    corners[end - 2] = mid0 + np.searchsorted(keys, edge_keys(c_in, v_in, n))
    corners[end - 1] = bnd_index[v_in]

    areas = np.bincount(T.ravel(), weights=np.repeat(np.abs(signed_areas(P, T)) / 3.0, 3),
                        minlength=n).astype(np.float64, copy=False)
    return MedianDual(points, corners, offsets, areas)


def dual_faces(P: NDArray[np.float64], T: NDArray[np.int64], edges: NDArray[np.int64]
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(width (E,), unit normal (E, 2) pointing from edges[:, 0] to edges[:, 1]) of each edge's
    median-dual face: its chord, centroid to centroid (centroid to midpoint on the boundary),
    turned a quarter. The chord's width times the normal is the face's integrated normal, so a
    uniform flux v crosses the face at v · normal per unit width."""
    n = len(P)
    keys = edge_keys(edges[:, 0], edges[:, 1], n)
    cen = centroids(P, T)
    k = np.searchsorted(keys, edge_keys(T.ravel(), T[:, [1, 2, 0]].ravel(), n))
    t = np.repeat(np.arange(len(T)), 3)
    starts = np.concatenate([[0], np.cumsum(np.bincount(k, minlength=len(edges)))[:-1]])
    first = np.zeros(len(k), bool)
    first[np.argsort(k, kind="stable")[starts]] = True           # each edge's first triangle
    ends = np.empty((len(edges), 2, 2))
    ends[:, 1] = 0.5 * (P[edges[:, 0]] + P[edges[:, 1]])          # kept on a boundary edge
    ends[k[first], 0] = cen[t[first]]
    ends[k[~first], 1] = cen[t[~first]]
    chord = ends[:, 1] - ends[:, 0]
    width = np.hypot(chord[:, 0], chord[:, 1])
    normal = np.stack([chord[:, 1], -chord[:, 0]], axis=1) / width[:, None]
    e = P[edges[:, 1]] - P[edges[:, 0]]
    normal *= np.sign(np.einsum("ij,ij->i", normal, e))[:, None]
    return width, normal
