"""`qmesh.mesh` and `qmesh.iterate`: the front door for every medium.

One conductivity on a domain without regions is Algorithm 2.1 as the chapter states it
(`qmesh.mesher.loop`); a domain with regions, or a conductivity per region ({tag: Anisotropy}),
is a heterogeneous medium (`qmesh.media`, MEDIA.md), each face meshed by that same loop.
Both layers sit below this module, so neither imports the other.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from functools import wraps
from typing import Any, Union

from qmesh import media
from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.mesher import loop
from qmesh.mesher.step import Step
from qmesh.triangle_mesh import Mesh

Conductivity = Union[Anisotropy, Mapping[int, Anisotropy]]
"""One Anisotropy, or {region tag: Anisotropy} for a medium."""


def _heterogeneous(domain: Any, conductivity: Any) -> bool:
    return bool(getattr(domain, "regions", ())) or isinstance(conductivity, Mapping)


@wraps(loop.mesh)
def mesh(domain: Any, anisotropy: Conductivity, **options: Any) -> Mesh:
    if _heterogeneous(domain, anisotropy):
        return media.mesh(domain, anisotropy, **options)
    return loop.mesh(domain, anisotropy, **options)


@wraps(loop.iterate)
def iterate(domain: Any, anisotropy: Conductivity, **options: Any) -> Iterator[Step]:
    if _heterogeneous(domain, anisotropy):
        return media.iterate(domain, anisotropy, **options)
    return loop.iterate(domain, anisotropy, **options)


mesh.__doc__ = (loop.mesh.__doc__ or "") + """
    A domain with regions or a mapping {region tag: Anisotropy} is a medium (`qmesh.media`):
    each face meshed by the same loop in its region's metric, q_ij ≥ 0 on interface edges too.
    """
iterate.__doc__ = (loop.iterate.__doc__ or "") + """
    A domain with regions or a mapping {region tag: Anisotropy} is a medium: a Step per stage of
    every face's run (the faces done so far stitched in), the whole domain last.
    """
