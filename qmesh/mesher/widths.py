"""Which of many polygons may be thin in their own metrics, and how wide those are.

A face whose longest segment is many of its widths (in its metric) needs boundary pieces set by
its width rather than by h (media/plan.py). The width of a polygon's hull is at least its area
over its diameter: that bound, taken for every polygon at once, clears the compact ones, and only
the others build their hull (`sizing.hull_metric_width`), which at a thousand faces was most of
the plan's time.
"""

from __future__ import annotations

import numpy as np

from qmesh.mesher.sizing import hull_metric_width


def thin_widths(X: np.ndarray, first: np.ndarray, anis: list, k: list, longest: np.ndarray,
                aspect: float) -> np.ndarray:
    """The width in its metric ∇²s / k of the hull of each polygon (corners X[first[i]:first[i+1]])
    that may be thin, `aspect` widths shorter than its `longest` segment; inf for the others."""
    n_f = len(first)
    n0 = np.diff(np.append(first, len(X)))
    face = np.repeat(np.arange(n_f), n0)
    nxt = np.arange(1, len(X) + 1)
    nxt[first + n0 - 1] = first
    d = X - np.minimum.reduceat(X, first)[face]
    area = 0.5 * np.abs(np.bincount(face, d[:, 0] * d[nxt, 1] - d[:, 1] * d[nxt, 0], minlength=n_f))
    H = np.array([a.H / kk if a.is_constant else np.full((2, 2), np.nan) for a, kk in zip(anis, k)])
    a, b, c = H[:, 0, 0], H[:, 0, 1], H[:, 1, 1]
    det = a * c - b * b
    with np.errstate(all="ignore"):
        l00, l10, l11 = np.sqrt(a), b / np.sqrt(a), np.sqrt(det / a)     # H = L Lᵀ
        Y = np.column_stack([d[:, 0] * l00[face] + d[:, 1] * l10[face], d[:, 1] * l11[face]])
        across = np.hypot(*(np.maximum.reduceat(Y, first) - np.minimum.reduceat(Y, first)).T)
        low = (1 - 1e-6) * area * l00 * l11 / across        # metric area / metric diameter
        clear = (det > 1e-6 * a * c) & np.isfinite(low) & (aspect * low >= longest)
    width = np.full(n_f, np.inf)
    for i in np.flatnonzero(~clear):                     # the few that may be thin
        width[i] = hull_metric_width(X[first[i]:first[i] + n0[i]].copy(), anis[i], k[i])
    return width
