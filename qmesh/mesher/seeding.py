"""Initial points of Algorithm 2.1 ("read the boundary points; select initial interior points").

The chapter starts from about as many random interior points as boundary points and lets the
insertions grow the mesh. For a constant Q the optimal mesh is known in shape: equilateral in
the metric space x' = Lᵀx (LLᵀ = H), i.e. a hexagonal lattice there. Starting from that lattice
at the target density leaves the vertex step only the boundary layer to settle, and avoids the
lattice defects (vertices of degree 5 and 7) that a random start freezes in, which raise the
largest stiffness eigenvalue and so κ2. For a varying s there is no global lattice, and the
random start is used.

The lattice is laid out row by row along the domain's longest metric direction and only inside
Ω (scanlines against the boundary segments), so its cost follows the number of points made,
however thin or rotated Ω is in the metric.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from qmesh.geometry import rings
from qmesh.geometry.portable import cholesky2, det2, eigh2, inv2, matmul2, moments2, times2
from qmesh.geometry.triangles import rounded
from qmesh.mesher.sizing import domain_triangulation, metric_edge_lengths

MARGIN = 0.3        # lattice points keep this many metric edge lengths from the boundary
JITTER = 1e-3       # random perturbation of lattice points, in metric edge lengths
ELONGATED = 4.0     # rows follow Ω's long axis only when its inertia is this many times the other


def boundary_points(domain, anisotropy, h: float, factor: float | None):
    """Points splitting every segment into pieces of metric length at most factor·h (none when
    factor is None): arrays (points (k, 2), segment of each (k,))."""
    if factor is None:
        return np.empty((0, 2)), np.empty(0, np.int64)
    pieces = np.maximum(1, np.ceil(metric_edge_lengths(domain, anisotropy) / (factor * h))).astype(np.int64)
    seg = np.repeat(np.arange(len(pieces)), pieces - 1)
    k = np.arange(len(seg)) - np.repeat(np.cumsum(pieces - 1) - (pieces - 1), pieces - 1) + 1
    A, B = domain.segment_ends
    t = (k / pieces[seg])[:, None]
    return A[seg] + t * (B[seg] - A[seg]), seg


def random_interior(domain, k, rng) -> np.ndarray:
    """k points uniformly distributed inside Ω, kept off its boundary.

    Sampled in the triangles of a triangulation of Ω, chosen by area; the barycentric
    coordinates are pulled 1e-3 towards the triangle's centroid so no point touches an edge.
    """
    P, T = domain_triangulation(domain)
    A, B, C = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    area = 0.5 * np.abs((B - A)[:, 0] * (C - A)[:, 1] - (B - A)[:, 1] * (C - A)[:, 0])
    tri = rng.choice(len(T), size=k, p=area / area.sum())
    r1, r2 = rng.random(k), rng.random(k)
    s = np.sqrt(r1)
    w = np.column_stack([1.0 - s, s * (1.0 - r2), s * r2])
    w = (1.0 - 1e-3) * w + 1e-3 / 3.0
    return w[:, 0:1] * A[tri] + w[:, 1:2] * B[tri] + w[:, 2:3] * C[tri]


def _metric_frame(domain, H):
    """The map x ↦ x L R to metric coordinates whose x axis is Ω's longest direction."""
    L = cholesky2(H)                               # H = L Lᵀ; metric coordinates x' = Lᵀ x
    X = times2(domain.seeds, L)
    A, B = domain.segment_ends
    w = np.hypot(*times2(B - A, L).T)              # weight corners by their segments' length
    c = (X * w[:, None]).sum(axis=0) / w.sum()
    val, vec = eigh2(moments2(X - c, w))
    if val[1] < ELONGATED * val[0]:
        return L                                   # not elongated: keep the metric's own axes
    R = vec[:, ::-1]                               # columns: longest direction first
    R *= np.where(np.abs(R[0]) >= np.abs(R[1]), np.sign(R[0]), np.sign(R[1]))   # a fixed sign
    if det2(R) < 0:
        R[:, 1] *= -1
    return matmul2(L, R)


@dataclass(frozen=True)
class Lattice:
    """Lattice points and where they sit on the lattice: `points` (n, 2) in the domain's
    coordinates; `u`, `row` (n,) their places (point k is at x = lo[0] + u[k]·h/2,
    y = lo[1] + (row[k] + ½)·dy in the metric frame x ↦ x·frame, before the jitter; u and row
    have the same parity), so that its triangles are known in closed form (lattice_delaunay.py)."""

    points: np.ndarray
    u: np.ndarray
    row: np.ndarray
    frame: np.ndarray       # (2, 2): metric frame coordinates are x @ frame
    lo: np.ndarray          # (2,) origin of the lattice in the frame
    h: float                # metric spacing

    def __len__(self) -> int:
        return len(self.points)


def metric_lattice(domain, H, h, rng) -> Lattice:
    """Hexagonal lattice of metric spacing h, mapped back, at least MARGIN·h inside Ω."""
    M = _metric_frame(domain, H)
    A, B = domain.segment_ends
    Am, Bm = times2(A, M), times2(B, M)
    lo = np.minimum(Am.min(axis=0), Bm.min(axis=0))
    hi = np.maximum(Am.max(axis=0), Bm.max(axis=0))
    dy = h * np.sqrt(3.0) / 2.0
    n_rows = int(np.ceil(rounded((hi[1] - lo[1]) / dy))) + 1
    if n_rows > 10 * 50_000_000:
        return _empty(M, lo, h)
    y = lo[1] + (np.arange(n_rows) + 0.5) * dy
    row, x0, x1 = rings.scanline_intervals(y, Am, Bm)
    off = lo[0] + 0.5 * h * (row % 2)
    i0 = np.ceil(rounded((x0 - off) / h)).astype(np.int64)       # rounded: same points anywhere
    count = np.maximum(np.floor(rounded((x1 - off) / h)).astype(np.int64) - i0 + 1, 0)
    r = np.repeat(row, count)
    i = np.repeat(i0, count) + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    X = np.column_stack([lo[0] + (i + 0.5 * (r % 2)) * h, y[r]])
    X += rng.uniform(-JITTER, JITTER, X.shape) * h
    keep = ~np.isfinite(rings.distance(X, Am, Bm, rounded(MARGIN * h)))
    return Lattice(times2(X[keep], inv2(M)), (2 * i + r % 2)[keep], r[keep].astype(np.int64), M, lo, h)


def _empty(M, lo, h) -> Lattice:
    return Lattice(np.empty((0, 2)), np.empty(0, np.int64), np.empty(0, np.int64), M, lo, h)


def lattice_for_count(domain, H, n, rng) -> Lattice:
    """A metric lattice with at most, and about, n points.

    The spacing first comes from the metric area less the boundary band the margin leaves
    empty, then from one count; a last step widens it by 1% while there are too many points.
    """
    if n < 1:
        return _empty(np.eye(2), np.zeros(2), 1.0)
    A, B = domain.segment_ends
    L = cholesky2(H)
    E = times2(B - A, L)
    area_m = domain.area * np.sqrt(det2(H))
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
