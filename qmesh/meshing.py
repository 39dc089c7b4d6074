"""`qmesh.mesh` and `qmesh.iterate`: the front door for every medium.

One conductivity on a domain without regions is Algorithm 2.1 as the chapter states it
(`qmesh.mesher.loop`); a domain with regions, or a conductivity per region ({tag: Anisotropy}),
is a heterogeneous medium (`qmesh.media`, MEDIA.md), each region meshed by that same loop.
Both layers sit below this module, so neither imports the other.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import wraps

from qmesh import media
from qmesh.mesher import loop


def _heterogeneous(domain, conductivity) -> bool:
    return bool(getattr(domain, "regions", ())) or isinstance(conductivity, Mapping)


@wraps(loop.mesh)
def mesh(domain, anisotropy, **options):
    if _heterogeneous(domain, anisotropy):
        return media.mesh(domain, anisotropy, **options)
    return loop.mesh(domain, anisotropy, **options)


@wraps(loop.iterate)
def iterate(domain, anisotropy, **options):
    if _heterogeneous(domain, anisotropy):
        return media.iterate(domain, anisotropy, **options)
    return loop.iterate(domain, anisotropy, **options)


mesh.__doc__ = loop.mesh.__doc__ + """
    A domain with regions or a mapping {region tag: Anisotropy} is meshed by `qmesh.media.mesh`
    (a conductivity per region, q_ij ≥ 0 on interface edges too).
    """
iterate.__doc__ = loop.iterate.__doc__ + """
    A domain with regions or a mapping {region tag: Anisotropy} runs `qmesh.media.iterate`.
    """
