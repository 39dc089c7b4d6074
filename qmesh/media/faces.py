"""A face of the partition as a `qmesh.Domain` of its own, with the points shared on its edges.

Each face is meshed by the single-region mesher (Algorithm 2.1), which keeps its input points
fixed and q_ij ≥ 0 on its boundary edges in its own metric (GEOMETRY.md §1). Interface points
are given to both neighbours as input points, so both meshes have exactly the same vertices on
the interface. Segment tags of a face domain are its partition edge + 1, so the face mesh's
boundary edges say which partition edge they lie on.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from qmesh.domain.domain import Domain
from qmesh.errors import QmeshError


def face_domain(part, face, extra: dict, name: str):
    """The Domain of `face`: its cycles' vertices with `extra[e]` (points on partition edge e,
    ordered from edges[e, 0] to edges[e, 1]) inserted along the way."""
    rings, tags = [], []
    for c in face.cycles:
        pts, tg = [], []
        for h in part.cycle(c):
            e, backwards = int(h >> 1), bool(h & 1)
            pts.append(part.points[part.half_from[h]][None])
            tg.append(np.array([e + 1]))
            x = extra.get(e)
            if x is not None and len(x):
                pts.append(x[::-1] if backwards else x)
                tg.append(np.full(len(x), e + 1))
        rings.append(np.concatenate(pts))
        tags.append(np.concatenate(tg))
    try:
        return Domain(rings[0], rings[1:], tags=tags)
    except QmeshError as e:
        raise QmeshError(f"{name} cannot be meshed on its own: {e} (regions that touch in a "
                         "single point pinch it; let them share an edge or keep them apart)") from None


def points_on_edges(mesh, part, n_seeds: int) -> dict:
    """The vertices a face mesh put on partition edges, beyond its input points: {edge: (k, 2)}."""
    E, tags = mesh.boundary_edges, mesh.boundary_tags - 1
    out = {}
    for side in (0, 1):
        v = E[:, side]
        new = v >= n_seeds
        for e in np.unique(tags[new]):
            out.setdefault(int(e), []).append(v[new][tags[new] == e])
    # a corner of the partition is never a point "on" an edge (round-off copies included)
    tree = cKDTree(part.points)
    tol = 1e-12 * float(np.ptp(part.points, axis=0).max())
    res = {}
    for e, v in out.items():
        X = mesh.points[np.unique(np.concatenate(v))]
        far = tree.query(X)[0] > tol
        if far.any():
            res[e] = X[far]
    return res


def merge_points(part, e: int, old: np.ndarray | None, new: np.ndarray) -> np.ndarray:
    """Points on edge e, old and new, without repeats, ordered along the edge."""
    a, b = part.points[part.edges[e]]
    X = new if old is None else np.concatenate([old, new])
    X = np.unique(X, axis=0)
    t = (X - a) @ (b - a)
    return X[np.argsort(t, kind="stable")]
