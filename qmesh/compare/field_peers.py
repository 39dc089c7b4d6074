"""Peers for a conductivity field Q(x), at the same N: MMG2D with the field's per-vertex metric,
and isotropic Triangle.

- `mmg2d`: MMG2D (mmgpy, through `metric_peers.mmg2d`: Triangle's constrained triangulation of Ω
  as the start mesh, the input points required corners, re-run on its own output until the
  median metric edge length is ≤ 1.1, the scale h calibrated to the target N) with the metric
  H(x) = adj Q̃(x) / √det Q̃(x) / h² at its vertices — the shape of Q, as qmesh meshes it. Q̃ is
  Q averaged over the square of half-side `width` around the vertex (mirrored into Ω's box, as
  `qmesh.fields.metric.smoothed`): with a tiny width (the default for formulas, 1e-7 of Ω's
  extent) Q̃ is Q at the vertex, except at a singular point such as FVCA5 test 5's corner, where
  the samples take the limit from inside; a raster takes qmesh's own width (one element at the
  target N), since a vertex's single cell would give MMG white noise for a metric.
- `triangle`: Shewchuk's Triangle, isotropic (`pq30a`, the maximum area calibrated to the target
  N), as `media_peers.triangle`.
"""

from __future__ import annotations

import numpy as np

from qmesh.compare import media_peers, metric_peers
from qmesh.compare.peers import PeerMesh
from qmesh.conductivity.anisotropy import Anisotropy, adj2
from qmesh.domain.domain import as_domain
from qmesh.fields.metric import smoothed, smoothing_width

POINT_WIDTH = 1e-7
"""The averaging half-width, as a share of Ω's extent, that stands for Q at the point."""


def field_shape_metric(field, domain, width: float) -> Anisotropy:
    """The metric-only Anisotropy H = adj Q̃ / √det Q̃ (det H = 1) of `field` averaged over
    squares of half-side `width`."""
    domain = as_domain(domain)
    box = domain.bounds

    def hessian(P):
        A = adj2(smoothed(field, np.asarray(P, dtype=float), width, box))
        det = A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]
        return A / np.sqrt(det)[:, None, None]

    return Anisotropy.metric_only(hessian, f"shape of {getattr(field, 'label', 'Q')}")


def peer_width(field, domain, target_vertices: int) -> float:
    """The averaging half-width the MMG2D peer uses: qmesh's own for a raster, a point's else."""
    domain = as_domain(domain)
    if field.is_raster:
        return smoothing_width(domain, int(target_vertices), None)
    lo, hi = domain.bounds
    return POINT_WIDTH * float(np.max(np.asarray(hi) - np.asarray(lo)))


def mmg2d(domain, field, target_vertices: int, *, width: float | None = None,
          rtol: float = 0.03) -> PeerMesh:
    """MMG2D with the per-vertex shape metric of `field` (module docstring), N calibrated."""
    domain = as_domain(domain)
    w = peer_width(field, domain, target_vertices) if width is None else float(width)
    return metric_peers.mmg2d(domain, field_shape_metric(field, domain, w), int(target_vertices),
                              rtol=rtol)


def triangle(domain, target_vertices: int, *, rtol: float = 0.03) -> PeerMesh:
    """Isotropic Triangle (`pq30a`), the maximum area calibrated to the target N."""
    return media_peers.triangle(as_domain(domain), int(target_vertices), rtol=rtol)
