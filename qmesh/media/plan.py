"""Everything a medium's run decides before and between its faces: one sizing for all of them.

MEDIA.md §3: each region r is meshed in its metric ∇²s_r with its magnitude k_r divided out, so
one metric edge length h serves every face. N is shared between the faces by metric area through
the single-region mesher's own relation h ↔ N, each face counted with the points its interfaces
will hold and the grading toward them, less those two faces count twice (mesher/face_count.py).

A face thin or sharp in its own metric needs more vertices than its area says, so the faces
still to come are sized again before each face (`size_rest`; with thousands of faces, each time
a share of those left is done: `resize_due`), and the largest, meshed last, is
given the count that remains (`sizing_of`): the run lands on N without a second run.
"""

from __future__ import annotations

from collections.abc import Callable
from types import SimpleNamespace
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from qmesh.domain.domain import Domain
from qmesh.domain.junctions import check_junctions
from qmesh.domain.regions import conductivity_of_regions
from qmesh.errors import QmeshError
from qmesh.domain.faces import face_domain
from qmesh.mesher import sizing
from qmesh.mesher.components import Components
from qmesh.mesher.normalise import hessian_scales
from qmesh.mesher.plan import BOUNDARY_FACTOR
from qmesh.mesher.widths import thin_widths
from qmesh.mesher.face_meshes import FaceMeshes
from qmesh.mesher.face_count import SharedPoints, face_counter

RESIZE = 2.0     # the faces still to come are sized at most this factor away from the first h
COARSER = 64.0   # ... and at most this factor coarser (a target below what the faces need)
THIN_ASPECT = 8.0  # a face whose longest side is this many widths (in its metric) is thin
LEAST_SHARE = 0.5  # faces whose least count is this share of the target are sized by width at once
THIN = 0.25      # a face w wide in its metric needs boundary pieces about this many w long
TINY = 1e-5      # a face this small (× the domain's size) is meshed after the faces around it
SLACK = 0.03     # ... and only when the faces done so far put the run this share off its target
ROUND = 1e-6     # lengths this close count as equal (the face mesher measures them in its own frame)
WHOLE = 0.01     # shared pieces up to this share longer than a face's h are kept whole
NEAR = 1e-9      # lengths measured many at once are this close to one measured alone
SMALL = 200      # faces expected to take fewer triangles share a run where they can
EVERY = 64       # the faces left are sized again before each of the first EVERY faces, then
SHARE = 1 / 16   # ... once this share of the faces left is meshed (each sizing reads all of them)


class MediaPlan:
    """Per face: its anisotropy, scale k, metric area and segment lengths; the shared h; the
    interface cuts; and the order the faces are meshed in."""

    def __init__(self, domain: Any, conductivity: Any, target_vertices: int | None,
                 size: float | None) -> None:
        self.domain = domain
        self.part = part = domain.partition
        self.faces = part.faces
        self.corners = cKDTree(part.points)   # the partition's points, for every face (points_on_edges)
        self.extra: SharedPoints | None = None   # the interface points, once h is known
        cond = conductivity_of_regions(domain, conductivity)
        self.anis = [cond[f.region] for f in self.faces]
        if target_vertices is not None and target_vertices <= len(part.points):
            raise QmeshError(f"target_vertices = {target_vertices} must exceed the "
                             f"{len(part.points)} input points of the domain and its regions")
        bare = part.faces_rings(list(self.faces), {})       # every face's rings, as its Domain's
        self.k = hessian_scales(self.anis, bare.split(bare.points))
        self._H = np.array([a.H if a.is_constant else np.full((2, 2), np.nan) for a in self.anis])
        self.area, lengths = self._measures(bare)
        check_junctions(part, self.anis, self.face_name)
        # every face's segments, concatenated; each interface edge's segment on either side
        self._seg_len = np.concatenate(lengths)
        self._total = sum(self.area), sum(float(L.sum()) for L in lengths)   # area, boundary
        self._seg_face = np.repeat(np.arange(len(self.faces)), bare.face_sizes)
        seg_edge = bare.tags - 1
        self._inter = np.flatnonzero(part.interface)
        slot = np.full((len(part.edges), 2), -1)
        slot[seg_edge, (part.edge_faces[seg_edge, 1] == self._seg_face).astype(np.int64)] = \
            np.arange(len(seg_edge))
        self._side = slot[self._inter]
        self._seg_inter = np.full(len(seg_edge), -1)               # each segment's interface edge
        self._seg_inter[self._side] = np.arange(len(self._inter))[:, None]
        self.longest = self._seg_len[self._side].max(axis=1)        # in the longer side's metric
        longest = np.maximum.reduceat(self._seg_len, np.cumsum(bare.face_sizes) - bare.face_sizes)
        X, first = part.outer_corners()
        self.extent = (np.maximum.reduceat(X, first) - np.minimum.reduceat(X, first)).max(axis=1)
        width = thin_widths(X, first, self.anis, self.k, longest, THIN_ASPECT)
        w = np.where(THIN_ASPECT * width < longest, THIN * width, np.inf)
        self._thin_step = w[self._seg_face]
        self.target = target_vertices
        by_area = sorted(range(len(self.faces)), key=lambda i: self.area[i])
        # the largest last, given the count that remains (sizing_of); then the tiny faces, whose
        # edge points, closer together than a triangulation of the rest resolves, go into the
        # faces around them by insertion (insert_shared) instead of into those faces' runs
        tiny = self.extent <= TINY * domain.diameter
        self.order = [i for i in by_area if not tiny[i]] + [i for i in by_area if tiny[i]]
        self.last = self.order[int(np.count_nonzero(~tiny)) - 1] if not tiny.all() else by_area[-1]
        self.thin = False          # sized with the faces' widths from the start
        if target_vertices is not None:
            # a least count over LEAST_SHARE of the target: thin from the first face on
            huge = 10.0 * (np.sqrt(self._total[0]) + self._total[1])
            self.thin = self.counter(self.order, thin=True)(huge) > LEAST_SHARE * target_vertices
            self.h = self.h_euler = self._size_for(self.order, target_vertices)
            if self.thin:      # no coarser than COARSER × Euler's h (a target below the least)
                self.h = min(self._size_for(self.order, target_vertices, True), COARSER * self.h)
        else:
            self.h = self.h_euler = float(size) if size is not None else float(np.mean(self._seg_len))
            asked = (f"size = {self.h:.3g}" if size is not None
                     else f"the default size (the mean edge length in the metrics, {self.h:.3g})")
            sizing.check_vertex_count(self.counter(self.order)(self.h), asked)
        self.h_rest = self.h
        self._sized_at = 0         # the face before which the faces left were last sized
        # interface edges cut evenly into pieces ≤ h in both sides' metrics (the others: by their face)
        self.extra = SharedPoints(part.even_cuts(self._inter, np.ceil(self.longest / (BOUNDARY_FACTOR * self.h))),
                                  len(part.edges))

    def _measures(self, bare: Any) -> tuple[np.ndarray, list]:
        """Each face's metric area and its segments' metric lengths, as from its Domain (a face
        the partition's rings do not make one alone, or of a varying s, builds it); a constant
        Q's factor taken once per Anisotropy (the area of a unit domain: 1 × it, exactly)."""
        areas = Domain.checked_areas(bare.split(bare.points, bare.ring_sizes), bare.face_rings)
        unit, area = {}, []
        for i, (a, k, m) in enumerate(zip(self.anis, self.k, areas)):
            if m is None or not bare.simple[i] or not a.is_constant:
                area.append(sizing.metric_area_scaled(face_domain(self.part, self.faces[i], {},
                                                                  self.face_name(i)), a, k))
                continue
            if (id(a), k) not in unit:
                unit[id(a), k] = sizing.metric_area_scaled(SimpleNamespace(area=1.0), a, k)
            area.append(m * unit[id(a), k])
        return np.array(area), self._lengths(bare)

    def _lengths(self, bare: Any) -> list:
        """Each face's segment lengths in its metric, faces of one constant Q, scale and segment
        count measured together (the bits of a call per face: `sizing.stacked_segment_lengths`)."""
        A, B = bare.segment_ends()
        first, n = np.cumsum(bare.face_sizes) - bare.face_sizes, bare.face_sizes
        alike: dict[tuple, list[int]] = {}
        for i, (a, k, m) in enumerate(zip(self.anis, self.k, n.tolist())):
            alike.setdefault((id(a), k, m) if a.is_constant else (i,), []).append(i)
        out: dict[int, np.ndarray] = {}
        for f in alike.values():
            at = first[f][:, None] + np.arange(n[f[0]])
            out.update(zip(f, sizing.stacked_segment_lengths(A[at], B[at], self.anis[f[0]], self.k[f[0]])))
        return [out[i] for i in range(len(self.faces))]

    def face_name(self, i: int) -> str:
        r, names = self.faces[i].region, self.domain.region_names
        return f"region {r}" + (f" ({names[r]})" if r in names else "")

    def too_small(self, i: int) -> QmeshError | None:
        """Why face i could not be meshed when it, or a face beside it, is tiny (TINY × the domain's
        size or less): the points its metric needs on its edges come closer than round-off allows
        beside the face around it. None otherwise."""
        D, ef = self.domain.diameter, self.part.edge_faces
        near = [i] + [int(f) for f in ef[(ef == i).any(axis=1)].ravel() if f >= 0]
        j = min(near, key=lambda f: self.extent[f])
        if (x := self.extent[j]) > TINY * D:
            return None
        where = "" if j == i else f", and {self.face_name(i)} around it cannot be meshed"
        return QmeshError(f"{self.face_name(j)} is {x:.3g} across, {x / D:.2g} × the domain's size{where}: "
                          "the points its metric needs on its edges come closer together than floating "
                          "point resolves beside the rest of the domain; enlarge it, or leave it out "
                          "(give that area its neighbour's conductivity)")

    def counter(self, faces: list, thin: bool = False) -> Callable[[float], float]:
        """The vertices the faces `faces` add at metric edge length h, as a function of h
        (`face_count.face_counter`); what h does not change taken once (a bisection calls it a
        hundred times), from their segments, the interface edges they touch and the points there."""
        mine = np.zeros(len(self.faces), bool)
        mine[faces] = True
        seg = mine[self._seg_face]                                 # the faces' segments
        ef = self.part.edge_faces[self._inter]
        touch = mine[ef[:, 0]] | mine[ef[:, 1]]                   # interface edges they touch
        iface = np.append(np.cumsum(touch) - 1, -1)[self._seg_inter[seg]]   # -1: none
        known = self.extra.pieces[self._inter[touch]] if self.extra is not None else 1
        return face_counter(self.area[mine], (np.cumsum(mine) - 1)[self._seg_face[seg]], self._seg_len[seg],
                            self._thin_step[seg], iface, self._seg_len[self._side[touch]],
                            self._thin_step[self._side[touch]], known, mine[ef[touch]].all(axis=1),
                            BOUNDARY_FACTOR, thin)

    def _size_for(self, faces: list, n: float, thin: bool = False) -> float:
        return sizing.size_for_count(self.counter(faces, thin), n, *self._total, steps=100)

    def resize_due(self, at: int) -> bool:
        """Whether the faces left are to be sized again before the at-th face: before each of
        the first EVERY, then each time SHARE of the faces then left is done (a sizing per face
        made thousands of cells quadratic; a medium of up to EVERY faces is sized as before)."""
        if at > EVERY and at - self._sized_at < SHARE * (len(self.order) - at):
            return False
        self._sized_at = at
        return True

    def size_rest(self, rest: list, n_done: int) -> None:
        """Size the faces `rest` still to mesh for what the target leaves after `n_done`
        vertices, when the run is more than SLACK off course (a target near the faces' own
        minimum needs the coarsest h); without a target the size stays."""
        if self.target is None or not rest:
            return
        if abs(n_done + self.counter(rest, self.thin)(self.h_rest) - self.target) > SLACK * self.target:
            h = self._size_for(rest, self.target - n_done, self.thin)
            self.h_rest = float(np.clip(h, self.h / RESIZE, self.h * RESIZE))
        # the faces left cannot fit what the target leaves even at their least (thin faces): the
        # coarsest h for them, up to COARSER, so N ends near the faces' own minimum
        if n_done + self.counter(rest, thin=True)(self.h_euler * COARSER) > (1 + SLACK) * self.target:
            h = self._size_for(rest, self.target - n_done, thin=True)
            self.h_rest = float(np.clip(h, self.h_rest, self.h_euler * COARSER))

    def sizing_of(self, i: int, dom: Any, meshes: FaceMeshes) -> dict:
        """The face mesher's sizing of face i: `size` h·√k_r (h in the user's metric ∇²s_r), or for
        the last face the count that lands the run on target_vertices when it leaves room; when h
        is a hair shorter than its interface pieces (it would split each in two), their size."""
        a, k, L = self.anis[i], self.k[i], sizing.metric_edge_lengths(dom, self.anis[i], self.k[i])
        n = 0
        if self.target is not None and i == self.last and (meshes or i != self.order[-1]):
            n = self.target - meshes.vertex_count(dom.seeds) + len(dom.seeds)
        count = n > len(dom.seeds)
        h = sizing.size_for_vertices(sizing.metric_area_scaled(dom, a, k), L, n, BOUNDARY_FACTOR) if count else self.h_rest
        cut = float(L[self.part.interface[dom.segment_tags - 1]].max(initial=0)) / BOUNDARY_FACTOR
        if h * (1 - ROUND) <= cut <= h * (1 + WHOLE):
            return {"size": cut * (1 + ROUND) * np.sqrt(k)}
        return {"target_vertices": n} if count else {"size": h * np.sqrt(k)}

    def small(self, faces: Any, alone: set, like: int) -> np.ndarray:
        """Which `faces` may share a run with face `like`: expected to take fewer than SMALL
        triangles, of its constant Q, and not failed in a group before (`alone`)."""
        f = np.asarray(faces, np.int64)
        return ((self._H[f] == self._H[like]).all(axis=(1, 2)) & ~np.isin(f, list(alone))
                & (self.area[f] / sizing.equilateral_area(self.h_rest) < SMALL))

    def same_sizing(self, faces: np.ndarray, rings: Any, first: dict, meshes: FaceMeshes) -> np.ndarray:
        """Which `faces` (their `rings`, one constant Q, not the last face) `sizing_of` sizes as
        `first`: their lengths measured at once, and a face whose interface pieces come near h
        (within round-off of sizing_of's thresholds) measured alone, as sizing_of measures it."""
        A, B = rings.segment_ends()
        L = sizing.segment_lengths(A, B, self.anis[faces[0]], self.k[faces[0]])
        L = np.where(self.part.interface[rings.tags - 1], L, 0.0)
        cut = np.maximum.reduceat(L, np.cumsum(rings.face_sizes) - rings.face_sizes) / BOUNDARY_FACTOR
        h, k = self.h_rest, np.asarray(self.k)[faces]
        out = h * np.sqrt(k) == first["size"] if "size" in first else np.zeros(len(faces), bool)
        near = np.flatnonzero((cut >= h * (1 - ROUND) * (1 - NEAR)) & (cut <= h * (1 + WHOLE) * (1 + NEAR)))
        for j in near.tolist():
            R, T = rings.face(j)
            out[j] = self.sizing_of(int(faces[j]), Components(R, [T], [len(T)]), meshes) == first
        return out
