"""The domain Ω: a convex polygon whose corners are the fixed seed boundary points.

The chapter's test domain is the regular VB-gon inscribed in the unit circle (Section 2.3.3).
Other boundary vertices the mesher adds lie on the polygon's edges and slide along them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import QmeshError


def _turning(E: np.ndarray) -> tuple[np.ndarray, float]:
    """Cross products of consecutive edges and the total turning angle (2π for a convex CCW loop)."""
    En = np.roll(E, -1, axis=0)
    cross = E[:, 0] * En[:, 1] - E[:, 1] * En[:, 0]
    dot = np.einsum("ij,ij->i", E, En)
    return cross, float(np.arctan2(cross, dot).sum())


@dataclass(frozen=True)
class Polygon:
    """A convex polygon given by its corners in counter-clockwise order.

    The corners are the seed boundary points: they are mesh vertices that never move.
    """

    points: np.ndarray = field(repr=False)

    def __post_init__(self):
        P = np.asarray(self.points, dtype=float)
        if P.ndim != 2 or P.shape[1] != 2:
            raise QmeshError(f"polygon points must have shape (n, 2), got {P.shape}")
        if len(P) < 3:
            raise QmeshError(f"a polygon needs at least 3 points, got {len(P)}")
        if not np.all(np.isfinite(P)):
            raise QmeshError("polygon points must be finite")
        E = np.roll(P, -1, axis=0) - P
        if np.any(np.hypot(E[:, 0], E[:, 1]) <= 1e-12 * np.abs(P).max()):
            raise QmeshError("polygon has repeated consecutive points")
        cross, turning = _turning(E)
        scale = np.abs(E).max() ** 2
        if np.all(cross < 0) and abs(turning + 2 * np.pi) < 1e-6:
            raise QmeshError("polygon points must be in counter-clockwise order")
        if np.any(cross <= 1e-12 * scale):
            raise QmeshError("polygon is not strictly convex; non-convex domains are not supported yet")
        if abs(turning - 2 * np.pi) > 1e-6:
            raise QmeshError("polygon is self-intersecting (it winds more than once); "
                             "only simple convex polygons are supported yet")
        P = P.copy()
        P.setflags(write=False)
        object.__setattr__(self, "points", P)

    @property
    def seeds(self) -> np.ndarray:
        """The fixed seed boundary points (the corners)."""
        return self.points

    @property
    def edges(self) -> tuple[np.ndarray, np.ndarray]:
        """Edge start points and unit tangents, edge k from corner k to corner k+1."""
        A = self.points
        E = np.roll(A, -1, axis=0) - A
        return A, E / np.hypot(E[:, 0], E[:, 1])[:, None]

    @property
    def area(self) -> float:
        x, y = self.points.T
        return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))

    def contains(self, P: np.ndarray, tol: float = 1e-9) -> np.ndarray:
        """Boolean mask of points inside or on the polygon (within tol times its diameter)."""
        A, T = self.edges
        P = np.asarray(P, dtype=float)
        # signed distance to the left of every edge (inward for CCW)
        d = (T[None, :, 0] * (P[:, None, 1] - A[None, :, 1])
             - T[None, :, 1] * (P[:, None, 0] - A[None, :, 0]))
        diam = np.ptp(self.points, axis=0).max()
        return np.all(d >= -tol * diam, axis=1)

    def edge_of(self, P: np.ndarray, tol: float = 1e-9) -> np.ndarray:
        """Index of the polygon edge each point lies on, or -1 (corners report their outgoing edge)."""
        A, T = self.edges
        P = np.asarray(P, dtype=float)
        rel = P[:, None, :] - A[None, :, :]
        d = T[None, :, 0] * rel[..., 1] - T[None, :, 1] * rel[..., 0]
        t = np.einsum("nkj,kj->nk", rel, T)
        L = np.hypot(*(np.roll(A, -1, axis=0) - A).T)
        diam = np.ptp(self.points, axis=0).max()
        on = (np.abs(d) <= tol * diam) & (t >= -tol * diam) & (t <= L[None, :] + tol * diam)
        # a corner lies on two edges: report the one it starts (the smaller distance along it)
        return np.where(on.any(axis=1), np.where(on, t, np.inf).argmin(axis=1), -1)


def Disk(vb: int, radius: float = 1.0, center=(0.0, 0.0)) -> Polygon:
    """The regular `vb`-gon inscribed in the circle: the chapter's unit-disk domain (Section 2.3.3)."""
    if isinstance(vb, bool) or not isinstance(vb, (int, np.integer)):
        raise QmeshError(f"VB must be an integer, got {vb!r}")
    if vb < 3:
        raise QmeshError(f"VB must be at least 3, got {vb}")
    if vb > 10_000_000:
        raise QmeshError(f"VB = {vb} is too large")
    if not (np.isfinite(radius) and radius > 0):
        raise QmeshError(f"radius must be finite and > 0, got {radius}")
    c = np.asarray(center, dtype=float)
    if c.shape != (2,) or not np.all(np.isfinite(c)):
        raise QmeshError(f"center must be two finite numbers, got {center!r}")
    t = 2 * np.pi * np.arange(vb) / vb
    return Polygon(c + radius * np.column_stack([np.cos(t), np.sin(t)]))
