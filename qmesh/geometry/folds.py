"""Triangles that fold or overlap: what a mesh file can hide and `qmesh report` must show.

In a valid triangulation every triangle turns the same way (counter-clockwise, area > 0) and
every interior edge is used once in each direction by its two triangles. A triangle is
counted as folded or overlapping when

- it is degenerate or turns the other way than most triangles (a fold);
- it repeats another triangle's three vertices (a duplicate, in either orientation);
- it turns the right way and uses an edge in the same direction as another such triangle, or
  an edge that two others use (two triangles on the same side of an edge overlap there).

These are local tests: two layers that share no edge are not seen.
"""

from __future__ import annotations

import numpy as np

from qmesh.geometry.topology import edge_keys


def folded_mask(points, triangles) -> np.ndarray:
    """(M,) bool: the triangles that fold or overlap (see the module's docstring)."""
    P = np.asarray(points, dtype=float)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    m = len(T)
    if m == 0:
        return np.zeros(0, bool)
    area = _doubled_areas(P, T)
    bad = (-area if _clockwise(area) else area) <= 0

    _, inverse, count = np.unique(np.sort(T, axis=1), axis=0, return_inverse=True, return_counts=True)
    bad |= count[inverse.ravel()] > 1

    n = np.int64(max(len(P), 1))
    good = np.flatnonzero(~bad)  # a turned triangle is counted itself, not its neighbours
    u, v = T[good].ravel(), T[good][:, [1, 2, 0]].ravel()
    owner = np.repeat(good, 3)
    directed = u * n + v
    _, inv, cnt = np.unique(directed, return_inverse=True, return_counts=True)
    undirected = edge_keys(u, v, n)
    _, inv2, cnt2 = np.unique(undirected, return_inverse=True, return_counts=True)
    overlap = (cnt[inv] > 1) | (cnt2[inv2] > 2)
    bad[owner[overlap]] = True
    return bad


def _doubled_areas(P, T) -> np.ndarray:
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def _clockwise(area: np.ndarray) -> bool:
    """Most triangles turn clockwise (a tie: the total area does)."""
    votes = int(np.sign(area).sum())
    return votes < 0 or (votes == 0 and area.sum() < 0)


def turns_clockwise(points, triangles) -> bool:
    """True when a mesh turns clockwise as a whole (its file's convention, not a fold): most of
    its triangles do."""
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    return bool(len(T)) and _clockwise(_doubled_areas(np.asarray(points, dtype=float), T))


def folded_triangles(mesh) -> int:
    """How many triangles of `mesh` fold or overlap (0 for a valid triangulation)."""
    return int(folded_mask(mesh.points, mesh.triangles).sum())
