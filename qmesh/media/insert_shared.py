"""Points a neighbour put on an interface, inserted into a finished face mesh without re-meshing.

MEDIA.md §2. A point a face mesher split into an interface subsegment goes into the finished face
across it: its boundary edge is split there, flips restore the Q-Delaunay property in that face's
metric, and a boundary edge the point then encroaches (a small metric angle at a corner) is split
as the mesher splits its own, the points landing on an interface going on in turn. So every share
of q_ij in this face stays ≥ 0.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from qmesh.domain.junctions import crowded_junction
from qmesh.errors import QmeshError
from qmesh.geometry import topology
from qmesh.geometry.portable import dot2
from qmesh.mesher.conform import beside_corners, encroached, marked, split_points
from qmesh.mesher.corners import mirrored_in_face
from qmesh.mesher.triangulate import restore
from qmesh.triangle_mesh import Mesh

MAX_SPLITS = 200     # rounds of splits of encroached boundary edges after one insertion


def insert_on_boundary(mesh: Mesh, anisotropy, points: dict, part) -> tuple[Mesh, dict]:
    """`mesh` (a face mesh, boundary tag = partition edge + 1) with `points` {partition edge:
    (k, 2)} inserted on its boundary edges of that edge (points it has already are skipped),
    and the points it then had to add on interface edges of `part`, {edge: (k, 2)}."""
    edge = np.concatenate([np.full(len(X), e, np.int64) for e, X in points.items()])
    X = np.concatenate([np.asarray(X, float).reshape(-1, 2) for X in points.values()])
    new = cKDTree(mesh.points).query(X)[0] > 1e-12 * float(np.ptp(mesh.points, axis=0).max())
    if not new.any():
        return mesh, {}
    P, T, fixed = np.array(mesh.points), np.array(mesh.triangles), np.array(mesh.fixed)
    twin = topology.twins(T)
    out = np.full(len(P), -1, np.int64)       # partition edge of each vertex's outgoing boundary edge
    out[mesh.boundary_edges[:, 0]] = mesh.boundary_tags - 1
    X, edge = X[new], edge[new]
    while len(X):                             # at most one split per triangle at a time
        hb = _holding(P, T, twin, out, part, X, edge)
        first = np.unique(hb // 3, return_index=True)[1]
        P, T, twin, out, fixed = _split(P, T, twin, out, fixed, hb[first], X[first])
        X, edge = np.delete(X, first, axis=0), np.delete(edge, first)
    T, twin, _ = restore(P, T, twin, anisotropy)                  # its own metric
    corners = part.points[np.bincount(part.edges.ravel(), minlength=len(part.points)) >= 3]
    at_part = marked(P, part.points)
    on_edge, added = [np.zeros(0, np.int64)], [np.zeros((0, 2))]  # split points, their edges
    for _ in range(MAX_SPLITS):
        hb = np.flatnonzero(twin < 0)
        t, k = np.divmod(hb, 3)
        u, v, w = T[t, k], T[t, topology.NXT[k]], T[t, topology.PRV[k]]
        bad = np.flatnonzero(encroached(P[u], P[v], P[w], anisotropy))
        if not len(bad):
            break
        first = bad[np.unique(t[bad], return_index=True)[1]]
        x = split_points(P[u[first]], P[v[first]], fixed[u[first]], fixed[v[first]], anisotropy)
        x = beside_corners(x, P, u[first], v[first], w[first], marked(P, corners), anisotropy)
        at_part = np.concatenate([at_part, np.zeros(len(P) - len(at_part), bool)])
        x = mirrored_in_face(P, u[first], v[first], w[first], out, at_part, part, anisotropy, x)
        crowded_junction(x, P[u[first]], P[v[first]], corners, float(np.ptp(P, axis=0).max()))
        on_edge.append(out[u[first]])
        added.append(x)
        P, T, twin, out, fixed = _split(P, T, twin, out, fixed, hb[first], x)
        T, twin, _ = restore(P, T, twin, anisotropy)
    else:
        raise QmeshError("boundary edges stay encroached after "
                         f"{MAX_SPLITS} splits next to an inserted interface point")
    face = Mesh(P, T, fixed, np.column_stack([u, v]), out[u] + 1, mesh.tag_names)   # its boundary
    e, x = np.concatenate(on_edge), np.concatenate(added)
    keep = part.interface[e]
    return face, {int(k): x[keep & (e == k)] for k in np.unique(e[keep])}


def _holding(P, T, twin, out, part, X, edge) -> np.ndarray:
    """For each point X[i] on partition edge edge[i], the boundary half-edge that holds it."""
    hb = np.flatnonzero(twin < 0)
    u, v = T[hb // 3, hb % 3], T[hb // 3, topology.NXT[hb % 3]]
    found = np.full(len(X), -1, np.int64)
    for e in np.unique(edge):                  # one pass per partition edge touched
        a, b = part.points[part.edges[e]]
        d = (b - a) / float(dot2(b - a, b - a))
        on = np.flatnonzero(out[u] == e)
        su, sv = dot2(P[u[on]] - a, d), dot2(P[v[on]] - a, d)
        order = np.argsort(np.minimum(su, sv))
        lo, hi = np.minimum(su, sv)[order], np.maximum(su, sv)[order]
        mine = np.flatnonzero(edge == e)
        s = dot2(X[mine] - a, d)
        j = np.searchsorted(lo, s) - 1
        ok = (j >= 0) & (s < hi[np.maximum(j, 0)])
        if not ok.all():
            x = X[mine[~ok][0]].tolist()
            raise QmeshError(f"no boundary edge of the face holds the interface point {x}")
        found[mine] = hb[on[order[j]]]
    return found


def _split(P, T, twin, out, fixed, hb, x):
    """Boundary half-edges hb (one per triangle) split at points x; the new vertices continue
    the partition edge of the half-edge they split."""
    n, u = len(P), T[hb // 3, hb % 3]
    T, twin = topology.split_boundary_edges(T, twin, hb, n + np.arange(len(hb)))
    return (np.concatenate([P, x]), T, twin, np.concatenate([out, out[u]]),
            np.concatenate([fixed, np.zeros(len(hb), bool)]))
