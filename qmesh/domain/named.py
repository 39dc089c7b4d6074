"""Named domains for examples, the viewer, the benchmarks and the tests (GEOMETRY.md §1–§2).

Each returns a `Domain` of diameter about 2 centred near the origin, with the default tags
(1 for the outline, 2, 3, … for the holes) and names for them.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from qmesh.domain.domain import Disk, Domain


def _circle(n: int, radius: float, center: ArrayLike = (0.0, 0.0)) -> NDArray[np.float64]:
    t = 2 * np.pi * np.arange(n) / n
    return np.asarray(center, dtype=float) + radius * np.column_stack([np.cos(t), np.sin(t)])


def disk(vb: int = 64) -> Domain:
    """The chapter's regular VB-gon inscribed in the unit circle."""
    return Disk(vb)


def lshape() -> Domain:
    """[-1, 1]² less its upper-right quarter: one reflex corner of 270°."""
    return Domain([[-1, -1], [1, -1], [1, 0], [0, 0], [0, 1], [-1, 1]], names={1: "outline"})


def square_with_hole(hole_points: int = 32, hole_radius: float = 0.4) -> Domain:
    """[-1, 1]² with a circular hole (a regular polygon) at its centre."""
    return Domain([[-1, -1], [1, -1], [1, 1], [-1, 1]], [_circle(hole_points, hole_radius)],
                  names={1: "outline", 2: "hole"})


def annulus(outer_points: int = 64, inner_points: int = 32, inner_radius: float = 0.5) -> Domain:
    """The ring between two regular polygons inscribed in circles of radius 1 and `inner_radius`."""
    return Domain(_circle(outer_points, 1.0), [_circle(inner_points, inner_radius)],
                  names={1: "outer", 2: "inner"})


def plate_with_holes(hole_points: int = 16) -> Domain:
    """A 2 × 1 plate with three circular holes of different sizes."""
    holes = [_circle(hole_points, r, c) for r, c in
             ((0.2, (-0.55, 0.0)), (0.12, (0.1, 0.15)), (0.15, (0.6, -0.1)))]
    return Domain([[-1, -0.5], [1, -0.5], [1, 0.5], [-1, 0.5]], holes,
                  names={1: "outline", 2: "hole 1", 3: "hole 2", 4: "hole 3"})


def notched_square() -> Domain:
    """[-1, 1]² with a thin slot cut in from the right edge (two reflex corners)."""
    return Domain([[-1.0, -1.0], [1.0, -1.0], [1.0, -0.05], [-0.2, -0.05], [-0.2, 0.05], [1.0, 0.05],
                   [1.0, 1.0], [-1.0, 1.0]], names={1: "outline"})


NAMED = {
    "disk": disk,
    "L-shape": lshape,
    "square with hole": square_with_hole,
    "annulus": annulus,
    "plate with holes": plate_with_holes,
    "notched square": notched_square,
}
"""Display name → factory (no arguments needed)."""
