"""A face of the partition as a `qmesh.Domain` of its own, with the points shared on its edges
as input points, so both neighbours of an interface have exactly the same vertices on it.
Segment tags of a face domain are its partition edge + 1, so the face mesh's boundary edges say
which partition edge they lie on.
"""

from __future__ import annotations

from qmesh.domain.domain import Domain
from qmesh.errors import QmeshError


def face_domain(part, face, extra: dict, name: str):
    """The Domain of `face`: its cycles' vertices with `extra[e]` (points on partition edge e, in
    order from edges[e, 0]) inserted along the way. With no vertex met twice (a pinch) it is as
    simple as the partition made it, the extra points lying on its edges: `Domain.from_checked_rings`
    skips the pair checks (a thousand holes around a face took most of its run's time)."""
    rings, tags, simple = part.face_rings(face, extra)
    known = Domain.from_checked_rings(rings, tags) if simple else None
    if known is None:
        try:
            known = Domain(rings[0], rings[1:], tags=tags)
        except QmeshError as e:
            raise QmeshError(f"{name} cannot be meshed on its own: {e} (regions that touch in a "
                             "single point pinch it; let them share an edge or keep them apart)"
                             ) from None
    known.media_face = True          # a side is a partition edge (corners.side_runs)
    return known

