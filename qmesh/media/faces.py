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
    order from edges[e, 0]) inserted along the way; unless `checked`, as the partition made it."""
    rings, tags = [], []
    for c in face.cycles:
        pts, tg = [], []
        for h in part.cycle(c):          # half-edge h runs along edge h >> 1, backwards when odd
            x = extra.get(int(h >> 1), np.zeros((0, 2)))
            pts += [part.points[part.half_from[h]][None], x[::-1] if h & 1 else x]
            tg.append(np.full(len(x) + 1, int(h >> 1) + 1))
        rings.append(np.concatenate(pts))
        tags.append(np.concatenate(tg))
    if not checked:
        return Components(rings, tags, [sum(map(len, rings))])
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
