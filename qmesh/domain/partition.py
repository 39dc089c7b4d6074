"""Ω cut into faces by its regions: the planar arrangement of every ring, and each face's region.

MEDIA.md §2–3: an interface is a boundary segment seen from both sides. The outline, the holes
and every region's rings (a region may have holes of its own) are merged into one planar
graph: points closer than `TOUCH` × the domain's size are one vertex, a point lying on another
ring's segment splits that segment (so shared edges need not be split alike on both sides),
identical segments are one edge. Two segments that still cross are an error naming both.
The faces of the graph come from the usual half-edge walk (next = the first outgoing edge
clockwise from the twin), a component's outer (clockwise) cycle becomes a hole of the smallest
face of another component around it. Each half-edge knows what lies on its left (region k,
inside Ω, outside Ω) from the rings it came from; a face's region is what its half-edges say,
and a face whose half-edges disagree is an overlap, a region leaving Ω or crossing a hole.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from itertools import chain

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from qmesh.errors import QmeshError
from qmesh.geometry import rings as _rings
from qmesh.geometry.portable import arctan2

TOUCH = 1e-9        # points this close (× the domain's size) are one vertex / lie on a segment
OUTSIDE = -2        # left label: outside Ω
INSIDE = -1         # left label: inside Ω, region not said


@dataclass(frozen=True)
class Ring:
    """One input ring, oriented with its side on the left: `owner` 0 for Ω's rings (outline and
    holes), k ≥ 1 for region k's; `name` says which for error messages."""
    points: np.ndarray
    owner: int
    name: str


@dataclass(frozen=True)
class Face:
    """A face of the arrangement: its outer cycle (counter-clockwise) and hole cycles
    (clockwise), each a list of half-edge indices, and its region tag."""
    cycles: tuple
    region: int


@dataclass(frozen=True)
class FaceRings:
    """Rings of several faces, concatenated face after face (outer cycle first)."""
    points: np.ndarray        # (n, 2) the rings' points, extra points inserted
    tags: np.ndarray          # (n,) segment tags: partition edge + 1 (segment i starts at point i)
    ring_sizes: np.ndarray    # points of every ring
    face_sizes: np.ndarray    # points of every face
    face_rings: np.ndarray    # rings of every face
    simple: np.ndarray        # per face: no vertex met twice (a pinch)

    def split(self, X: np.ndarray, sizes: np.ndarray | None = None) -> list:
        """X (one row per point) cut face by face, or by `sizes`."""
        sizes = self.face_sizes if sizes is None else sizes
        return np.split(X, np.cumsum(sizes)[:-1])

    def face(self, j: int) -> tuple[list, np.ndarray]:
        """The rings of the j-th face and its segment tags."""
        r, p = np.cumsum(self.face_rings) - self.face_rings, np.cumsum(self.face_sizes) - self.face_sizes
        sizes = self.ring_sizes[r[j]:r[j] + self.face_rings[j]]
        return self.split(self.points[p[j]:p[j] + self.face_sizes[j]], sizes), self.tags[p[j]:p[j] + self.face_sizes[j]]

    def touching(self, before: np.ndarray) -> np.ndarray:
        """Per face: whether it has a point (bit for bit) of `before` or of a face before it."""
        lab = np.repeat(np.arange(len(self.face_sizes) + 1), np.append(len(before), self.face_sizes))
        X = np.concatenate([before, self.points])
        o = np.lexsort((lab, X[:, 1], X[:, 0]))
        X, lab = X[o], lab[o]
        new = np.ones(len(X), bool)
        new[1:] = (X[1:] != X[:-1]).any(axis=1)
        low = lab[new][np.cumsum(new) - 1]                  # the first face holding each point
        hit = np.zeros(len(self.face_sizes) + 1, bool)
        hit[lab[low < lab]] = True
        return hit[1:]

    def segment_ends(self) -> tuple[np.ndarray, np.ndarray]:
        """Start and end of every segment (segment i runs from point i to the next of its ring)."""
        n, ends = np.arange(1, len(self.points) + 1), np.cumsum(self.ring_sizes)
        n[ends - 1] = ends - self.ring_sizes
        return self.points, self.points[n]


@dataclass(frozen=True)
class Partition:
    points: np.ndarray        # (V, 2) arrangement vertices (the input points, merged)
    edges: np.ndarray         # (E, 2) vertex indices, edges[e, 0] < edges[e, 1]
    edge_source: list         # per edge: the (ring name, segment) it first came from
    edge_tag: np.ndarray      # per edge: the user's boundary tag where it lies on ∂Ω, else 0
    half_from: np.ndarray     # half-edge h = 2e + d runs edges[e, d] → edges[e, 1 - d]
    nxt: np.ndarray           # the next half-edge of the same cycle (face on the left)
    faces: tuple              # Face, ...
    edge_faces: np.ndarray    # (E, 2): face left of half-edge 2e and of 2e + 1 (-1: outside Ω)
    first_half: np.ndarray    # a half-edge of every cycle

    def cycle(self, c: int) -> np.ndarray:
        """The half-edges of cycle c in walking order (the face on their left), from first_half[c]."""
        order, start = self.walk
        return order[start[c]:start[c + 1]]

    @cached_property
    def walk(self) -> tuple[np.ndarray, np.ndarray]:
        """Every cycle's half-edges in walking order, cycle after cycle: (half-edges, offsets),
        cycle c being half-edges[offsets[c]:offsets[c + 1]] from first_half[c]. Taken once for
        all cycles by pointer doubling (a walk per face is a Python step per half-edge)."""
        n = len(self.nxt)
        first = np.zeros(n, bool)
        first[self.first_half] = True
        succ = np.where(first, np.arange(n), self.nxt)        # a cycle's first half-edge stays
        dist = (~first).astype(np.int64)                      # steps to it, doubled each round
        while True:
            nxt = succ[succ]
            if np.array_equal(nxt, succ):
                break
            dist += dist[succ]
            succ = nxt
        of = np.empty(n, np.int64)
        of[self.first_half] = np.arange(len(self.first_half))
        cyc = of[succ]
        size = np.bincount(cyc, minlength=len(self.first_half))
        order = np.lexsort(((size[cyc] - dist) % size[cyc], cyc))
        return order, np.concatenate([[0], np.cumsum(size)])

    def outer_corners(self) -> tuple[np.ndarray, np.ndarray]:
        """The corners of every face's outer cycle, face after face, and where each face's start."""
        order, start = self.walk
        c0 = np.array([f.cycles[0] for f in self.faces], np.int64)
        n0 = start[c0 + 1] - start[c0]
        first = np.cumsum(n0) - n0
        return self.points[self.half_from[order[np.repeat(start[c0] - first, n0) + np.arange(n0.sum())]]], first

    def face_rings(self, face: Face, extra: dict) -> tuple[list, list, bool]:
        """The rings of `face` (outer first) with `extra[e]` (points on edge e, in order from
        edges[e, 0]) inserted along their edges, each point's segment tag (edge + 1), and whether
        they are simple: no vertex met twice (a pinch)."""
        r = self.faces_rings([face], extra)
        cut = np.cumsum(r.ring_sizes).tolist()
        return ([r.points[a:b] for a, b in zip([0] + cut, cut)], [r.tags[a:b] for a, b in zip([0] + cut, cut)],
                bool(r.simple[0]))

    def faces_rings(self, faces: list, extra: dict) -> FaceRings:
        """`face_rings` of many faces at once, their rings concatenated face after face: a call
        per face costs more than its rings (a thousand inclusions)."""
        order, start = self.walk
        cycles = [f.cycles for f in faces]
        n_cyc = np.fromiter(map(len, cycles), np.int64, len(cycles))
        c = np.fromiter(chain.from_iterable(cycles), np.int64, int(n_cyc.sum()))
        size = start[c + 1] - start[c]
        hs = order[np.repeat(start[c] - np.cumsum(size) + size, size) + np.arange(size.sum())]
        e = hs >> 1                      # half-edge h runs along edge h >> 1, backwards when odd
        R, tags = self.points[self.half_from[hs]], e + 1
        of = np.repeat(np.repeat(np.arange(len(faces)), n_cyc), size)     # face of each half-edge
        xs = [extra.get(k) for k in e.tolist()] if extra else []
        n = np.fromiter((0 if x is None else len(x) for x in xs), np.int64, len(xs)) if xs else \
            np.zeros(len(hs), np.int64)
        key = np.unique(of * np.int64(len(self.points)) + self.half_from[hs])
        simple = np.bincount(key // len(self.points), minlength=len(faces)) == np.bincount(of, minlength=len(faces))
        if n.any():
            at = np.arange(len(hs)) + np.cumsum(n) - n       # each corner, its edge's points after it
            inner = np.ones(len(hs) + int(n.sum()), bool)
            inner[at] = False
            corners, R = R, np.empty((len(inner), 2))
            R[at] = corners
            R[inner] = np.concatenate([x[::-1] if h & 1 else x for h, x in zip(hs.tolist(), xs)
                                       if x is not None and len(x)])
            tags, size = np.repeat(tags, n + 1), np.add.reduceat(n + 1, np.cumsum(size) - size)
        return FaceRings(R, tags, size, np.add.reduceat(size, np.cumsum(n_cyc) - n_cyc), n_cyc, simple)

    def even_cuts(self, edges: np.ndarray, pieces: np.ndarray) -> dict[int, np.ndarray]:
        """{edge: the points cutting it into `pieces` equal pieces, from edges[e, 0] on} for the
        edges cut in more than one."""
        V, E, n = self.points, self.edges, pieces.astype(np.int64)
        e, n = edges[n > 1], n[n > 1]
        at = np.repeat(e, n - 1)
        j = np.arange(len(at)) - np.repeat(np.cumsum(n - 1) - (n - 1), n - 1) + 1    # 1 … n - 1
        X = V[E[at, 0]] + (j / np.repeat(n, n - 1))[:, None] * (V[E[at, 1]] - V[E[at, 0]])
        return dict(zip(e.tolist(), np.split(X, np.cumsum(n - 1)[:-1])))

    @cached_property
    def interface(self) -> np.ndarray:
        """Edges with a face of Ω on both sides (read once per face and hand-over)."""
        out = (self.edge_faces >= 0).all(axis=1)
        out.setflags(write=False)
        return out

    @cached_property
    def outline_tags(self) -> np.ndarray:
        """By a face mesh's boundary tag (edge + 1): whether the edge is Ω's alone, so that the
        face mesh may remove its vertices there (`mesher.polish`; tag 0 is none)."""
        out = np.r_[False, ~self.interface]
        out.setflags(write=False)
        return out


def points_on_edges(mesh, corners: cKDTree, n_seeds: int) -> dict:
    """The vertices a face mesh put on partition edges, beyond its input points: {edge: (k, 2)}
    (a corner of the partition, round-off copies included, is never a point "on" an edge:
    `corners`, a KD-tree of the partition's points)."""
    e, v = np.repeat(mesh.boundary_tags - 1, 2), mesh.boundary_edges.ravel()
    ev = np.unique(np.column_stack([e, v])[v >= n_seeds], axis=0)       # by edge, then vertex
    tol = 1e-12 * float((corners.maxes - corners.mins).max())          # np.ptp of its points
    ev = ev[corners.query(mesh.points[ev[:, 1]])[0] > tol]
    return {int(k): mesh.points[ev[ev[:, 0] == k, 1]] for k in np.unique(ev[:, 0])}


def partition(rings: list[Ring], segment_tags: list[np.ndarray], size: float) -> Partition:
    """The arrangement of `rings` (Ω's first: outline, holes; then the regions'); `segment_tags`
    the user's tags of Ω's rings' segments, one array per Ω ring."""
    # 1. vertices: every ring point, points closer than TOUCH·size merged (first one kept)
    user = np.concatenate([r.points for r in rings])
    # computed about the box's centre: cross products of far-off coordinates (1e8 and more)
    # would cancel; the partition keeps the user's coordinates bit for bit
    centre = 0.5 * user.min(axis=0) + 0.5 * user.max(axis=0)
    pts = user - centre
    sizes = [len(r.points) for r in rings]
    offsets = np.cumsum([0] + sizes)
    pairs = cKDTree(pts).query_pairs(TOUCH * size, output_type="ndarray")
    g = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])) if len(pairs) else
                      (np.empty(0), (np.empty(0, int), np.empty(0, int))), shape=(len(pts),) * 2)
    _, label = connected_components(g, directed=False)
    first = np.full(label.max() + 1, len(pts))
    np.minimum.at(first, label, np.arange(len(pts)))
    _, vid = np.unique(first[label], return_inverse=True)
    keep = np.sort(np.unique(first[label]))
    V, Vu = pts[keep], user[keep]
    # directed input segments: vertex ids, owner ring, segment index within its ring
    sring = np.repeat(np.arange(len(rings)), sizes)
    sseg = np.arange(len(pts)) - offsets[:-1][sring]        # each point's index in its ring
    ends = offsets[1:] - 1
    succ = np.arange(1, len(pts) + 1)                       # each point's successor on its ring
    succ[ends] = offsets[:-1]
    sa, sb = vid, vid[succ]
    degenerate = sa == sb
    if degenerate.any():
        k = int(np.flatnonzero(degenerate)[0])
        raise QmeshError(f"{rings[sring[k]].name}: segment {sseg[k]} is shorter than "
                         f"{TOUCH:g} × the domain's size, so its ends are one point: enlarge "
                         "that ring or drop one of the two points")

    # 2. split every segment at the vertices lying on it
    near = _rings.near_points(V, V[sa], V[sb], sa, sb, TOUCH * size)
    pt, sg = near[:, 0], near[:, 1]
    ab = V[sb[sg]] - V[sa[sg]]
    t = np.einsum("ij,ij->i", V[pt] - V[sa[sg]], ab) / np.einsum("ij,ij->i", ab, ab)
    # chains: each segment's start, its inner points by t, then its end
    seg_all = np.concatenate([np.arange(len(sa)), sg, np.arange(len(sa))])
    t_all = np.concatenate([np.zeros(len(sa)), t, np.ones(len(sa))])
    v_all = np.concatenate([sa, pt, sb])
    order = np.lexsort((t_all, seg_all))
    seg_all, v_all = seg_all[order], v_all[order]
    link = seg_all[1:] == seg_all[:-1]
    da, db, dseg = v_all[:-1][link], v_all[1:][link], seg_all[:-1][link]
    keep = da != db
    da, db, dseg = da[keep], db[keep], dseg[keep]

    # 3. undirected edges; what lies on the left of each direction
    lo, hi = np.minimum(da, db), np.maximum(da, db)
    key = lo * np.int64(len(V)) + hi
    ukey, inv = np.unique(key, return_inverse=True)
    E = np.column_stack([ukey // len(V), ukey % len(V)])
    forward = da == lo                                     # runs like E[e, 0] → E[e, 1]
    owner = np.array([r.owner for r in rings])[sring[dseg]]
    half = 2 * inv + (~forward)                            # the half-edge each piece runs along
    src_first = np.full(len(E), len(dseg))
    np.minimum.at(src_first, inv, np.arange(len(dseg)))
    edge_source = [(rings[sring[dseg[k]]].name, int(sseg[dseg[k]])) for k in src_first]
    edge_tag = np.zeros(len(E), np.int64)
    on_omega = owner == 0
    tags = np.concatenate(segment_tags)
    # Ω's rings come first, so their segments' global index is their index into `tags`
    edge_tag[inv[on_omega]] = tags[offsets[sring[dseg[on_omega]]] + sseg[dseg[on_omega]]]
    _check_crossings(V, E, edge_source)

    # 4. the faces: the half-edge walk, and the cycles' nesting
    half_from = E.ravel()                                  # h = 2e: E[e,0] → E[e,1]; 2e+1 back
    half_to = E[:, ::-1].ravel()
    d = V[half_to] - V[half_from]
    ang = arctan2(d[:, 1], d[:, 0])
    order = np.lexsort((ang, half_from))                   # outgoing half-edges, CCW per vertex
    start = np.searchsorted(half_from[order], np.arange(len(V)))
    deg = np.bincount(half_from, minlength=len(V))
    pos = np.empty(len(order), np.int64)
    pos[order] = np.arange(len(order)) - start[half_from[order]]
    twin = np.arange(len(half_from)) ^ 1
    v = half_to
    nxt = order[start[v] + (pos[twin] - 1) % deg[v]]       # first clockwise from the twin
    n_half = len(half_from)
    _, cyc = connected_components(sp.coo_matrix((np.ones(n_half), (np.arange(n_half), nxt)),
                                                shape=(n_half, n_half)), connection="weak")
    cross = V[half_from, 0] * V[half_to, 1] - V[half_from, 1] * V[half_to, 0]
    area = np.bincount(cyc, weights=0.5 * cross)
    _, comp = connected_components(sp.coo_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])),
                                                 shape=(len(V),) * 2), directed=False)
    cyc_comp = np.zeros(len(area), np.int64)
    cyc_comp[cyc] = comp[half_from]
    outer_of = _nest(V, half_from, half_to, cyc, area, cyc_comp)

    # 5. labels: region k on the left of k's rings as given; Ω inside/outside from Ω's rings
    n_cyc = len(area)
    face_of_cycle = np.where(area > 0, np.arange(n_cyc), outer_of)   # -1: the unbounded face
    face_half = face_of_cycle[cyc]
    left = np.full(n_half, INSIDE)         # region ring reversed: says only "inside Ω"
    hit_region = np.zeros(n_half, np.int64)
    reg = owner > 0
    np.maximum.at(hit_region, half[reg], owner[reg])
    left[hit_region > 0] = hit_region[hit_region > 0]
    _check_same_side(owner[reg], half[reg], n_half, Vu, half_from)
    omega_out = np.zeros(n_half, bool)
    omega_out[(half ^ 1)[on_omega]] = True
    left[omega_out & (hit_region == 0)] = OUTSIDE
    # a half-edge both a region's (on its left) and outside Ω: the region leaves Ω
    bad = omega_out & (hit_region > 0)
    if bad.any():
        h = int(np.flatnonzero(bad)[0])
        raise QmeshError(f"region {hit_region[h]} leaves the domain: its edge from "
                         f"{Vu[half_from[h]].tolist()} to {Vu[half_to[h]].tolist()} runs along "
                         f"{edge_source[h // 2][0]} (segment {edge_source[h // 2][1]}) on the outside")
    faces, edge_faces, first_half = _label_faces(Vu, E, half_from, half_to, left, hit_region, omega_out,
                                     face_half, n_cyc, cyc, edge_source, area)
    return Partition(Vu, E, edge_source, edge_tag, half_from, nxt, faces, edge_faces, first_half)


def _check_crossings(V, E, edge_source) -> None:
    """Edges that still touch or cross after the splits: an error naming both input segments."""
    bad = _rings.crossings(V[E[:, 0]], V[E[:, 1]], E[:, 0], E[:, 1])
    if len(bad):
        i, j = (int(x) for x in bad[0])
        (ri, si), (rj, sj) = edge_source[i], edge_source[j]
        if rj.startswith("region") and not ri.startswith("region"):
            (ri, si), (rj, sj) = (rj, sj), (ri, si)          # name the region first
        where = "itself" if ri == rj else rj
        raise QmeshError(f"{ri} crosses {where}: its segment {si} meets segment {sj}"
                         + ("" if ri == rj else f" of {rj}"))


def _check_same_side(owner, half, n_half, V, half_from) -> None:
    """Two regions on the same side of one edge overlap there: QmeshError naming both, and
    saying they are the same polygon when every edge of one is an edge of the other on the
    same side (any orientation, start point or extra point on a side)."""
    if not len(half):
        return
    pair = np.unique(np.column_stack([half, owner]), axis=0)      # (half-edge, region) once
    h, r = pair[:, 0], pair[:, 1]
    shared = np.flatnonzero(h[1:] == h[:-1])
    if not len(shared):
        return
    a, b = int(r[shared[0]]), int(r[shared[0] + 1])               # a < b, one edge in common
    ha, hb = np.unique(h[r == a]), np.unique(h[r == b])
    if np.array_equal(ha, hb):
        raise QmeshError(f"region {a} and region {b} are the same polygon: give each region "
                         f"once (drop one of them, or give region {b} its own outline)")
    raise QmeshError(f"region {a} overlaps region {b} (near {V[half_from[h[shared[0]]]].tolist()}): "
                     "regions may share edges only from opposite sides")


def _nest(V, half_from, half_to, cyc, area, cyc_comp) -> np.ndarray:
    """For every clockwise cycle, the smallest counter-clockwise cycle of another component
    that contains it (-1: none, it bounds the unbounded face)."""
    n_cyc = len(area)
    outer_of = np.full(n_cyc, -1)
    cw = np.flatnonzero(area < 0)
    ccw = np.flatnonzero(area > 0)
    if len(cw) == 0 or len(ccw) == 0:
        return outer_of
    probe_half = np.full(n_cyc, -1)
    probe_half[cyc[::-1]] = np.arange(len(cyc))[::-1]
    P = V[half_from[probe_half[cw]]]                      # one vertex of each clockwise cycle
    is_ccw = area[cyc] > 0
    A, B, seg_cyc = V[half_from[is_ccw]], V[half_to[is_ccw]], cyc[is_ccw]
    ylo, yhi = np.minimum(A[:, 1], B[:, 1]), np.maximum(A[:, 1], B[:, 1])
    keys_all = []
    for pt, sg in _rings._pairs(P[:, 1], ylo, yhi):
        a, b, p = A[sg], B[sg], P[pt]
        straddle = (a[:, 1] > p[:, 1]) != (b[:, 1] > p[:, 1])
        tt = np.where(straddle, (p[:, 1] - a[:, 1]) / np.where(straddle, b[:, 1] - a[:, 1], 1.0), 0)
        hit = straddle & (a[:, 0] + tt * (b[:, 0] - a[:, 0]) > p[:, 0])
        keys_all.append(pt[hit] * np.int64(n_cyc) + seg_cyc[sg][hit])
    if keys_all:
        keys = np.concatenate(keys_all)
        uk, cnt = np.unique(keys, return_counts=True)
        uk = uk[cnt % 2 == 1]
        pt, c = uk // n_cyc, uk % n_cyc
        other = cyc_comp[c] != cyc_comp[cw[pt]]
        pt, c = pt[other], c[other]
        order = np.lexsort((area[c], pt))                 # smallest containing cycle first
        pt, c = pt[order], c[order]
        firsts = np.r_[True, pt[1:] != pt[:-1]] if len(pt) else np.zeros(0, bool)
        outer_of[cw[pt[firsts]]] = c[firsts]
    return outer_of


def _label_faces(V, E, half_from, half_to, left, hit_region, omega_out, face_half, n_cyc, cyc,
                 edge_source, area):
    """Each bounded face's region from its half-edges' left labels; disagreements are errors."""
    n_half = len(half_from)
    inside = face_half >= 0
    # per face: the regions its half-edges name, and whether any says "outside Ω"
    f, lab = face_half[inside], left[inside]
    hidx = np.flatnonzero(inside)
    face_region = np.zeros(n_cyc, np.int64)
    named = lab > 0
    order = np.lexsort((lab[named], f[named]))
    fr, lr, hr = f[named][order], lab[named][order], hidx[named][order]
    np.maximum.at(face_region, fr, lr)
    clash = lr != face_region[fr]
    if clash.any():
        k = int(np.flatnonzero(clash)[0])
        raise QmeshError(f"region {lr[k]} overlaps region {face_region[fr[k]]} (near "
                         f"{V[half_from[hr[k]]].tolist()})")
    outside = np.zeros(n_cyc, bool)
    np.logical_or.at(outside, f, lab == OUTSIDE)
    # a region face must be bounded by its own rings only; anything else lies inside it
    reg_face = face_region[f] > 0
    foreign = reg_face & (lab != face_region[f])
    if foreign.any():
        k = int(np.flatnonzero(foreign)[0])
        e = hidx[k] // 2
        what, seg = edge_source[e]
        raise QmeshError(f"{what} (segment {seg}) lies inside region {face_region[f[k]]}: "
                         "regions must not overlap each other or the domain's holes")
    # a face outside Ω (a hole, or a notch) must be bounded by Ω's rings only
    out_face = outside[f]
    stray = out_face & (lab != OUTSIDE)
    if stray.any():
        k = int(np.flatnonzero(stray)[0])
        what, seg = edge_source[hidx[k] // 2]
        raise QmeshError(f"{what} (segment {seg}) lies outside the domain (in a hole or beyond "
                         "the outline)")
    # cycles bounding the unbounded face: only the outline may
    unb = ~inside & (left != OUTSIDE)
    if unb.any():
        k = int(np.flatnonzero(unb)[0])
        what, seg = edge_source[k // 2]
        raise QmeshError(f"{what} (segment {seg}) lies outside the outline")
    faces, face_index = [], np.full(n_cyc, -1)
    holes_of = {}
    first_half = np.full(n_cyc, -1)
    first_half[cyc[::-1]] = np.arange(n_half)[::-1]
    for c in np.flatnonzero((area > 0) & ~outside):
        face_index[c] = len(faces)
        faces.append(c)
    for c in np.flatnonzero(area < 0):
        owner_face = face_half[first_half[c]]
        if owner_face >= 0 and face_index[owner_face] >= 0:
            holes_of.setdefault(int(face_index[owner_face]), []).append(int(c))
    face_list = tuple(Face((int(c),) + tuple(holes_of.get(i, ())), int(face_region[c]))
                      for i, c in enumerate(faces))
    hf = np.where(face_half >= 0, face_index[np.maximum(face_half, 0)], -1)
    return face_list, hf.reshape(-1, 2), first_half
