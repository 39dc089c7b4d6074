"""The metric a tensor field is meshed in: the shape of Q, smoothed at the target scale.

FIELDS.md §4: the mesh follows H = adj Q̃ / √det Q̃, where Q̃ is Q averaged over a square one
element across around each point — the shape of Q, not its magnitude (a region of a medium is
sized the same way), and a raster's cell-to-cell noise averaged out at the scale the mesh can
see. det H = 1, so N is shared by area. The mesher meshes it as a metric without s
(`Anisotropy.metric_only`): flips and encroachment in the local metric, the shape step.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from qmesh.conductivity.anisotropy import Anisotropy, shape_metric

_GAUSS = np.array([[sx, sy] for sx in (-1, 1) for sy in (-1, 1)]) / np.sqrt(3.0)
"""2 × 2 Gauss–Legendre points on [−1, 1]²: they avoid the centre, where a field such as
FVCA5 test 5's may be singular (its rotation centre is a corner of the domain)."""


def smoothing_width(domain, target_vertices: int | None, size: float | None) -> float:
    """Half the side of the averaging square: one element, from N by area (det H = 1), or the
    metric size asked for, or the mean boundary segment."""
    if target_vertices is not None:
        return float(np.sqrt(2.0 * domain.area / (np.sqrt(3.0) * target_vertices)))
    if size is not None:
        return float(size)
    A, B = domain.segment_ends
    return float(np.mean(np.hypot(*(B - A).T)))


def smoothed(field, P: NDArray[np.float64], width: float, box) -> NDArray[np.float64]:
    """Q averaged over the square of half-side `width` around each point: exact cell areas for
    a raster (`box_means`), a 2 × 2 Gauss rule for a formula. Q is only asked for in `box`
    (Ω's bounding box, (lo, hi)): the mesher probes its metric near Ω, and a user's Q need only
    be defined on Ω; a sample outside is mirrored into the box (clamping would put the samples
    of a corner onto the corner, where a field may be singular)."""
    lo, hi = box
    P = np.clip(np.asarray(P, dtype=float), lo, hi)
    if field.is_raster:
        return np.asarray(field.box_means(P, width), dtype=float)
    X = (P[:, None, :] + width * _GAUSS[None]).reshape(-1, 2)
    X = np.where(X < lo, 2 * lo - X, X)
    X = np.clip(np.where(X > hi, 2 * hi - X, X), lo, hi)
    return np.asarray(field(X), dtype=float).reshape(len(P), 4, 2, 2).mean(axis=1)


def field_metric(field, width: float, box) -> Anisotropy:
    """The metric-only Anisotropy H = adj Q̃ / √det Q̃ of `field` smoothed at `width` in `box`.

    Smoothed at `width`, H varies little over width/GRID: it is sampled once on a grid of that
    spacing over the box (at most MAX_GRID nodes a side) and interpolated bilinearly — the
    mesher asks for it at every vertex at every stage, and a formula's or a raster's smoothing
    costs a few evaluations each. A bilinear mix of SPD matrices is SPD."""
    lo, hi = (np.asarray(v, dtype=float) for v in box)
    n = np.clip(np.ceil((hi - lo) * GRID / width).astype(int) + 1, 2, MAX_GRID)
    gx, gy = np.linspace(lo[0], hi[0], n[0]), np.linspace(lo[1], hi[1], n[1])
    nodes = np.column_stack([np.repeat(gx, n[1]), np.tile(gy, n[0])])
    table = shape_metric(smoothed(field, nodes, width, (lo, hi))).reshape(-1, 4)
    table = np.ascontiguousarray(table[:, [0, 1, 3]])           # h11, h12, h22 at node i·n1 + j

    def hessian(P: NDArray[np.float64]) -> NDArray[np.float64]:
        P = np.asarray(P, dtype=float)
        u = np.clip((P[:, 0] - lo[0]) / (gx[1] - gx[0]), 0.0, n[0] - 1.0)
        v = np.clip((P[:, 1] - lo[1]) / (gy[1] - gy[0]), 0.0, n[1] - 1.0)
        i, j = np.minimum(u.astype(int), n[0] - 2), np.minimum(v.astype(int), n[1] - 2)
        fu, fv = (u - i)[:, None], (v - j)[:, None]
        k = i * n[1] + j                                         # the cell's lower-left node
        at = [np.take(table, k + c, axis=0) for c in (0, 1, n[1], n[1] + 1)]   # take: no slow path
        h = (1 - fu) * ((1 - fv) * at[0] + fv * at[1]) + fu * ((1 - fv) * at[2] + fv * at[3])
        return np.take(h, [0, 1, 1, 2], axis=1).reshape(-1, 2, 2)
    return Anisotropy.metric_only(hessian, getattr(field, "label", "") or "tensor field")


GRID = 2          # grid nodes per smoothing width
MAX_GRID = 2048   # nodes a side at most (4e6 in all)
