"""Anisotropies shared by the core tests."""

import numpy as np

import qmesh
from qmesh.geometry import topology


def exp_plus_y2() -> qmesh.Anisotropy:
    """s = exp(x) + y²: the Hessian diag(eˣ, 2) varies in size across the domain."""
    return qmesh.Anisotropy.from_s(
        lambda P: np.exp(P[:, 0]) + P[:, 1] ** 2,
        lambda P: np.column_stack([np.exp(P[:, 0]), 2 * P[:, 1]]),
        lambda P: np.stack([np.column_stack([np.exp(P[:, 0]), np.zeros(len(P))]),
                            np.column_stack([np.zeros(len(P)), np.full(len(P), 2.0)])], axis=1),
        label="exp(x) + y^2",
    )


def locally_regular(P, T, anisotropy) -> np.ndarray:
    """Relative lifted in-circle margin of every interior edge: ≥ 0 where it is locally regular.

    Written from the definition, independently of qmesh.triangulate: a lower-hull facet (u, v, a)
    has the lifted opposite vertex b on or above its plane, i.e. det[X_u − X_b; X_v − X_b;
    X_a − X_b] ≤ 0 with X = (x, y, s(x)) and (u, v, a) counter-clockwise. The tangent plane of s
    at b is subtracted first (a column operation: the determinant is unchanged, the round-off
    smaller), and the margin is divided by the product of the row norms.
    """
    twin = topology.twins(T)
    h = np.flatnonzero(twin >= 0)
    t1, e1 = np.divmod(h, 3)
    t2, e2 = np.divmod(twin[h], 3)
    u, v, a = T[t1, e1], T[t1, (e1 + 1) % 3], T[t1, (e1 + 2) % 3]
    b = T[t2, (e2 + 2) % 3]
    s, g = anisotropy.s(P), anisotropy.grad(P)
    rows = []
    for k in (u, v, a):
        d = P[k] - P[b]
        rows.append(np.column_stack([d, s[k] - s[b] - np.einsum("ni,ni->n", g[b], d)]))
    R = np.stack(rows, axis=1)                                            # (k, 3, 3)
    return -np.linalg.det(R) / np.prod(np.linalg.norm(R, axis=2), axis=1)
