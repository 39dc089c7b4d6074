"""What the corners of a domain allow a mesh's min metric quality to be, for the benchmark pages.

A triangle with a vertex c on the boundary has its angle at c inside the boundary's wedge there,
in any linear metric, so at most the wedge's angle α measured in the triangle's own metric; and
a triangle with an angle α < 60° has metric quality (2.94) at most the isosceles one's,
2√3 sin α / (2 + 4 sin²(α/2)). No mesh of that domain can do better than the smallest of these.
"""

from __future__ import annotations

import numpy as np


def corner_bound(P, T, Qbar, tags=None) -> float:
    """The bound over the boundary vertices of the triangles T (P their points, Qbar (len(T), 2, 2)
    each triangle's conductivity; its metric is adj Q̄): 1 where every wedge is 60° or wider.
    With region `tags` (one per triangle), each region's triangles on their own: its wedges are
    its corners on the outline and on its interfaces."""
    P, T = np.asarray(P, float), np.asarray(T)
    if tags is not None:
        tags, Qbar = np.asarray(tags), np.asarray(Qbar, float)
        return min((corner_bound(P, T[tags == r], Qbar[tags == r]) for r in np.unique(tags)),
                   default=1.0)
    X = P[T]
    cw = ((X[:, 1, 0] - X[:, 0, 0]) * (X[:, 2, 1] - X[:, 0, 1])
          - (X[:, 1, 1] - X[:, 0, 1]) * (X[:, 2, 0] - X[:, 0, 0])) < 0
    T = np.where(cw[:, None], T[:, [0, 2, 1]], T)                # Ω to the left of a → b
    a, b = T.ravel(), T[:, [1, 2, 0]].ravel()
    _, inv, counts = np.unique(np.sort(np.stack([a, b], 1), axis=1), axis=0,
                               return_inverse=True, return_counts=True)
    out = counts[inv.ravel()] == 1                             # boundary half-edges a → b
    nxt, prv = np.full(len(P), -1), np.full(len(P), -1)
    nxt[a[out]], prv[b[out]] = b[out], a[out]
    c, t = T.ravel(), np.repeat(np.arange(len(T)), 3)
    on = nxt[c] >= 0
    c, t = c[on], t[on]
    u, v = P[nxt[c]] - P[c], P[prv[c]] - P[c]
    Q = np.asarray(Qbar, float)[t]
    adj = np.stack([np.stack([Q[:, 1, 1], -Q[:, 0, 1]], -1), np.stack([-Q[:, 1, 0], Q[:, 0, 0]], -1)], -2)
    R = np.linalg.cholesky(0.5 * (adj + np.swapaxes(adj, 1, 2)))   # H = R Rᵀ: metric vectors Rᵀx
    U, V = np.einsum("kji,kj->ki", R, u), np.einsum("kji,kj->ki", R, v)
    alpha = np.arctan2(U[:, 0] * V[:, 1] - U[:, 1] * V[:, 0], (U * V).sum(axis=1)) % (2 * np.pi)
    alpha = alpha[alpha < np.pi / 3]
    if not len(alpha):
        return 1.0
    return float((2 * np.sqrt(3) * np.sin(alpha) / (2 + 4 * np.sin(alpha / 2) ** 2)).min())


def regions_corner_bound(mesh, conductivity) -> float:
    """The bound of a medium's mesh: each region's triangles on their own, in its Q (a region's
    wedges are its corners on the outline and on its interfaces)."""
    Qbar = np.stack([conductivity[r].matrix for r in np.asarray(mesh.region_tags).tolist()]) \
        if len(mesh.region_tags) else np.zeros((0, 2, 2))
    return corner_bound(mesh.points, mesh.triangles, Qbar, mesh.region_tags)
