"""Independent checks of a medium whose regions hold fields: element means recomputed per region
(a constant itself; a collapsed-Gauss rule of another family than the mesher's for a formula)
and q_ij ≥ 0 counted the way MEDIA.md guarantees it: inside a region the sum of the two shares,
on an interface each side's share on its own, on the boundary the one share."""

import numpy as np

from qmesh.conductivity.anisotropy import adj2
from qmesh.geometry import topology
from tests.fields.test_field_mesh import reference_means

ROUND = 1e-9     # a share or a sum counts as positive beyond this share of the terms it sums


def region_means(P, T, tags, parts):
    """Means per triangle: `parts` {tag: (2, 2) array | f(x, y) → (..., 2, 2)}."""
    out = np.empty((len(T), 2, 2))
    for r, q in parts.items():
        sel = np.flatnonzero(tags == r)
        out[sel] = q if isinstance(q, np.ndarray) else reference_means(q, P, T[sel])
    return out


def failing_edges(P, T, tags, Qbar) -> dict:
    """The edges whose K_ij (−q_ij) is > 0 beyond round-off, by kind: interior (inside one
    region: the two shares summed), interface (each side alone), boundary (one share)."""
    X = P[T]
    E = X[:, [2, 0, 1]] - X[:, [1, 2, 0]]
    twice = (X[:, 1, 0] - X[:, 0, 0]) * (X[:, 2, 1] - X[:, 0, 1]) - \
        (X[:, 1, 1] - X[:, 0, 1]) * (X[:, 2, 0] - X[:, 0, 0])
    K = (np.einsum("mki,mij,mkj->mk", E, adj2(Qbar), E[:, [1, 2, 0]]) / (2.0 * twice[:, None])).ravel()
    size = (np.linalg.norm(E, axis=2) * np.linalg.norm(E[:, [1, 2, 0]], axis=2)
            * np.linalg.norm(Qbar, axis=(1, 2))[:, None] / (2.0 * np.abs(twice)[:, None])).ravel()
    twin = topology.twins(T)
    g = np.where(twin >= 0, twin, np.arange(len(twin)))
    other = tags[g // 3]
    inside = (twin >= 0) & (np.repeat(tags, 3) == other)
    iface = (twin >= 0) & ~inside
    k = K + np.where(inside, K[g], 0.0)
    scale = size + np.where(inside, size[g], 0.0)
    bad = k > ROUND * scale
    once = np.arange(len(twin)) < g
    return {"interior": int((bad & inside & once).sum()),
            "interface": int(np.unique(np.minimum(np.arange(len(twin)), g)[bad & iface]).size),
            "boundary": int((bad & (twin < 0)).sum())}
