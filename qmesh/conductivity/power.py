"""Q^p: a conductivity field with Q's principal directions and its principal values raised to p.

Why: meshed as a field, Q^p gives elements stretched along Q's principal directions, with the
aspect √(k1/k2)^p — isotropic at p = 0, Q's own shape at p = 1. That is the family of meshes
benchmarks/bench_front.py measures against the true Q (the accuracy–certificate front,
docs/guide/monotonicity.md). Q^p = V diag(k1^p, k2^p) Vᵀ for Q = V diag(k1, k2) Vᵀ.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from qmesh import checks
from qmesh.conductivity.field import TensorField, _check_components
from qmesh.conductivity.means import full_tensors
from qmesh.errors import QmeshError
from qmesh.geometry import portable

Array = NDArray[np.float64]


def power(field: TensorField, p: float) -> TensorField:
    """The field Q^p of `field` Q: the same eigenvectors, the eigenvalues raised to `p` (any
    finite real; p = 0 gives the identity, p = 1 Q again, to round-off).

    A constant field gives a constant one, a raster a raster of the same cells (k1^p, k2^p at
    the same angle, so its means stay exact), a formula or a callable a callable that evaluates
    `field` and powers it point by point (checked where it is evaluated, as `field` is)."""
    if not isinstance(field, TensorField):
        raise QmeshError(f"field must be a qmesh.TensorField, got {checks.describe(field)}")
    p = checks.real(p, "p")
    label = f"({field.label})^{p:g}"
    raster = field._raster
    if raster is not None:
        k1, k2, angle = principal(raster.q)
        powered = TensorField.from_raster(raster.x + raster.origin[0], raster.y + raster.origin[1],
                                          portable.power(k1, p), portable.power(k2, p), angle)
        powered.label = label                                  # says it is a power, as the others
        return powered
    source, constant = field._components, field._constant

    def components(X: Array, Y: Array) -> Array:
        q = powered_components(source(X, Y), p)                # a large |p| can overflow: checked
        return _check_components(X, Y, q[:, 0], q[:, 1], q[:, 1], q[:, 2], label)

    return TensorField._of_components(components, label, None if constant is None
                                      else powered_components(constant[None], p)[0].tolist())


def principal(q: Array) -> tuple[Array, Array, Array]:
    """Components (..., 3) of SPD tensors → (k1, k2, angle in degrees): k1 ≥ k2 the principal
    values, k1 along the direction at `angle` counter-clockwise from the x axis."""
    mean, half = 0.5 * (q[..., 0] + q[..., 2]), 0.5 * (q[..., 0] - q[..., 2])
    radius = np.hypot(half, q[..., 1])
    angle = 0.5 * np.degrees(portable.arctan2(q[..., 1], half))
    return mean + radius, mean - radius, angle


def powered_components(q: Array, p: float) -> Array:
    """Components (n, 3) of SPD tensors Q → those of Q^p (eigen-decomposed all at once, in
    closed form: the same bits on every CPU)."""
    k, V = portable.eigh2(full_tensors(q))                     # ascending k, columns of V
    with np.errstate(over="ignore", invalid="ignore"):           # the caller refuses inf
        M = portable.matmul2(V * portable.power(k, p)[:, None, :], np.swapaxes(V, 1, 2))
    return np.column_stack([M[:, 0, 0], 0.5 * (M[:, 0, 1] + M[:, 1, 0]), M[:, 1, 1]])
