"""How many vertices faces meshed at one metric edge length h add, on points shared with others.

MEDIA.md §3 ("plus what the interfaces need"). Euler's relation (sizing.py) counts a face from
its metric area and its boundary pieces. A face sharing an interface with a finer neighbour gets
that neighbour's points, more than its own h would put there, and the triangles between them and
its interior grade from their spacing s up to h: so each face is counted with the pieces its
interface edges will hold, and with the triangles of that grading (`graded_triangles`). Without
them the faces meshed last, sized by what remains, ended coarser than the rest.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from qmesh.mesher.sizing import equilateral_area

GRADING = 1.0   # metric size gained per unit of metric distance from a finer boundary (calibrated)


class SharedPoints(dict[int, np.ndarray]):
    """{partition edge: its interface points so far}, keeping each edge's piece count (points
    + 1) as an array, so a face's count reads them at once."""

    def __init__(self, points: dict, n_edges: int) -> None:
        super().__init__()
        self.pieces = np.ones(n_edges, np.int64)
        for e, X in points.items():
            self[e] = X

    def __setitem__(self, e: int, X: np.ndarray) -> None:
        super().__setitem__(e, X)
        self.pieces[e] = len(X) + 1


def graded_triangles(c: np.ndarray, own: np.ndarray, depth: np.ndarray, h: float) -> np.ndarray:
    """Triangles beyond area / (√3/4 h²) that a face needs beside a boundary segment of c pieces
    where its own h puts `own` (≤ c): the spacing s = h·own/c grows by GRADING per unit distance
    up to h, or up to `depth` into the face (its area over its perimeter: a thin face is graded
    all through); ∫ 4/(√3 x²) − 4/(√3 h²) over that layer."""
    s = h * (own / c)                # exactly h where the face puts its own pieces
    d = np.minimum((h - s) / GRADING, depth)
    return 4.0 / np.sqrt(3.0) * c * s * ((1.0 / s - 1.0 / (s + GRADING * d)) / GRADING - d / (h * h))


def face_counter(area: np.ndarray, at: np.ndarray, L: np.ndarray, w: np.ndarray, iface: np.ndarray,
                 L_side: np.ndarray, w_side: np.ndarray, known: np.ndarray | int, shared: np.ndarray,
                 factor: float, thin: bool) -> Callable[[float], float]:
    """count(h) of faces of metric `area`s: their segments' face `at`, metric length L and thin
    step w (pieces no longer than w on a thin face), the interface edge `iface` of each (-1:
    none), and of those interface edges both sides' lengths and steps, the pieces `known` on
    them so far and whether both sides are among the faces (`shared`); pieces at most factor·h.
    Euler per face, less one count of every interface point two of them share or that is there
    already. `thin`: the faces' least count, their boundary pieces ≲ w whatever h is, and each
    interface counted at its fewer side's pieces."""
    mine, depth = iface >= 0, area / np.maximum(np.bincount(at, L, minlength=len(area)), 1e-300)

    def count(h: float) -> float:
        step = np.minimum(factor * h, w) if thin else factor * h
        pieces = np.maximum(1, np.ceil(L / step))                  # per face segment, own h
        step = np.minimum(factor * h, w_side) if thin else factor * h
        both = np.maximum(1, np.ceil(L_side / step))
        tri = area / equilateral_area(h)
        if thin:
            nb = np.bincount(at, pieces, minlength=len(area))
            return float(0.5 * (np.maximum(tri, nb - 2) + nb + 2).sum()) - float(np.minimum(both[:, 0], both[:, 1]).sum())
        # the pieces each interface edge gets: its known ones, each split evenly at h if longer
        held = known * np.ceil(both.max(axis=1) / known)
        c = pieces.copy()
        c[mine] = held[iface[mine]]
        nb = np.bincount(at, c, minlength=len(area))
        if (c > pieces).any():
            tri = tri + np.bincount(at, graded_triangles(c, pieces, depth[at], factor * h), minlength=len(area))
        return float(0.5 * (tri + nb + 2).sum()) - float(np.where(shared, held, known).sum())

    return count
