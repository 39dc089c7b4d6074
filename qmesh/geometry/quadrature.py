"""Symmetric quadrature rules on a triangle, in barycentric coordinates.

The measurements integrate (s_h − s)² (degree 4 for quadratic s) and |∇s_h − ∇s|² (degree 2)
per triangle (MATH.md "Interpolation error"). One rule exact to degree 4 serves both.

Reference: D. A. Dunavant, "High degree efficient symmetrical Gaussian quadrature rules for the
triangle", Int. J. Numer. Meth. Eng. 21 (1985) 1129–1148, Table I, p = 4 (6 points; the same rule
as Strang & Fix 1973). Weights are normalised to sum to 1: ∫_T f ≈ |T| Σ_q w_q f(x_q).
"""

from __future__ import annotations

import numpy as np


def _orbit3(a: float, b: float) -> list[list[float]]:
    """The three permutations of the barycentric point (a, b, b)."""
    return [[a, b, b], [b, a, b], [b, b, a]]


# Dunavant (1985), degree 4, 6 points: two orbits of type (a, b, b).
DUNAVANT4_POINTS = np.array(
    _orbit3(0.108103018168070, 0.445948490915965)
    + _orbit3(0.816847572980459, 0.091576213509771)
)
DUNAVANT4_WEIGHTS = np.array([0.223381589678011] * 3 + [0.109951743655322] * 3)
DUNAVANT4_DEGREE = 4

for _a in (DUNAVANT4_POINTS, DUNAVANT4_WEIGHTS):
    _a.setflags(write=False)

