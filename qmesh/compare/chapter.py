"""The chapter's printed reference values (Tables 2.2 and 2.3), and Triangle's area per VB.

Unit disk (the regular VB-gon), Q = diag(0.1, 10), s = 5x² + 0.05y² (Section 2.3.3). The
isotropic meshes of the chapter come from Shewchuk's Triangle; `TRIANGLE_AREA` holds the
maximum-area switch that reproduces their N (within 2.5%). The chapter's L2 column appears low
by a factor √2 against the exact integral (MATH.md); it is kept as printed.
"""

from __future__ import annotations

import numpy as np

from qmesh.errors import QmeshError

VB = (32, 45, 64, 90, 128, 180, 256, 360, 512)

# Table 2.2 (N, ‖e_s‖_L2, |e_s|_h1) and Table 2.3 (κ2), isotropic and adapted anisotropic.
ISOTROPIC = {
    "n_vertices": (85, 190, 389, 873, 1631, 2633, 5201, 8453, 25019),
    "l2_error": (6.27e-2, 2.34e-2, 1.07e-2, 4.59e-3, 2.52e-3, 1.55e-3, 7.72e-4, 4.81e-4, 1.58e-4),
    "h1_error": (1.25, 7.42e-1, 5.04e-1, 3.28e-1, 2.43e-1, 1.91e-1, 1.35e-1, 1.07e-1, 6.11e-2),
    "kappa2": (40, 99, 220, 534, 1037, 1721, 3551, 5974, 17849),
}
ADAPTED = {
    "n_vertices": (101, 131, 212, 280, 428, 656, 817, 1380, 2312),
    "l2_error": (1.13e-2, 1.01e-2, 4.68e-3, 4.04e-3, 2.43e-3, 1.69e-3, 1.46e-3, 8.97e-4, 4.83e-4),
    "h1_error": (3.43e-1, 3.11e-1, 2.16e-1, 1.94e-1, 1.52e-1, 1.21e-1, 1.13e-1, 8.89e-2, 6.56e-2),
    "kappa2": (6.0, 6.7, 15, 18, 26, 35, 46, 71, 132),
}
QUANTITIES = ("n_vertices", "l2_error", "h1_error", "kappa2")

TRIANGLE_AREA = (0.04, 0.015, 0.007, 0.003, 0.0016, 0.001, 0.0005, 0.0003, 0.0001)
"""Triangle's `a` switch (maximum triangle area) for each VB of the chapter."""

L2_FACTOR = float(np.sqrt(2.0))
"""Our exact ‖e_s‖_L2 divided by the chapter's printed value on matched meshes (≈ √2)."""


def _check_vb(vb) -> int:
    if isinstance(vb, bool) or not isinstance(vb, (int, np.integer)) or vb < 3:
        raise QmeshError(f"VB must be an integer ≥ 3, got {vb!r}")
    return int(vb)


def row(vb: int, kind: str) -> dict | None:
    """The chapter's printed values for one VB, `kind` "isotropic" or "adapted"; None if not printed."""
    if kind not in ("isotropic", "adapted"):
        raise QmeshError(f"kind must be 'isotropic' or 'adapted', got {kind!r}")
    vb = _check_vb(vb)
    if vb not in VB:
        return None
    table = ISOTROPIC if kind == "isotropic" else ADAPTED
    i = VB.index(vb)
    return {q: table[q][i] for q in QUANTITIES}


def _loglog(vb: int, values) -> float:
    """Interpolate (or extrapolate linearly at the ends) log(values) against log(VB)."""
    x, y = np.log(VB), np.log(np.asarray(values, dtype=float))
    lx = np.log(vb)
    if lx <= x[0]:
        i = 0
    elif lx >= x[-1]:
        i = len(x) - 2
    else:
        i = int(np.searchsorted(x, lx)) - 1
    t = (lx - x[i]) / (x[i + 1] - x[i])
    return float(np.exp(y[i] + t * (y[i + 1] - y[i])))


def triangle_area(vb: int) -> float:
    """Triangle's maximum-area switch for VB: the chapter's value, else log-log interpolated."""
    vb = _check_vb(vb)
    if vb in VB:
        return TRIANGLE_AREA[VB.index(vb)]
    return _loglog(vb, TRIANGLE_AREA)


def adapted_target(vb: int) -> int:
    """The vertex count an adapted mesh should reach: the chapter's adapted N, else interpolated."""
    vb = _check_vb(vb)
    if vb in VB:
        return ADAPTED["n_vertices"][VB.index(vb)]
    return max(vb + 1, int(round(_loglog(vb, ADAPTED["n_vertices"]))))
