"""A tensor field Q(x) meshed by Algorithm 2.1 itself, then certified on its element means.

FIELDS.md §4. A field has no s, so it is meshed in its metric (metric.py: the shape of Q,
smoothed at the target scale) by the same loop, plan and stages as a constant Q
(`mesher.loop.iterate` with `Anisotropy.metric_only`: seeding in the local metric, flips and
encroachment in the local metric, the shape step). Then the P1 stiffness matrix is assembled
with the element means Q̄_T and every edge that fails q_ij ≥ 0 is flipped or split
(certify.py): the last Step's mesh carries the means it was certified with.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterator
from dataclasses import fields, replace
from typing import Any

import numpy as np

from qmesh.conductivity.anisotropy import Anisotropy, shape_metric
from qmesh.domain.domain import as_domain
from qmesh.errors import QmeshError, QmeshWarning
from qmesh.fields import followable
from qmesh.fields.certify import Certificate, certify
from qmesh.fields.metric import field_metric, smoothing_width
from qmesh.geometry.triangles import metric_quality
from qmesh.mesher import budget, loop
from qmesh.mesher.diagnose import warn_if_thin
from qmesh.mesher.options import Options
from qmesh.mesher.plan import TOLERANCE
from qmesh.mesher.step import Stats, Step, last_step
from qmesh.triangle_mesh import Mesh

OPTION_NAMES = {f.name for f in fields(Options)}


def iterate(domain: Any, field: Any, *, target_vertices: int | None = None,
            size: float | None = None, **options: Any) -> Iterator[Step]:
    """Algorithm 2.1 on the field's metric, a Step after every stage, then a last Step whose
    mesh passes q_ij ≥ 0 on every edge with the element means (`Mesh.conductivity`), the only
    one `converged`. The options are those of a constant Q (`qmesh.iterate`)."""
    domain = as_domain(domain)
    # the options, checked as the mesher checks them (naming them), before the smoothing width
    # reads target_vertices or size
    Options.checked(target_vertices=target_vertices, size=size,
                    **{k: v for k, v in options.items() if k in OPTION_NAMES})
    if target_vertices is not None:            # refused before the metric's table is built
        budget.check(int(target_vertices), varying=True, field=True)
    metric = _constant(field)                  # numbers only: the constant Q's own path, no
    if metric is None:                         # metric table, no smoothing, the same mesh as it
        width = smoothing_width(domain, target_vertices, size)
        # a formula no mesh of this size can follow, or not integrable: refused before it is tried
        followable.check(domain, field, width,
                         None if target_vertices is None else int(target_vertices))
        metric = field_metric(field, width, domain.bounds)
    steps = loop.iterate(domain, metric, target_vertices=target_vertices, size=size, **options)
    return _certified(steps, field, metric, target_vertices)


def _constant(field: Any) -> Anisotropy | None:
    """`Anisotropy.constant` of a constant field's Q; None for a varying field, and for a Q the
    constant refuses (beyond the floats): the field's own path then says what to change."""
    Q = getattr(field, "constant_matrix", None)
    if Q is None:
        return None
    try:
        return Anisotropy.constant(Q)
    except QmeshError:
        return None


def mesh(domain: Any, field: Any, *, progress: Callable[[Step], object] | None = None,
         **options: Any) -> Mesh:
    """The mesh of the last Step of `iterate` with the same arguments; `progress`, when given,
    is called with every Step."""
    return last_step(iterate(domain, field, **options), progress).mesh


def _certified(steps: Iterator[Step], field: Any, metric: Any,
               target: int | None) -> Iterator[Step]:
    last = None
    for last in steps:
        yield replace(last, converged=False)
    assert last is not None
    warn_if_thin(last.mesh, metric, stacklevel=4)
    m, cert = certify(last.mesh, field, metric=metric)
    # said before the last Step is yielded: a caller that stops at `converged` still hears it
    say(m, cert, target, stacklevel=4)
    yield final_step(m, cert, last.iteration)


def final_step(m: Mesh, cert: Certificate, iteration: int) -> Step:
    """The certified mesh's Step, its quality in each triangle's own means (FIELDS.md §3), as
    `measure.report` and the views measure it; no energy without an s."""
    assert m.conductivity is not None
    q = metric_quality(m.points, m.triangles, shape_metric(m.conductivity))
    return Step("triangulate", iteration, m, Stats(m.n_vertices, m.n_triangles, float("nan"),
                float(np.nanmin(q)), float(np.nanmean(q)), flips=cert.flips, added=cert.added),
                converged=True)


def say(m: Mesh, cert: Certificate, target: int | None, stacklevel: int = 3) -> None:
    """What the repair added beyond the target, and what it left failing: never a silent pass."""
    if cert.added and (target is None or m.n_vertices > (1 + TOLERANCE) * target):
        warnings.warn(f"keeping every q_ij >= 0 with the element means of Q took {cert.added} more "
                      f"vertices (N = {m.n_vertices}): Q changes faster across some triangles than "
                      "the mesh resolves", QmeshWarning, stacklevel=stacklevel)
    if cert.remaining:
        warnings.warn(f"{cert.remaining} edges still have q_ij < 0 with the element means after "
                      f"{cert.rounds} rounds of flips and splits (worst (q_ij - bound) / "
                      f"(sum|q_ij^T| + bound) = {cert.worst:.2e}, the bound the means' error); ask "
                      "for more vertices", QmeshWarning, stacklevel=stacklevel)
