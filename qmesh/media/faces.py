"""A face of the partition as a `qmesh.Domain` of its own, with the points shared on its edges
as input points, so both neighbours of an interface have exactly the same vertices on it.
Segment tags of a face domain are its partition edge + 1, so the face mesh's boundary edges say
which partition edge they lie on.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from qmesh.domain.domain import Domain
from qmesh.errors import QmeshError
from qmesh.mesher.components import Components


def face_domain(part, face, extra: dict, name: str, checked: bool = True):
    """The Domain of `face`: its cycles' vertices with `extra[e]` (points on partition edge e, in
    order from edges[e, 0]) inserted along the way; unless `checked`, as the partition made it.
    Checked without extra points on its edges, the face is as simple as the partition made it
    unless a vertex comes back (a pinch): the pair checks run only then (`Domain._known`)."""
    order, start = part.walk
    c = np.asarray(face.cycles, np.int64)
    size = start[c + 1] - start[c]
    hs = order[np.repeat(start[c] - np.cumsum(size) + size, size) + np.arange(size.sum())]
    e = hs >> 1                          # half-edge h runs along edge h >> 1, backwards when odd
    corners = part.points[part.half_from[hs]]
    xs = [extra.get(k) for k in e.tolist()] if extra else []
    n = np.fromiter((0 if x is None else len(x) for x in xs), np.int64, len(xs)) if xs else None
    if n is None or not n.any():
        R, tags = corners, e + 1
    else:
        at = np.arange(len(hs)) + np.cumsum(n) - n           # each corner, its edge's points after it
        R = np.empty((len(hs) + int(n.sum()), 2))
        R[at] = corners
        inner = np.ones(len(R), bool)
        inner[at] = False
        R[inner] = np.concatenate([x[::-1] if h & 1 else x for h, x in zip(hs.tolist(), xs) if x is not None and len(x)])
        tags = np.repeat(e + 1, n + 1)
        size = np.add.reduceat(n + 1, np.cumsum(size) - size)
    cut = np.cumsum(size).tolist()
    rings = [R[a:b] for a, b in zip([0] + cut, cut)]
    tags = [tags[a:b] for a, b in zip([0] + cut, cut)]
    if not checked:
        return Components(rings, tags, [len(R)])
    if n is None or not n.any():
        v = part.half_from[hs]
        known = Domain._known(rings, tags) if len(np.unique(v)) == len(v) else None
        if known is not None:
            return known
    try:
        return Domain(rings[0], rings[1:], tags=tags)
    except QmeshError as e:
        raise QmeshError(f"{name} cannot be meshed on its own: {e} (regions that touch in a "
                         "single point pinch it; let them share an edge or keep them apart)") from None


def points_on_edges(mesh, corners: cKDTree, n_seeds: int) -> dict:
    """The vertices a face mesh put on partition edges, beyond its input points: {edge: (k, 2)}
    (a corner of the partition, round-off copies included, is never a point "on" an edge:
    `corners`, a KD-tree of the partition's points)."""
    e, v = np.repeat(mesh.boundary_tags - 1, 2), mesh.boundary_edges.ravel()
    ev = np.unique(np.column_stack([e, v])[v >= n_seeds], axis=0)       # by edge, then vertex
    tol = 1e-12 * float((corners.maxes - corners.mins).max())          # np.ptp of its points
    ev = ev[corners.query(mesh.points[ev[:, 1]])[0] > tol]
    return {int(k): mesh.points[ev[ev[:, 0] == k, 1]] for k in np.unique(ev[:, 0])}
