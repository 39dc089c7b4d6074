"""`qmesh.mesh` and `qmesh.iterate`: the front door for every medium.

One conductivity on a domain without regions is Algorithm 2.1 as the chapter states it
(`qmesh.mesher.loop`); a domain with regions, or a conductivity per region ({tag: Anisotropy}),
is a heterogeneous medium (`qmesh.media`, MEDIA.md), each face meshed by that same loop; a
TensorField (`qmesh.fields`) on a domain or in some regions of a medium is meshed in its metric
and certified on its element means (`qmesh.media.field_regions` for a medium).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from functools import wraps
from typing import Any, Union

from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.conductivity.field import TensorField
from qmesh.domain.domain import as_domain
from qmesh.errors import QmeshError
from qmesh.mesher import loop
from qmesh.mesher.step import Step
from qmesh.triangle_mesh import Mesh

Conductivity = Union[Anisotropy, TensorField, Mapping[int, Union[Anisotropy, TensorField]]]
"""One Anisotropy, a TensorField, or {region tag: Anisotropy | TensorField} for a medium."""


def _heterogeneous(domain: Any, conductivity: Any) -> bool:
    return bool(getattr(domain, "regions", ())) or isinstance(conductivity, Mapping)


def _field_domain(domain: Any, field: TensorField) -> Any:
    """The domain, once checked to lie where the field is known (a raster's cells)."""
    domain = as_domain(domain)
    field.check_covers(domain.bounds)
    return domain


def _route(domain: Any, conductivity: Any) -> tuple[Any, Any]:
    """The module that meshes this case — `qmesh.fields`, `qmesh.media.field_regions`,
    `qmesh.media`, or the loop of Algorithm 2.1 — and the domain it gets. Each module is
    imported here, when a case needs it: one constant Q on a domain loads neither the fields
    nor the media."""
    if isinstance(conductivity, TensorField) and not getattr(domain, "regions", ()):
        from qmesh import fields
        return fields, _field_domain(domain, conductivity)
    if not _heterogeneous(domain, conductivity):
        return loop, domain
    from qmesh.media import field_regions
    if field_regions.holds_fields(domain, conductivity):
        return field_regions, domain
    from qmesh import media
    return media, domain


@contextmanager
def _memory_said() -> Iterator[None]:
    """A MemoryError the budget's estimate did not foresee, said as a QmeshError (the last resort:
    `mesher.budget` refuses what it can foresee before anything is allocated)."""
    try:
        yield
    except MemoryError as e:
        raise QmeshError("the run ran out of memory (an allocation failed: "
                         f"{str(e)[:120] or 'MemoryError'}); ask for fewer vertices, or free memory "
                         "or raise the process's memory limit") from None


def _guarded(steps: Iterator[Step]) -> Iterator[Step]:
    with _memory_said():
        return (yield from steps)


@wraps(loop.mesh)
def mesh(domain: Any, anisotropy: Conductivity, **options: Any) -> Mesh:
    with _memory_said():
        return _mesh(domain, anisotropy, **options)


def _mesh(domain: Any, anisotropy: Conductivity, **options: Any) -> Mesh:
    route, domain = _route(domain, anisotropy)
    return route.mesh(domain, anisotropy, **options)


@wraps(loop.iterate)
def iterate(domain: Any, anisotropy: Conductivity, **options: Any) -> Iterator[Step]:
    with _memory_said():
        return _guarded(_iterate(domain, anisotropy, **options))


def _iterate(domain: Any, anisotropy: Conductivity, **options: Any) -> Iterator[Step]:
    route, domain = _route(domain, anisotropy)
    return route.iterate(domain, anisotropy, **options)


mesh.__doc__ = (loop.mesh.__doc__ or "") + """
    A `TensorField` Q(x) (a formula, a callable or a raster) is meshed in the shape of Q and
    certified: every q_ij ≥ 0 with the stiffness assembled from the element means, which the
    mesh carries (`Mesh.conductivity`; `qmesh.fields`).
    A domain with regions or a mapping {region tag: Anisotropy} is a medium (`qmesh.media`):
    each face meshed by the same loop in its region's metric, q_ij ≥ 0 on interface edges too.
    Its regions may hold TensorFields ({tag: Anisotropy | TensorField}; one TensorField on a
    domain with regions holds in each): each face meshed in its field's metric, then the whole
    certified on the element means, each side of an interface on its own.
    """
iterate.__doc__ = (loop.iterate.__doc__ or "") + """
    A `TensorField`: a Step per stage on the field's metric, then the certified mesh.
    A domain with regions or a mapping {region tag: Anisotropy} is a medium: a Step per stage of
    every face's run (the faces done so far stitched in), the whole domain last (certified
    on the element means when a region holds a TensorField).
    """
