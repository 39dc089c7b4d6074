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
    table = np.empty((len(nodes), 3))                          # h11, h12, h22 at node i·n1 + j
    for s in range(0, len(nodes), CHUNK):                      # a chunk's samples at a time
        part = shape_metric(smoothed(field, nodes[s:s + CHUNK], width, (lo, hi))).reshape(-1, 4)
        table[s:s + CHUNK] = part[:, [0, 1, 3]]

    du, dv = gx[1] - gx[0], gy[1] - gy[0]
    top_u, top_v = n[0] - 1.0, n[1] - 1.0
    h11, h12, h22 = (np.ascontiguousarray(table[:, c]) for c in range(3))

    def hessian(P: NDArray[np.float64]) -> NDArray[np.float64]:
        # the bilinear mix (1 − fu)((1 − fv) a0 + fv a1) + fu((1 − fv) a2 + fv a3) of the cell's
        # corners, component by component into the output (the mesher asks some 30 times an
        # iteration, for a few thousand points each: temporaries and gathers of rows cost more
        # than the arithmetic)
        P = np.asarray(P, dtype=float)
        u = np.minimum(np.maximum((P[:, 0] - lo[0]) / du, 0.0), top_u)
        v = np.minimum(np.maximum((P[:, 1] - lo[1]) / dv, 0.0), top_v)
        i, j = np.minimum(u.astype(int), n[0] - 2), np.minimum(v.astype(int), n[1] - 2)
        fu, fv = u - i, v - j
        gu, gv = 1 - fu, 1 - fv
        k = i * n[1] + j                                         # the cell's lower-left node
        k1, k2, k3 = k + 1, k + n[1], k + (n[1] + 1)
        out = np.empty((len(P), 2, 2))
        for c, (row, col) in zip((h11, h12, h22), ((0, 0), (0, 1), (1, 1))):
            out[:, row, col] = gu * (gv * c[k] + fv * c[k1]) + fu * (gv * c[k2] + fv * c[k3])
        out[:, 1, 0] = out[:, 0, 1]
        return out
    return Anisotropy.metric_only(hessian, getattr(field, "label", "") or "tensor field")


GRID = 2          # grid nodes per smoothing width
MAX_GRID = 2048   # nodes a side at most (4e6 in all)
CHUNK = 1 << 16   # nodes smoothed at a time: the table's samples never all held at once
