"""Initial interior points of Algorithm 2.1 ("select initial interior points").

The chapter starts from about as many random interior points as boundary points and lets the
insertions grow the mesh. For a constant Q the optimal mesh is known in shape: equilateral in
the metric space x' = Lᵀx (LLᵀ = H), i.e. a hexagonal lattice there. Starting from that lattice
at the target density leaves the vertex step only the boundary layer to settle, and avoids the
lattice defects (vertices of degree 5 and 7) that a random start freezes in, which raise the
largest stiffness eigenvalue and so κ2. For a varying s there is no global lattice, and the
random start is used.
"""

from __future__ import annotations

import numpy as np

MARGIN = 0.3        # lattice points keep this many metric edge lengths from the boundary
JITTER = 1e-3       # random perturbation of lattice points, in metric edge lengths


def random_interior(domain, k, rng) -> np.ndarray:
    """k points uniformly distributed inside the convex polygon, kept off its boundary.

    Sampled in the fan of triangles (centroid, corner k, corner k+1), chosen by area; the
    barycentric weight of the boundary edge is capped at 1 − 1e-3 so no point touches it.
    """
    A = domain.points
    B = np.roll(A, -1, axis=0)
    c = A.mean(axis=0)
    area = 0.5 * np.abs((A - c)[:, 0] * (B - c)[:, 1] - (A - c)[:, 1] * (B - c)[:, 0])
    fan = rng.choice(len(A), size=k, p=area / area.sum())
    r1, r2 = rng.random(k), rng.random(k)
    s = np.sqrt(r1) * (1.0 - 1e-3)                 # distance from the centroid towards the edge
    return c + s[:, None] * ((1.0 - r2)[:, None] * (A[fan] - c) + r2[:, None] * (B[fan] - c))


def metric_lattice(domain, H, h, rng) -> np.ndarray:
    """Hexagonal lattice of metric spacing h, mapped back, at least MARGIN·h inside the polygon."""
    L = np.linalg.cholesky(H)                      # H = L Lᵀ; metric coordinates x' = Lᵀ x
    corners = domain.points @ L                    # rows: (Lᵀ x)ᵀ = xᵀ L
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    dy = h * np.sqrt(3.0) / 2.0
    ny, nx = int(np.ceil((hi[1] - lo[1]) / dy)) + 1, int(np.ceil((hi[0] - lo[0]) / h)) + 2
    j, i = np.divmod(np.arange(nx * ny), nx)
    X = np.column_stack([lo[0] + (i + 0.5 * (j % 2)) * h, lo[1] + j * dy])
    X += rng.uniform(-JITTER, JITTER, X.shape) * h
    return X[_inside_by(corners, X, MARGIN * h)] @ np.linalg.inv(L)


def _inside_by(corners, X, margin) -> np.ndarray:
    """Points of X at distance > margin inside the convex CCW polygon `corners`.

    Each point is tested against the edge its direction from the centroid crosses (found by
    binary search on the corners' angles), which decides inside or outside exactly, and that
    edge's two neighbours; where edges are shorter than the margin (a fine boundary) a point
    may keep less than the margin from a farther edge, which the vertex step then settles.
    O(len(X) log n) instead of O(len(X) n).
    """
    c = corners.mean(axis=0)
    ang = np.arctan2(corners[:, 1] - c[1], corners[:, 0] - c[0])
    start = np.argmin(ang)
    corners = np.roll(corners, -start, axis=0)
    ang = np.roll(ang, -start)
    n = len(corners)
    k = (np.searchsorted(ang, np.arctan2(X[:, 1] - c[1], X[:, 0] - c[0]), side="right") - 1) % n
    E = np.roll(corners, -1, axis=0) - corners
    nrm = np.column_stack([-E[:, 1], E[:, 0]]) / np.hypot(E[:, 0], E[:, 1])[:, None]
    ok = np.ones(len(X), bool)
    for shift in (-1, 0, 1):
        e = (k + shift) % n
        ok &= np.einsum("ij,ij->i", X - corners[e], nrm[e]) > margin
    return ok


def lattice_for_count(domain, H, n, rng) -> np.ndarray:
    """A metric lattice with at most, and about, n points.

    The spacing first comes from the metric area less the boundary band the margin leaves
    empty, then from one count; a last step widens it by 1% while there are too many points.
    """
    if n < 1:
        return np.empty((0, 2))
    corners = domain.points @ np.linalg.cholesky(H)
    E = np.roll(corners, -1, axis=0) - corners
    area_m = domain.area * np.sqrt(np.linalg.det(H))
    perimeter_m = np.hypot(E[:, 0], E[:, 1]).sum()
    cell = np.sqrt(3.0) / 2.0                      # lattice area per point is cell·h²
    # area_m − perimeter_m·MARGIN·h = n·cell·h², solved for h > 0
    b = perimeter_m * MARGIN
    h = (-b + np.sqrt(b * b + 4.0 * cell * max(n, 1) * area_m)) / (2.0 * cell * max(n, 1))
    X = metric_lattice(domain, H, h, rng)
    if len(X):
        h *= np.sqrt(len(X) / n)
        X = metric_lattice(domain, H, h, rng)
    while len(X) > n:                              # never more than asked: insertion tops up
        h *= 1.01
        X = metric_lattice(domain, H, h, rng)
    return X
