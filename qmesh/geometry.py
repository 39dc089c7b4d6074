"""Per-triangle geometry shared by the mesher and the measurements.

Areas, the vertex gradients of the area, metric edge lengths and the metric quality (2.94).
Everything is vectorised over the (M, 3) triangle array.
"""

from __future__ import annotations

import numpy as np


def signed_areas(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Signed area of every triangle (> 0 when counter-clockwise)."""
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def area_gradients(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """∇_{x_a}|T| for each corner a of each triangle, shape (M, 3, 2) (MATH.md, below (2.85)).

    For a counter-clockwise triangle (i, j, k): ∇_{x_i}|T| = ½ (y_j − y_k, x_k − x_j).
    """
    X = P[T]                                  # (M, 3, 2)
    nxt, prv = X[:, [1, 2, 0]], X[:, [2, 0, 1]]
    d = nxt - prv                             # x_j − x_k for corner i
    return 0.5 * np.stack([d[..., 1], -d[..., 0]], axis=-1)


def centroids(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    return P[T].mean(axis=1)


def metric_hessians(anisotropy, P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """The metric H = ∇²s of each triangle, evaluated at its centroid: (M, 2, 2)."""
    if anisotropy.is_constant:
        return np.broadcast_to(anisotropy.H, (len(T), 2, 2))
    return np.asarray(anisotropy.hessian(centroids(P, T)), dtype=float)


def metric_edge_lengths2(P: np.ndarray, T: np.ndarray, H: np.ndarray) -> np.ndarray:
    """Squared metric lengths eᵀHe of the three edges opposite each corner: (M, 3)."""
    X = P[T]
    E = X[:, [2, 0, 1]] - X[:, [1, 2, 0]]     # edge opposite corner a: x_{a+2} − x_{a+1}
    return np.einsum("mki,mij,mkj->mk", E, H, E)


def metric_areas(P: np.ndarray, T: np.ndarray, H: np.ndarray) -> np.ndarray:
    """Area in metric space: √det H · |T|."""
    det = H[:, 0, 0] * H[:, 1, 1] - H[:, 0, 1] * H[:, 1, 0]
    return np.sqrt(det) * signed_areas(P, T)


def metric_quality(P: np.ndarray, T: np.ndarray, H: np.ndarray) -> np.ndarray:
    """Quality (2.94) in metric space, normalised to 1 for an equilateral triangle: 4√3 Ã / Σ l̃²."""
    l2 = metric_edge_lengths2(P, T, H).sum(axis=1)
    return 4.0 * np.sqrt(3.0) * metric_areas(P, T, H) / l2
