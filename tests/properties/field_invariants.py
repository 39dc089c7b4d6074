"""The invariants of a field's or a medium's mesh, and a corner's angle in the metric.

`q_defects`: every q_ij ≥ 0 with one conductivity per triangle (the mesh's own element means,
`Mesh.conductivity`, or each region's constant Q): interior edges by their sum, an interface
edge (two regions) by each side's share on its own — what the guide promises (MEDIA.md §2) —
and boundary edges; below zero by more than 1e-9 of the largest share of the triangles beside
the edge (round-off). Per triangle, the share of the edge opposite corner k is
q^T = ½ √det Q̄_T cot θ_k = uᵀ adj(Q̄_T) v / (2 u × v), u, v the edges from corner k.

`corner_angles`: the angles, in the metric adj Q of the region on each side, of the sectors
the domain's and its regions' edges make at a point; the smallest is what a corner refusal is
judged by (a refusal of a corner of 0.1° or more is a defect).
"""

from __future__ import annotations

import math

import numpy as np

EPS = np.finfo(float).eps
REL = 1e-9
CORNER_FLOOR = 0.1
"""Degrees in the metric: a corner this wide or wider must mesh, not be refused as too sharp."""


def _adj(Q: np.ndarray) -> np.ndarray:
    H = np.empty_like(Q)
    H[:, 0, 0], H[:, 1, 1] = Q[:, 1, 1], Q[:, 0, 0]
    H[:, 0, 1], H[:, 1, 0] = -Q[:, 0, 1], -Q[:, 1, 0]
    return H


def shares(P: np.ndarray, T: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """q^T of the edge opposite each corner of each triangle, (M, 3)."""
    H = _adj(np.asarray(Q, dtype=float))
    X = P[T]
    out = np.empty(T.shape)
    for c in range(3):
        u, v = X[:, (c + 1) % 3] - X[:, c], X[:, (c + 2) % 3] - X[:, c]
        out[:, c] = np.einsum("mi,mij,mj->m", u, H, v) / (2 * (u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]))
    return out


def q_defects(P: np.ndarray, T: np.ndarray, Q: np.ndarray, regions: np.ndarray | None = None) -> list[str]:
    """Edges with q_ij < 0 beyond round-off, by kind (interior, interface, boundary)."""
    P = np.asarray(P, dtype=float)
    extent = float(np.abs(P).max())
    P = P - P.min(axis=0)
    T = np.asarray(T, dtype=np.int64)
    q = shares(P, T, Q)
    n = len(P)
    # edge (c+1, c+2) of each triangle is opposite corner c
    ends = np.sort(np.concatenate([T[:, [1, 2]], T[:, [2, 0]], T[:, [0, 1]]]), axis=1)
    key = ends[:, 0] * n + ends[:, 1]
    share = np.concatenate([q[:, 0], q[:, 1], q[:, 2]])
    tri = np.tile(np.arange(len(T)), 3)
    _, inverse, count = np.unique(key, return_inverse=True, return_counts=True)
    total = np.bincount(inverse, weights=share, minlength=len(count))
    size = np.bincount(inverse, weights=np.abs(share), minlength=len(count))
    E = P[T[:, [1, 2, 0]]] - P[T]
    h_min = float(np.hypot(E[..., 0], E[..., 1]).min())
    rounding = 64 * EPS * extent / max(h_min, 1e-300)   # the output's own round-off, eps·|x|/h
    # round-off is relative to each triangle's largest share: a share that is 0 in exact
    # arithmetic (a right angle in the metric) comes out as ±eps times the others
    tri_scale = np.abs(q).max(axis=1)[tri]
    tol = (REL + rounding) * np.maximum(np.bincount(inverse, weights=tri_scale, minlength=len(count)), 1e-300)
    reg = np.zeros(len(T), np.int64) if regions is None else np.asarray(regions)
    r = reg[tri]
    lo = np.full(len(count), np.iinfo(np.int64).max)
    hi = np.full(len(count), np.iinfo(np.int64).min)
    np.minimum.at(lo, inverse, r)
    np.maximum.at(hi, inverse, r)
    interface = (count == 2) & (lo != hi)
    bad_share = np.zeros(len(count), bool)
    np.logical_or.at(bad_share, inverse, share < -(REL + rounding) * np.maximum(tri_scale, 1e-300))
    kinds = {"interior": (count == 2) & ~interface, "interface": interface, "boundary": count == 1}
    failing = {"interior": kinds["interior"] & (total < -tol), "interface": interface & bad_share,
               "boundary": kinds["boundary"] & (total < -tol)}
    out = []
    for kind, mask in failing.items():
        if not mask.any():
            continue
        if kind == "interface":
            worst_share = np.full(len(count), np.inf)
            np.minimum.at(worst_share, inverse, share / size[inverse])
            worst = float(worst_share[mask].min())
        else:
            worst = float((total[mask] / size[mask]).min())
        out.append(f"q_ij-{kind}: {int(mask.sum())} of {int(kinds[kind].sum())} {kind} edges have "
                   f"q_ij < 0 with the mesh's means (worst q_ij / Σ|q_ij^T| = {worst:.3g})")
    return out


def triangle_conductivity(mesh, Q_of: dict) -> np.ndarray:
    """The mesh's own element means, or (a medium of constant regions) each region's Q."""
    if mesh.conductivity is not None:
        return np.asarray(mesh.conductivity, dtype=float)
    P, T = np.asarray(mesh.points, dtype=float), np.asarray(mesh.triangles)
    tags = np.asarray(mesh.region_tags)
    Q = np.empty((len(T), 2, 2))
    centroids = P[T].mean(axis=1)
    for tag in np.unique(tags).tolist():
        at = tags == tag
        Q[at] = (Q_of[tag] if tag in Q_of else Q_of[0])(centroids[at])    # {0: Q}: in every region
    return Q


# --------------------------------------------------------------------------- corners

def _point_in_ring(X: np.ndarray, R: np.ndarray) -> np.ndarray:
    A, B = R, np.roll(R, -1, axis=0)
    y0, y1 = A[None, :, 1], B[None, :, 1]
    crosses = (y0 > X[:, None, 1]) != (y1 > X[:, None, 1])
    with np.errstate(all="ignore"):                  # a horizontal edge: no crossing
        xc = A[None, :, 0] + (X[:, None, 1] - y0) * (B[None, :, 0] - A[None, :, 0]) / (y1 - y0)
    return (np.sum(crosses & (X[:, None, 0] < xc), axis=1) % 2) == 1


def corner_angles(p, rings, regions, Q_of: dict) -> list[tuple[float, int]]:
    """(metric angle in degrees, region) of each sector of Ω at the point p between the edges
    of the outline, holes and regions that start, end or pass at p."""
    p = np.asarray(p, dtype=float)
    rings = [np.asarray(R, dtype=float) for R in rings]
    regions = [np.asarray(R, dtype=float) for R in regions]
    every = rings + regions
    scale = max(float(np.ptp(np.concatenate(rings), axis=0).max()), 1e-300)
    tol = 1e-9 * scale + 64 * EPS * float(np.abs(p).max())
    dirs = []
    for R in every:
        A, B = R, np.roll(R, -1, axis=0)
        for a, b in zip(A, B):
            if np.hypot(*(a - p)) <= tol:
                dirs.append(b - a)
            elif np.hypot(*(b - p)) <= tol:
                dirs.append(a - b)
            else:
                ab = b - a
                t = float(np.dot(p - a, ab) / np.dot(ab, ab))
                if 0 < t < 1 and np.hypot(*(a + t * ab - p)) <= tol:
                    dirs += [ab, -ab]
    if len(dirs) < 2:
        return []
    D = np.array(dirs) / np.hypot(*np.array(dirs).T)[:, None]
    theta = np.unique(np.round(np.arctan2(D[:, 1], D[:, 0]), 12))
    out = []
    for k in range(len(theta)):
        t0, t1 = theta[k], theta[(k + 1) % len(theta)] + (2 * np.pi if k + 1 == len(theta) else 0)
        mid = 0.5 * (t0 + t1)
        X = p + 1e-6 * scale * np.array([[math.cos(mid), math.sin(mid)]])
        if not _point_in_ring(X, rings[0])[0] or any(_point_in_ring(X, h)[0] for h in rings[1:]):
            continue
        region = next((j + 1 for j, R in enumerate(regions) if _point_in_ring(X, R)[0]), 0)
        at = Q_of[region] if region in Q_of else Q_of[0]      # {0: Q}: one Q in every region
        H = _adj(np.asarray(at(p[None]), dtype=float))[0]
        u, v = np.array([math.cos(t0), math.sin(t0)]), np.array([math.cos(t1), math.sin(t1)])
        cross = math.sqrt(max(H[0, 0] * H[1, 1] - H[0, 1] * H[1, 0], 0.0)) * (u[0] * v[1] - u[1] * v[0])
        angle = math.degrees(math.atan2(cross, float(u @ H @ v))) % 360.0
        out.append((angle, region))
    return out


def refused_corner(message: str) -> tuple[float, float, float] | None:
    """(x, y, the angle qmesh states) of a corner refusal's message, else None."""
    import re

    m = re.search(r"corner at \(([^,]+), ([^)]+)\) is ([0-9.e+-]+)° in the metric", message)
    return None if m is None else (float(m.group(1)), float(m.group(2)), float(m.group(3)))


def nearest_corner(xy, rings, regions) -> np.ndarray:
    """The input point nearest xy (the message prints 6 significant digits)."""
    P = np.concatenate([np.asarray(R, dtype=float) for R in list(rings) + list(regions)])
    return P[np.argmin(np.hypot(*(P - np.asarray(xy)).T))]


def sharpest_corner(rings, regions, Q_of: dict) -> float:
    """The smallest metric angle of any sector at any input point (degrees)."""
    every = [np.asarray(R, dtype=float) for R in list(rings) + list(regions)]
    points = np.unique(np.concatenate(every), axis=0)
    return min((a for p in points for a, _ in corner_angles(p, rings, regions, Q_of)), default=float("nan"))
