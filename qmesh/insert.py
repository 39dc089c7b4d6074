"""Point insertion near badly shaped or oversized triangles (chapter Section 2.3.2, (2.94)).

Size and shape are measured in metric space (the triangle mapped by H^{1/2} at its centroid).
A triangle is refined when its metric area exceeds the area threshold (set by the mesher from
the target size or vertex count), or when its quality (2.94) is below the threshold — never when its
metric area is below `min_area` ("Triangles smaller than a preset minimum area are not refined").
Where the point goes is not critical, since the next adjustment moves it (the chapter): interior
triangles are split at their centroid (the metric centroid too, the map being affine); when a
triangle's longest metric edge lies on the domain boundary, that edge is split at its midpoint
instead, which is how vertices appear on the boundary between the seed points. Boundary edges
longer than `boundary_length` (metric) are split as well, so the boundary keeps pace with the
interior.

Neighbouring triangles are not both refined in one round unless they are grossly oversized; the
highest-priority (largest area / quality) candidates win, up to the vertex budget.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import topology
from .geometry import metric_areas, metric_edge_lengths2, metric_hessians, metric_quality

GROSS = 4.0             # above this multiple of the threshold, neighbours may be refined together


@dataclass
class Insertion:
    """What one insertion stage did: the new points, their boundary edge (-1 interior)."""

    T: np.ndarray
    twin: np.ndarray
    points: np.ndarray      # (k, 2) new points, appended after the existing ones
    edge_id: np.ndarray     # (k,) polygon edge of new boundary points, -1 for interior ones


def target_area(h: float) -> float:
    """Metric area of an equilateral triangle of edge h."""
    return np.sqrt(3.0) / 4.0 * h * h


def insert(P, T, twin, anisotropy, *, area_threshold, boundary_length, corner_edge,
           quality_threshold, min_area, budget, refine_boundary=True) -> Insertion:
    """Choose where to add points and split the triangles there.

    `corner_edge[i]` is the polygon edge a boundary vertex i starts (its own edge for sliding
    vertices, the outgoing edge for a seed corner); it names the edge of points split in after i.
    """
    n = len(P)
    none = Insertion(T, twin, np.empty((0, 2)), np.empty(0, np.int64))
    if budget <= 0:
        return none
    Hm = metric_hessians(anisotropy, P, T)
    area = metric_areas(P, T, Hm)
    quality = metric_quality(P, T, Hm)
    L2 = metric_edge_lengths2(P, T, Hm)                        # edge opposite each corner
    At = area_threshold
    cand = (area > At) | ((quality < quality_threshold) & (area > min_area))
    priority = area / At / np.maximum(quality, 1e-3)

    # the longest metric edge of each triangle, as a half-edge (edge opposite corner c is c+1→c+2)
    c = np.argmax(L2, axis=1)
    longest = 3 * np.arange(len(T)) + topology.NXT[c]
    on_boundary = twin[longest] < 0
    # boundary half-edges long in metric space are refined whatever their triangle
    he_len2 = L2[:, topology.PRV].ravel()                      # half-edge 3t+e is opposite corner e+2
    long_bnd = np.zeros(len(T), bool)
    if refine_boundary:
        bnd = twin < 0
        too_long = bnd & (he_len2 > boundary_length ** 2)
        long_bnd[np.flatnonzero(too_long) // 3] = True
    else:
        on_boundary[:] = False

    want = cand | long_bnd
    prio = np.where(long_bnd, np.maximum(priority, 2.0), priority)
    chosen = want & (_local_max(T, twin, np.where(want, prio, -np.inf)) | (area > GROSS * At) | long_bnd)
    idx = np.flatnonzero(chosen)
    idx = idx[np.argsort(-prio[idx], kind="stable")][:budget]

    # boundary splits: the triangle's longest edge if it is a boundary edge, else its longest
    # boundary edge when that one is too long
    tri_he = (3 * idx[:, None] + np.arange(3))
    bnd_len = np.where(twin[tri_he] < 0, he_len2[tri_he], -1.0)
    longest_bnd = tri_he[np.arange(len(idx)), np.argmax(bnd_len, axis=1)]
    split_bnd = on_boundary[idx] | long_bnd[idx]
    he = np.where(on_boundary[idx], longest[idx], longest_bnd)[split_bnd]
    tri = idx[~split_bnd]

    u = T[he // 3, he % 3]
    v = T[he // 3, topology.NXT[he % 3]]
    new_b = 0.5 * (P[u] + P[v])
    T, twin = topology.split_boundary_edges(T, twin, he, n + np.arange(len(he)))
    new_i = P[T[tri]].mean(axis=1)
    T, twin = topology.split_triangles(T, twin, tri, n + len(he) + np.arange(len(tri)))
    return Insertion(T, twin, np.concatenate([new_b, new_i]),
                     np.concatenate([corner_edge[u], np.full(len(tri), -1)]))


def _local_max(T, twin, prio):
    """Triangles whose priority is at least that of each edge-neighbour."""
    nb = np.where(twin >= 0, twin // 3, -1).reshape(-1, 3)
    other = np.where(nb >= 0, prio[np.maximum(nb, 0)], -np.inf)
    return np.all(prio[:, None] >= other, axis=1) & np.isfinite(prio)
