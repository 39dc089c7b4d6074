"""The mutable arrays of one run of Algorithm 2.1, in normalised coordinates.

Every stage changes the state only through these methods, so the arrays that travel together
(points, their fixed / pinned flags and the segment each boundary vertex slides on; triangles
and their half-edge twins) always grow and shrink together. A `Step` gets a read-only
snapshot in the user's coordinates, sharing the arrays that did not change since the last one.
"""

from __future__ import annotations

import numpy as np

from qmesh.geometry import topology
from qmesh.triangle_mesh import Mesh, frozen
from qmesh.mesher.step import Stats


class State:
    """Points `P`, triangles `T` with half-edge `twin`s, and per point: `fixed` (an input point),
    `pinned` (a boundary point that does not slide), `edge_id` (the segment a boundary point
    slides on, else -1)."""

    def __init__(self, norm, built):
        self.norm = norm
        self.domain, self.anisotropy = norm.domain, norm.anisotropy
        self.P, self.T, self.twin, self.edge_id = built.P, built.T, built.twin, built.edge_id
        self.fixed = np.zeros(len(self.P), bool)
        self.fixed[:len(self.domain.seeds)] = True
        self.pinned = built.pinned
        self._seen_P = self._seen_T = None
        self.mesh = self.snapshot()

    # ------------------------------------------------------------------ what the stages read

    def tangents(self) -> np.ndarray:
        """Unit tangent of the segment each sliding vertex lies on; 0 for the others."""
        _, tan = self.domain.edges
        t = np.zeros_like(self.P)
        on = self.edge_id >= 0
        t[on] = tan[self.edge_id[on]]
        t[self.fixed | self.pinned] = 0.0
        return t

    def on_boundary(self) -> np.ndarray:
        """Boundary vertices: the seeds and the vertices sliding on the segments."""
        return self.fixed | (self.edge_id >= 0)

    def corner_edge(self) -> np.ndarray:
        """Segment that starts at each boundary vertex (seed k starts segment k)."""
        ce = self.edge_id.copy()
        ce[self.fixed] = np.flatnonzero(self.fixed)
        return ce

    # ------------------------------------------------------------------ how the stages change it

    def move(self, P: np.ndarray) -> None:
        """New positions, same connectivity (the adjust stage)."""
        self.P = P
        self.mesh = self.snapshot()

    def join_boundary(self, snap) -> None:
        """Vertices that crossed the boundary now slide on the segment they crossed; the
        triangles between them and the boundary are gone (`boundary.snap_to_boundary`)."""
        self.T, self.twin = snap.T, snap.twin
        self.edge_id = self.edge_id.copy()
        self.edge_id[snap.vertices] = snap.edge_id

    def relocate(self, T: np.ndarray, twin: np.ndarray, P: np.ndarray) -> None:
        """Vertices moved to other triangles with the connectivity that goes with it."""
        self.P, self.T, self.twin = P, T, twin

    def add(self, T: np.ndarray, twin: np.ndarray, points: np.ndarray, edge_id: np.ndarray) -> None:
        """New free points (interior, or sliding on segment `edge_id`) and the triangulation
        that includes them."""
        k = len(points)
        self.T, self.twin = T, twin
        if k:
            self.P = np.concatenate([self.P, points])
            self.fixed = np.concatenate([self.fixed, np.zeros(k, bool)])
            self.pinned = np.concatenate([self.pinned, np.zeros(k, bool)])
            self.edge_id = np.concatenate([self.edge_id, edge_id])
        self.mesh = self.snapshot()

    def retriangulate(self, T: np.ndarray, twin: np.ndarray) -> None:
        """Same points, new connectivity (edge flips)."""
        self.T, self.twin = T, twin

    def conform(self, c) -> None:
        """The state after `conform.restore_conformity`: points pushed out of diametral ellipses,
        subsegments split."""
        self.P, self.T, self.twin = c.P, c.T, c.twin
        self.edge_id, self.fixed, self.pinned = c.edge_id, c.fixed, c.pinned
        self.mesh = self.snapshot()

    # ------------------------------------------------------------------ what a Step gets

    def snapshot(self) -> Mesh:
        """The current mesh in the user's coordinates, with its tagged boundary edges; arrays
        that did not change since the last snapshot are shared with it."""
        if self.P is not self._seen_P:
            self._user_P, self._seen_P = frozen(self.norm.to_user(self.P), np.float64), self.P
        if self.T is not self._seen_T:
            hb = np.flatnonzero(self.twin < 0)
            t, e = np.divmod(hb, 3)
            a = self.T[t, e]
            self._edges = frozen(np.column_stack([a, self.T[t, topology.NXT[e]]]), np.int64)
            self._tags = frozen(self.domain.segment_tags[self.corner_edge()[a]], np.int64)
            self._user_T, self._seen_T = frozen(self.T, np.int64), self.T
        return Mesh(self._user_P, self._user_T, self.fixed, self._edges, self._tags,
                    self.domain.tag_names)

    def stats(self, **extra) -> Stats:
        return Stats(self.mesh.n_vertices, self.mesh.n_triangles,
                     source=(self.mesh, self.norm.user_anisotropy), **extra)
