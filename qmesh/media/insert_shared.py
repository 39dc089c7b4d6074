"""Points a neighbour put on an interface, inserted into a finished face mesh without re-meshing.

MEDIA.md §2: an interface edge needs the same vertices on both sides. When a face mesher splits
an interface subsegment (to keep q_ij ≥ 0 in its own metric), the face on the other side,
already meshed, gets the point by splitting its boundary edge there (topology.split_boundary_edges)
and restoring the Q-Delaunay property by flips in its own metric (triangulate.restore). No
point is added, so the exchange ends after one pass; and q_ij ≥ 0 is kept: interior edges are
locally Q-Delaunay again after the flips, and a piece a–p of a boundary edge a–b that no vertex
encroached is not encroached either (its diametral ellipse lies inside a–b's, GEOMETRY.md §1),
so the apex of each piece lies outside its ellipse and its q_ij ≥ 0.
"""

from __future__ import annotations

import numpy as np

from scipy.spatial import cKDTree

from qmesh.geometry import topology
from qmesh.triangle_mesh import Mesh
from qmesh.mesher.triangulate import restore


MAX_SPLITS = 200     # shell splits of encroached boundary edges after one insertion


def insert_on_boundary(mesh: Mesh, anisotropy, points: dict, part):
    """`mesh` with `points` {partition edge: (k, 2)} inserted on its boundary edges of that
    edge (boundary tag = partition edge + 1; points it already has are skipped), and the points
    it then had to add on interface edges of the partition `part`, {edge: (k, 2)}, for the
    neighbours.

    A point put next to a corner may encroach the boundary edge on the corner's other side
    (a small angle in this face's metric); that edge is split at the encroaching vertex's metric
    distance from the corner (the end of its partition edge nearer the vertex): a concentric
    shell (Ruppert 1995), so the two pieces at the corner are alike and neither is encroached.
    """
    tol = 1e-12 * float(np.ptp(mesh.points, axis=0).max())
    tree = cKDTree(mesh.points)
    todo = [(int(e), x) for e, X in points.items() for x in np.asarray(X)
            if not tree.query_ball_point(x, tol)]
    if not todo:
        return mesh, {}
    st = _State(mesh)
    while todo:
        todo = st.split(todo)
    st.restore(anisotropy)
    added = {}
    for _ in range(MAX_SPLITS):
        splits = st.encroached(anisotropy, part)
        if not splits:
            break
        st.split(splits)
        st.restore(anisotropy)
        for e, x in splits:
            if part.interface[e]:
                added.setdefault(e, []).append(x)
    else:
        raise ValueError("boundary edges stay encroached after "
                         f"{MAX_SPLITS} splits next to an inserted interface point")
    return st.mesh(mesh), {e: np.array(X) for e, X in added.items()}


class _State:
    """P, T, twin and the partition edge of every boundary half-edge, edited in place."""

    def __init__(self, mesh):
        self.P = np.array(mesh.points)
        self.T = np.array(mesh.triangles)
        self.twin = topology.twins(self.T)
        self.tag = {(int(a), int(b)): int(t) for (a, b), t in zip(mesh.boundary_edges,
                                                                   mesh.boundary_tags)}

    def boundary(self):
        hb = np.flatnonzero(self.twin < 0)
        t, k = np.divmod(hb, 3)
        return hb, t, self.T[t, k], self.T[t, topology.NXT[k]], self.T[t, topology.PRV[k]]

    def split(self, todo):
        """Split boundary edges at the points (edge, x) given, one per triangle; the rest is
        returned for the next batch."""
        hb, t, u, v, _ = self.boundary()
        hb_tag = np.array([self.tag[(int(a), int(b))] for a, b in zip(u, v)])
        chosen, rest, used = [], [], set()
        scale = float(np.ptp(self.P, axis=0).max())
        for e, x in todo:
            if np.min(np.hypot(*(self.P - x).T)) <= 1e-12 * scale:
                continue                      # already a vertex (given twice, or a corner)
            on = np.flatnonzero(hb_tag == e + 1)
            a, b = self.P[u[on]], self.P[v[on]]
            ab = b - a
            s = np.einsum("ij,ij->i", x - a, ab) / np.einsum("ij,ij->i", ab, ab)
            inside = (s > 0) & (s < 1)
            if not inside.any():
                raise ValueError(f"no boundary edge of the face holds {np.asarray(x).tolist()}")
            i = int(on[inside][np.argmin(np.abs(s[inside] - 0.5))])
            if t[i] in used:
                rest.append((e, x))
                continue
            used.add(t[i])
            chosen.append((i, x))
        p = len(self.P) + np.arange(len(chosen))
        for (i, _), q in zip(chosen, p):
            a, b = int(u[i]), int(v[i])
            e1 = self.tag.pop((a, b))
            self.tag[(a, int(q))] = self.tag[(int(q), b)] = e1
        self.P = np.concatenate([self.P, np.array([x for _, x in chosen]).reshape(-1, 2)])
        self.T, self.twin = topology.split_boundary_edges(
            self.T, self.twin, np.array([hb[i] for i, _ in chosen], np.int64), p)
        return rest

    def restore(self, anisotropy):
        self.T, self.twin, _ = restore(self.P, self.T, self.twin, anisotropy)   # own metric

    def encroached(self, anisotropy, part, tol=1e-12):
        """(edge, split point) for every boundary edge whose apex sees it at more than 90° in
        the metric (q_ij < 0): on the partition edge, at the apex's metric distance from the
        edge's end nearer the apex when that falls inside the piece, else its midpoint."""
        _, t, u, v, w = self.boundary()
        a, b, c = self.P[u], self.P[v], self.P[w]
        H = (np.broadcast_to(anisotropy.H, (len(t), 2, 2)) if anisotropy.is_constant else
             np.asarray(anisotropy.hessian((a + b + c) / 3), dtype=float))
        ca, cb = a - c, b - c

        def norm(x, Hx):
            return float(np.sqrt(x @ Hx @ x))
        dot = np.einsum("ni,nij,nj->n", ca, H, cb)
        lens = np.sqrt(np.einsum("ni,nij,nj->n", ca, H, ca) * np.einsum("ni,nij,nj->n", cb, H, cb))
        out = []
        for i in np.flatnonzero(dot < -tol * lens):
            e = self.tag[(int(u[i]), int(v[i]))] - 1
            p0, p1 = part.points[part.edges[e]]
            d0, d1 = norm(c[i] - p0, H[i]), norm(c[i] - p1, H[i])
            corner, far, r = (p0, p1, d0) if d0 <= d1 else (p1, p0, d1)
            L = norm(far - corner, H[i])
            x = corner + (r / L) * (far - corner)
            ta = norm(a[i] - corner, H[i]) / L
            tb = norm(b[i] - corner, H[i]) / L
            lo, hi = min(ta, tb), max(ta, tb)
            if not lo + 1e-9 < r / L < hi - 1e-9:
                x = 0.5 * (a[i] + b[i])
            out.append((e, x))
        return out

    def mesh(self, old: Mesh) -> Mesh:
        hb, t, u, v, _ = self.boundary()
        E = np.column_stack([u, v])
        tags = np.array([self.tag[(int(a), int(b))] for a, b in E], np.int64)
        fixed = np.concatenate([old.fixed, np.zeros(len(self.P) - old.n_vertices, bool)])
        return Mesh(self.P, self.T, fixed, E, tags, old.tag_names)
