"""The orientation predicate, exact: the sign of the turn a → b → c as real arithmetic has it.

Rounded, the cross product of nearly collinear points can take either sign, and a different one
for the same three points named in another order (t·(cos 1, sin 1) at t = 0, 1, ¼: 0 one way,
+1 another), so two crossing tests that call it in different orders disagree. Shewchuk's
filter (Adaptive Precision Floating-Point Arithmetic and Fast Robust Geometric Predicates,
1997, orient2d's first stage): the rounded determinant is kept wherever it exceeds its
rounding-error bound, which decides nearly every case; the few that remain are computed
exactly in rational arithmetic (every float is a rational), so the sign is that of the real
determinant, whichever order the points come in.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

EPS = np.finfo(float).eps / 2                        # the unit round-off, 2⁻⁵³
CCW_BOUND = (3.0 + 16.0 * EPS) * EPS                 # Shewchuk's ccwerrboundA


def orient(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Sign (−1, 0, +1) of the turn a → b → c, row by row (arrays (k, 2)): +1 counter-clockwise,
    exact for every finite input."""
    a, b, c = (np.asarray(z, dtype=float) for z in (a, b, c))
    with np.errstate(over="ignore", invalid="ignore"):
        left = (a[:, 0] - c[:, 0]) * (b[:, 1] - c[:, 1])
        right = (a[:, 1] - c[:, 1]) * (b[:, 0] - c[:, 0])
        det = left - right
        # products of opposite signs: |det| = |left| + |right|, sure; else Shewchuk's bound
        unsure = np.flatnonzero(~(np.abs(det) > CCW_BOUND * np.abs(left + right)))
    out = np.sign(det)
    # a product rounded to 0 is exactly 0 (a difference rounds to 0 only when exact), and the
    # other's sign is exact: so is det's then; inf or nan (beyond the range) is computed exactly
    unsure = unsure[((left[unsure] != 0) & (right[unsure] != 0)) | ~np.isfinite(det[unsure])]
    for k in unsure:                             # rare: nearly collinear
        out[k] = _exact(a[k], b[k], c[k])
    return out


def _exact(a, b, c) -> float:
    """The sign of the determinant in rational arithmetic."""
    ax, ay, bx, by, cx, cy = (Fraction(float(z)) for z in (*a, *b, *c))
    det = (ax - cx) * (by - cy) - (ay - cy) * (bx - cx)
    return float((det > 0) - (det < 0))
