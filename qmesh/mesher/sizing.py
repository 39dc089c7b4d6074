"""How big the mesh should be: metric area and boundary length of Ω, and the size h ↔ N relation.

Lengths and areas are measured in the metric H = ∇²s (MATH.md "Quality"): a mesh of metric
edge length h has triangles of metric area ≈ √3/4 h², and Euler's relation M = 2N − N_b − 2
links the triangle count M to the N vertices of which N_b lie on the boundary.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.errors import QmeshError
from qmesh.geometry.portable import cholesky2, det2, gauss_legendre, times2
from qmesh.geometry.rings import convex_width
from qmesh.mesher import budget
from qmesh.mesher.conform import conforming_delaunay

# Gauss–Legendre points on [0, 1] for the metric length of each boundary edge
_GL_X, _GL_W = gauss_legendre(8)
_GL_X, _GL_W = 0.5 * (_GL_X + 1.0), 0.5 * _GL_W

MAX_VERTICES = 50_000_000   # an absolute cap, far above what budget.py lets any machine here run


def metric_area(domain, anisotropy) -> float:
    """∫_Ω √det ∇²s: exact for constant Q; otherwise a midpoint rule on 64 sub-triangles of
    every triangle of a triangulation of Ω (holes and notches excluded)."""
    if anisotropy.is_constant:
        return domain.area * float(np.sqrt(det2(anisotropy.H)))
    P, T = domain_triangulation(domain)
    m = 8
    i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    keep = i + j < m
    up = np.column_stack([(i[keep] + 1 / 3) / m, (j[keep] + 1 / 3) / m])
    low = i + j < m - 1
    dn = np.column_stack([(i[low] + 2 / 3) / m, (j[low] + 2 / 3) / m])
    bary = np.concatenate([up, dn])                       # centroids of the m² sub-triangles
    A, B, C = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    X = A[:, None] + bary[None, :, 0:1] * (B - A)[:, None] + bary[None, :, 1:2] * (C - A)[:, None]
    Hs = np.asarray(anisotropy.hessian(X.reshape(-1, 2)), dtype=float)
    dets = np.clip(Hs[:, 0, 0] * Hs[:, 1, 1] - Hs[:, 0, 1] * Hs[:, 1, 0], 0.0, None)
    area = 0.5 * np.abs((B - A)[:, 0] * (C - A)[:, 1] - (B - A)[:, 1] * (C - A)[:, 0])
    return float((np.sqrt(dets).reshape(len(T), -1).mean(axis=1) * area).sum())


def domain_triangulation(domain) -> tuple[np.ndarray, np.ndarray]:
    """A triangulation (P, T) of Ω itself (Euclidean conforming Delaunay of its boundary),
    kept on the domain: sizing and random seeding integrate and sample over it."""
    cached = domain.__dict__.get("_triangulation")
    if cached is None:
        seeds = np.asarray(domain.seeds)
        c = conforming_delaunay(domain, seeds, np.full(len(seeds), -1, np.int64),
                                Anisotropy.constant(np.eye(2)), h=np.inf)
        cached = (c.P, c.T)
        domain.__dict__["_triangulation"] = cached
    return cached


def metric_edge_lengths(domain, anisotropy, scale: float = 1.0) -> np.ndarray:
    """Metric length ∫ √(τᵀHτ) of each boundary segment, H = ∇²s / scale."""
    return segment_lengths(*domain.segment_ends, anisotropy, scale)


def segment_lengths(A: np.ndarray, B: np.ndarray, anisotropy, scale: float = 1.0) -> np.ndarray:
    """Metric length of the segments A→B in H = ∇²s / scale (exact for a constant Q, 8-point
    Gauss–Legendre for a varying s). A region of a medium passes its own scale k_r, so every
    region is sized in its metric with its magnitude divided out (MEDIA.md §3)."""
    return stacked_segment_lengths(A[None], B[None], anisotropy, scale)[0]


def stacked_segment_lengths(A: np.ndarray, B: np.ndarray, anisotropy, scale: float = 1.0) -> np.ndarray:
    """`segment_lengths` of F polylines of n segments each, A and B (F, n, 2), in one pass: the
    same operations row by row and a product per polyline, so each has the bits of its own call
    (a thousand faces of a medium measured at once)."""
    F, n = A.shape[:2]
    E = (B - A).reshape(-1, 2)
    X = A.reshape(-1, 2)[:, None, :] + _GL_X[None, :, None] * E[:, None, :]
    Hs = (np.broadcast_to(anisotropy.H, (X.shape[0] * X.shape[1], 2, 2)) if anisotropy.is_constant
          else np.asarray(anisotropy.hessian(X.reshape(-1, 2)), dtype=float))
    Ek = np.repeat(E, len(_GL_X), axis=0)
    dens = np.sqrt(np.einsum("ni,nij,nj->n", Ek, Hs, Ek) / scale).reshape(F, n, -1)
    return (dens * _GL_W).sum(axis=-1)


def equilateral_area(h: float) -> float:
    """Metric area of an equilateral triangle of metric edge h: (√3/4)·h²."""
    return np.sqrt(3.0) / 4.0 * h * h


def size_of_area(area: float) -> float:
    """The edge of the equilateral triangle of this metric area (the inverse of the above)."""
    return np.sqrt(area / equilateral_area(1.0))


def boundary_vertices(edge_lengths: np.ndarray, h: float, boundary_factor: float | None) -> int:
    """Boundary vertex count when every edge longer than boundary_factor·h is split evenly."""
    if boundary_factor is None:
        return len(edge_lengths)
    return int(np.maximum(1, np.ceil(edge_lengths / (boundary_factor * h))).sum())


def vertices_for_size(area_m: float, edge_lengths: np.ndarray, h: float,
                      boundary_factor: float | None) -> float:
    """Expected N for metric edge length h: M·(√3/4)h² = area, M = 2N − N_b − 2."""
    return vertices_from_counts(area_m, h, boundary_vertices(edge_lengths, h, boundary_factor))


def vertices_from_counts(area_m: float, h: float, n_boundary: float) -> float:
    """Euler's relation for a triangulation of N vertices, N_b on the boundary: M = 2N − N_b − 2
    triangles of metric area (√3/4)h² fill the metric area, so N = (M + N_b + 2)/2."""
    return 0.5 * (area_m / equilateral_area(h) + n_boundary + 2)


def size_for_vertices(area_m: float, edge_lengths: np.ndarray, n: int,
                      boundary_factor: float | None) -> float:
    """The metric edge length h whose expected vertex count is n (bisection in log h)."""
    return size_for_count(lambda h: vertices_for_size(area_m, edge_lengths, h, boundary_factor),
                          n, area_m, float(edge_lengths.sum()))


def size_for_count(count, n: float, area_m: float, length_m: float, steps: int = 200) -> float:
    """The h at which the decreasing function count(h) crosses n: bisection in log h between
    sizes far below and far above any mesh of metric area area_m and boundary length length_m."""
    lo, hi = 1e-9 * np.sqrt(area_m), 10.0 * (np.sqrt(area_m) + length_m)
    for _ in range(steps):
        mid = np.sqrt(lo * hi)
        if count(mid) > n:
            lo = mid
        else:
            hi = mid
    return float(np.sqrt(lo * hi))


def check_vertex_count(n: float, what: str) -> None:
    """Refuse a mesh that would need absurd memory, before any work is done."""
    if not np.isfinite(n) or n > MAX_VERTICES:
        need = budget.estimate_bytes(min(n, 1e300), varying=False) / 2**30
        raise QmeshError(f"{what} asks for about {n:.3g} vertices (~{need:.3g} GiB of "
                         f"memory at least); the limit is {MAX_VERTICES:.0e}")


def metric_area_scaled(domain, anisotropy, k: float) -> float:
    """∫_Ω √det(∇²s / k): with k divided out before the determinant for a constant Q, so a
    conductivity of 1e300 (whose determinant overflows) is sized like any other (a region of a
    medium passes its own scale k_r)."""
    if anisotropy.is_constant:
        H = anisotropy.H / k
        return domain.area * float(np.sqrt(H[0, 0] * H[1, 1] - H[0, 1] * H[1, 0]))
    area = metric_area(domain, anisotropy) / k
    if not np.isfinite(area):
        raise QmeshError(f"the metric area of a region with k = {k:.3g} overflows; divide every "
                         "region's conductivity by a common factor (the mesh depends on their "
                         "shapes and ratios)")
    return area


def hull_metric_width(X: np.ndarray, anisotropy, k: float) -> float:
    """The width of the convex hull of the points X in the metric ∇²s / k (taken at their centre
    for a varying s): an upper bound of the width of a polygon with those corners."""
    c = X.mean(axis=0)
    H = (anisotropy.H if anisotropy.is_constant
         else np.asarray(anisotropy.hessian(c[None]), float)[0]) / k
    try:
        L = cholesky2(np.asarray(H, float))                  # |x|_H = |x L| with H = L Lᵀ
        if not np.isfinite(L).all():
            return np.inf
        Y = times2(X - c, L)
        hull = ConvexHull(Y)
    except (QhullError, ValueError):
        return np.inf
    return float(convex_width(Y[hull.vertices]))
