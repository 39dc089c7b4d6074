"""A medium whose regions hold tensor fields: {tag: Anisotropy | TensorField}, certified on the
element means.

MEDIA.md with FIELDS.md §4. A region holding a `TensorField` is meshed as a field is (its metric
`fields.metric.field_metric`: the shape of Q smoothed at the target scale, a metric without s),
a region holding an Anisotropy as today; every face by the medium's own plan and runs
(mesher.py: one sizing, interface points shared, the faces stitched). A field's element means
are not its metric, so the stitched mesh is then certified once on them (`fields.certify` with
the regions): every interior, interface and boundary q_ij ≥ 0 with each triangle's mean from
its own region (exact constants in Anisotropy regions), an interface's two shares each ≥ 0 on
its own, failing edges flipped inside a region or split (an interface edge on both sides). The
mesh carries the means (`Mesh.conductivity`) and its region tags.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.conductivity.field import TensorField
from qmesh.domain.domain import as_domain
from qmesh.domain.regions import conductivity_of_regions
from qmesh.errors import QmeshError
from qmesh.fields.certify import certify
from qmesh.fields.mesher import final_step, say
from qmesh.fields.metric import field_metric, smoothing_width
from qmesh.geometry.triangles import metric_quality
from qmesh.media import mesher
from qmesh.mesher.step import Stats, Step
from qmesh.triangle_mesh import Mesh

_ANY = Anisotropy.constant(np.eye(2))
"""Stands for a field while the mapping's tags are checked (`conductivity_of_regions`)."""


def holds_fields(domain: Any, conductivity: Any) -> bool:
    """True for a domain with regions and a TensorField, or a mapping holding one."""
    if isinstance(conductivity, TensorField):
        return bool(getattr(domain, "regions", ()))
    return isinstance(conductivity, Mapping) and any(isinstance(v, TensorField)
                                                     for v in conductivity.values())


def iterate(domain: Any, conductivity: Any, *, target_vertices: int | None = None,
            size: float | None = None, **options: Any) -> Iterator[Step]:
    """The medium's Steps (`media.iterate`, each field region in its field's metric), then a last
    Step whose mesh passes q_ij ≥ 0 on every edge with the element means, the only one
    `converged`. The arguments are checked now."""
    domain, cond, metrics = _metrics(domain, conductivity, target_vertices, size)
    steps = mesher.iterate(domain, metrics, target_vertices=target_vertices, size=size, **options)
    return _certified(steps, cond, metrics, target_vertices)


def mesh(domain: Any, conductivity: Any, *, target_vertices: int | None = None,
         size: float | None = None, progress: Callable[[Step], object] | None = None,
         **options: Any) -> Mesh:
    """The certified mesh of the last Step of `iterate`; `progress`, when given, is called with
    every Step (without it the faces' stages are not stitched one by one)."""
    domain, cond, metrics = _metrics(domain, conductivity, target_vertices, size)
    if progress is not None and not callable(progress):
        raise QmeshError(f"progress must be a function of one Step, got {type(progress).__name__}")
    seen: list = [0]                           # the iteration of the last Step shown

    def show(step: Step) -> None:
        seen[0] = step.iteration
        progress(_shown(step, metrics, False))
    m = mesher.mesh(domain, metrics, target_vertices=target_vertices, size=size,
                    progress=None if progress is None else show, **options)
    done, cert = certify(m, cond)
    say(done, cert, target_vertices)
    if progress is not None:
        progress(final_step(done, cert, seen[0]))
    return done


def _metrics(domain: Any, conductivity: Any, target: int | None,
             size: float | None) -> tuple[Any, dict, dict]:
    """The domain, {tag: Anisotropy | TensorField} for every region with a face, and what each is
    meshed in: an Anisotropy itself, a field its metric smoothed at one element of the target
    (`smoothing_width`) over its region's box (Ω's box for region 0), a raster checked to cover
    that box."""
    domain = as_domain(domain)
    if isinstance(conductivity, Mapping):
        for k, v in conductivity.items():
            if not isinstance(v, (Anisotropy, TensorField)):
                raise QmeshError(f"the conductivity of region {k} must be a qmesh.Anisotropy or "
                                 f"a qmesh.TensorField, got {type(v).__name__}")
        stand_in = {k: (_ANY if isinstance(v, TensorField) else v) for k, v in conductivity.items()}
        tags = conductivity_of_regions(domain, stand_in)          # tags and coverage checked
        cond = {r: conductivity[r] for r in tags}
    else:
        cond = {r: conductivity for r in conductivity_of_regions(domain, _ANY)}
    width = smoothing_width(domain, target, size)
    metrics, made = {}, {}
    for r, c in cond.items():
        if isinstance(c, Anisotropy):
            metrics[r] = c
            continue
        box = _box(domain, r)
        c.check_covers(box, f"region {r}" + (f" ({domain.region_names[r]})"
                                             if r in domain.region_names else ""))
        key = (id(c), tuple(np.concatenate(box).tolist()))
        if key not in made:                   # one field on several regions of one box: once
            made[key] = field_metric(c, width, box)
        metrics[r] = made[key]
    return domain, cond, metrics


def _box(domain: Any, r: int) -> tuple[np.ndarray, np.ndarray]:
    """The box (lo, hi) of region r within Ω: where its field is asked for."""
    lo, hi = (np.asarray(v, dtype=float) for v in domain.bounds)
    if r == 0:
        return lo, hi
    rlo, rhi = (np.asarray(v, dtype=float) for v in domain.regions[r - 1].bounds)
    return np.maximum(lo, rlo), np.minimum(hi, rhi)


def _shown(step: Step, metrics: dict, converged: bool) -> Step:
    """A medium's Step with its figures in the regions' metrics (a field's has no s: no energy)."""
    m = step.mesh
    q = _quality(m, metrics)
    stats = Stats(m.n_vertices, m.n_triangles, float("nan"), float(q.min()), float(q.mean()),
                  seconds=step.stats.seconds)
    return replace(step, stats=stats, converged=converged)


def _quality(m: Mesh, metrics: dict) -> np.ndarray:
    H = np.empty((m.n_triangles, 2, 2))
    for r, a in metrics.items():
        sel = np.flatnonzero(m.region_tags == r)
        H[sel] = a.H if a.is_constant else a.hessian(m.points[m.triangles[sel]].mean(axis=1))
    return metric_quality(m.points, m.triangles, H)


def _certified(steps: Iterator[Step], cond: dict, metrics: dict,
               target: int | None) -> Iterator[Step]:
    last = None
    for last in steps:
        yield _shown(last, metrics, False)
    assert last is not None
    done, cert = certify(last.mesh, cond)
    say(done, cert, target, stacklevel=4)     # before the last Step: a caller stopping there hears it
    yield final_step(done, cert, last.iteration)
