"""Interior vertices that the adjustment sends out of the domain go onto the boundary.

Chapter Section 2.3.2: "any vertices sent outside the domain by the vertex adjustment step are
projected back to the domain boundary, where they are allowed to move … along the boundary".
The energy E keeps pulling a vertex that sits next to a long boundary edge towards that edge;
held inside, it would end as a sliver. So when the relaxed step of an interior vertex v crosses
the boundary edge (a, b) of its own triangle (a, b, v), v is projected onto (a, b), the triangle
(a, b, v) is removed, and v becomes a sliding boundary vertex between a and b. A projection that
would land too close to a or b, or squash another triangle of v's star, is not made. A vertex
that stays inside but would leave (a, b, v) a sliver goes onto (a, b) too: the vertex step alone
can hold it there, a hair's breadth from the edge.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from qmesh.geometry import topology
from qmesh.mesher.adjust import MIN_AREA_KEPT
from qmesh.geometry.triangles import metric_hessians, metric_quality, signed_areas
from qmesh.mesher.conform import encroached

END_MARGIN = 0.02   # the projection must not fall on an end of the boundary edge
SLIVER = 0.2        # a boundary triangle below this metric quality hands its apex to the boundary


@dataclass
class Snap:
    T: np.ndarray
    twin: np.ndarray
    vertices: np.ndarray    # the vertices now on the boundary
    positions: np.ndarray   # their positions on it
    edge_id: np.ndarray     # their polygon edge


def _boundary_triangles(T, twin):
    """Each boundary half-edge a→b with the apex v of its triangle."""
    bh = np.flatnonzero(twin < 0)
    t, e = np.divmod(bh, 3)
    return t, T[t, e], T[t, topology.NXT[e]], T[t, topology.PRV[e]]


def _quality(P, a, b, v, anisotropy) -> np.ndarray:
    tri = np.column_stack([a, b, v])
    return metric_quality(P, tri, metric_hessians(anisotropy, P, tri))


def _slivers(P, d, a, b, v, anisotropy) -> np.ndarray:
    """Whether the triangles (a, b, v) would have metric quality below SLIVER after the move d."""
    return _quality(P + d, a, b, v, anisotropy) < SLIVER


def hold_off_boundary(P, T, twin, d, on_boundary, anisotropy) -> np.ndarray:
    """d with the moves of interior vertices that would flatten their boundary triangle (to a
    metric quality below SLIVER, and lower than now) undone.

    Used when no vertex may join the boundary (boundary_refinement=False): the energy would
    otherwise press such a vertex ever closer to a long boundary edge between seeds.
    """
    _, a, b, v = _boundary_triangles(T, twin)
    after = _quality(P + d, a, b, v, anisotropy)
    stop = ~on_boundary[v] & (after < SLIVER) & (after < _quality(P, a, b, v, anisotropy))
    d = d.copy()
    d[v[stop]] = 0.0
    return d


def hold_out_of_ellipses(P, T, twin, d, on_boundary, anisotropy) -> np.ndarray:
    """d with the moves of interior vertices undone where they would carry the vertex into the
    diametral ellipse of the boundary edge it faces (GEOMETRY.md §1).

    The triangulate stage would push such a vertex back out (conform.py) and the next vertex
    step pull it in again, for ever; holding it keeps the boundary q_ij ≥ 0 without that cycle.
    """
    _, a, b, v = _boundary_triangles(T, twin)
    inner = ~on_boundary[v]
    a, b, v = a[inner], b[inner], v[inner]
    Pn = P + d
    into = encroached(Pn[a], Pn[b], Pn[v], anisotropy) & ~encroached(P[a], P[b], P[v], anisotropy)
    d = d.copy()
    d[v[into]] = 0.0
    return d


def snap_to_boundary(P, T, twin, d, on_boundary, corner_edge, anisotropy) -> Snap:
    """Project interior vertices whose move `d` leaves the domain onto the boundary edge crossed.

    A vertex whose move keeps it inside but so close to the edge that its boundary triangle
    would be a sliver (metric quality below SLIVER) joins the boundary the same way.
    """
    t, a, b, v = _boundary_triangles(T, twin)
    ok = ~on_boundary[v]
    ab = P[b] - P[a]
    L2 = np.einsum("ki,ki->k", ab, ab)
    now, dv = P[v] - P[a], d[v]
    inside_now = ab[:, 0] * now[:, 1] - ab[:, 1] * now[:, 0]     # > 0: v is inside, left of ab
    inside_then = inside_now + ab[:, 0] * dv[:, 1] - ab[:, 1] * dv[:, 0]
    crosses = inside_then < 0
    # where the move leaves the domain through ab; a sliver apex goes to its projection
    frac = np.where(crosses, inside_now / np.where(crosses, inside_now - inside_then, 1.0), 1.0)
    par = np.einsum("ki,ki->k", now + frac[:, None] * dv, ab) / L2
    sliver = _slivers(P, d, a, b, v, anisotropy)
    ok &= (crosses | sliver) & (par > END_MARGIN) & (par < 1 - END_MARGIN)
    # one boundary edge per vertex: the first listed
    idx = np.flatnonzero(ok)
    _, first = np.unique(v[idx], return_index=True)
    idx = idx[first]
    pos = P[a[idx]] + par[idx, None] * ab[idx]

    # no other triangle of a projected vertex may be squashed (all projections together)
    moving = np.zeros(len(P), bool)
    moving[v[idx]] = True
    near = np.flatnonzero(topology.touching(T, moving))
    near = near[~np.isin(near, t[idx])]
    Pn = P.copy()
    Pn[v[idx]] = pos
    squashed = signed_areas(Pn, T[near]) < MIN_AREA_KEPT * signed_areas(P, T[near])
    bad_v = np.zeros(len(P), bool)
    bad_v[T[near[squashed]].ravel()] = True
    idx = idx[~bad_v[v[idx]]]
    pos = P[a[idx]] + par[idx, None] * ab[idx]

    T, twin = topology.remove_triangles(T, twin, t[idx])
    return Snap(T, twin, v[idx], pos, corner_edge[a[idx]])
