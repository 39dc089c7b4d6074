"""The domain Ω: an outline and holes (simple polygons) whose points are fixed mesh vertices.

GEOMETRY.md §1–§2. Every input point is a seed: a vertex of the mesh that never moves (the
chapter's polygon corners, Section 2.3.3). The boundary is a list of directed segments, each
from one seed to the next around its ring, with Ω on the left (outline counter-clockwise, holes
clockwise); other boundary vertices the mesher adds lie on a segment and slide along it. Each
segment carries an integer tag (default 1 for the outline, 2, 3, … for the holes) that the
mesh's boundary edges inherit, so users can put boundary conditions on them by name.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Union

import numpy as np
from numpy.typing import ArrayLike, NDArray

from qmesh.geometry import rings as _rings
from qmesh import checks
from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.domain import cells
from qmesh.domain.regions import attach, faces_of
from qmesh.errors import QmeshError
from qmesh.geometry.orientation import orient

MAX_POINTS = 10_000_000
TOUCH = 1e-9    # a point this close (× the domain's size) to a segment not its own touches it
SMALL = 64      # rings of at most this many points in all are checked pair by pair

Ring = Union[ArrayLike, "Domain"]
"""A ring of points: an (n, 2) array-like, or a `Polygon` / one-ring `Domain` standing for its outline."""
Names = Union[dict[int, str], Sequence[str]]
"""Names of tags: a dict tag → name, or one name per ring (per region)."""

if TYPE_CHECKING:
    from qmesh.domain.partition import Partition


def _ring_name(k: int) -> str:
    return "the outline" if k == 0 else f"hole {k}"


def _as_points(ring: Ring, name: str) -> NDArray[np.float64]:
    """An (n, 2) float array of a ring's points, or QmeshError naming the ring."""
    if isinstance(ring, Domain):
        if len(ring.rings) != 1:
            raise QmeshError(f"{name}: a domain with holes cannot be used as a ring")
        return np.array(ring.rings[0])
    if isinstance(ring, (str, bytes)) or ring is None:
        raise QmeshError(f"{name} must be an (n, 2) array of points, got {type(ring).__name__}")
    try:
        P = np.array(ring, dtype=float)
    except (TypeError, ValueError):
        raise QmeshError(f"{name} must be an (n, 2) array of numbers, got {ring!r:.80}") from None
    if P.ndim != 2 or P.shape[1] != 2:
        raise QmeshError(f"{name} must have shape (n, 2), got {P.shape}")
    if len(P) < 3:
        raise QmeshError(f"{name} needs at least 3 points, got {len(P)}")
    if len(P) > MAX_POINTS:
        raise QmeshError(f"{name} has {len(P)} points; the limit is {MAX_POINTS:.0e}")
    if not np.all(np.isfinite(P)):
        raise QmeshError(f"{name} has points that are not finite numbers")
    return P


def _check_points(raw: list[NDArray[np.float64]]) -> None:
    """Repeated consecutive points are refused (they would be one vertex); all rings at once."""
    sizes = [len(P) for P in raw]
    P = np.concatenate(raw)
    E = P[_next_points(sizes)] - P
    length = np.hypot(E[:, 0], E[:, 1])
    # points closer than round-off at their magnitude cannot be told apart
    tiny = length <= 8 * np.finfo(float).eps * np.abs(P).max(axis=1)
    if tiny.any():
        at = int(np.flatnonzero(tiny)[0])
        k = int(np.searchsorted(np.cumsum(sizes), at, side="right"))
        i = at - int(sum(sizes[:k]))
        raise QmeshError(f"{_ring_name(k)} has repeated points: point {i} and point "
                         f"{(i + 1) % sizes[k]} coincide at {P[at].tolist()}")


def _check_ring_area(P: NDArray[np.float64], name: str) -> float:
    """The signed area of a simple ring, refused when zero; taken on the ring divided by its
    extent, so its sign survives coordinates whose squares overflow or underflow (1e±300)."""
    d = float(np.abs(P - P[0]).max())
    area = _rings.signed_area((P - P[0]) / d) if d > 0 else 0.0
    if not abs(area) > 0:
        raise QmeshError(f"{name} has zero area")
    return area * d * d if abs(area * d * d) > 0 else np.copysign(np.finfo(float).tiny, area)


def _ring_area_or_none(P: NDArray[np.float64]) -> float | None:
    """`_check_ring_area` of a ring of 3 points or more, None where it refuses it."""
    try:
        return _check_ring_area(P, "") if len(P) >= 3 else None
    except QmeshError:
        return None


def _ring_tags(tag: ArrayLike | None, n: int, default: int, name: str) -> NDArray[np.int64]:
    """Per-segment tags of one ring from an int or a sequence of n ints."""
    if tag is None:
        return np.full(n, default, np.int64)
    t = np.asarray(tag)
    if t.dtype == bool or not np.issubdtype(t.dtype, np.integer):
        raise QmeshError(f"tags of {name} must be integers, got {tag!r:.80}")
    if np.any(t < 1) or np.any(t > 2**31 - 1):      # before int64: 2**63 arrives as uint64
        raise QmeshError(f"tags of {name} must be integers from 1 to 2**31 - 1")
    if t.ndim == 0:
        t = np.full(n, int(t), np.int64)
    if t.shape != (n,):
        raise QmeshError(f"tags of {name} must be one integer or {n} integers (one per segment), "
                         f"got shape {t.shape}")
    return t.astype(np.int64)


class Domain:
    """Ω: `outer` a simple polygon (either orientation), `holes` simple polygons strictly
    inside it and disjoint from each other. `Polygon` and `Disk` objects are accepted as rings.

    `tags`: None (1 for the outline, 2, 3, … for the holes), or one entry per ring, each an int
    or a sequence of ints, one per segment (segment i runs from point i to point i + 1 as given).
    `names`: a dict tag → name, or a sequence of names, one per ring.
    `regions`: simple polygons (arrays, `Polygon`s, or `Domain(outer, holes)` for a region with
    holes) inside Ω, pairwise non-overlapping, that may share edges with each other and with
    the boundary; region k (1-based) has tag k, the rest of Ω is region 0 (MEDIA.md).
    `region_names`: a dict tag → name, or one name per region.
    """

    media_face = False
    """True for a medium's face (`domain.faces.face_domain`): the segments of one edge of the
    partition (one tag, straight on) are one side of its corners (`mesher.corners.side_runs`)."""

    def __init__(self, outer: Ring, holes: Iterable[Ring] = (), tags: Iterable[ArrayLike] | None = None,
                 names: Names | None = None, regions: Iterable[Ring] | None = (),
                 region_names: Names | None = None) -> None:
        holes = checks.polygon_list(holes, "holes")
        raw = [_as_points(outer, "the outline")]
        raw += [_as_points(h, _ring_name(k + 1)) for k, h in enumerate(holes)]
        _check_points(raw)
        if tags is not None:
            try:
                tags = list(tags)
            except TypeError:
                raise QmeshError("tags must be a sequence with one entry per ring") from None
            if len(tags) != len(raw):
                raise QmeshError(f"tags must have one entry per ring ({len(raw)}), got {len(tags)}")
        ring_tags = [_ring_tags(None if tags is None else tags[k], len(P), k + 1, _ring_name(k))
                     for k, P in enumerate(raw)]
        _check_simple(_normalised(raw))
        areas = [_check_ring_area(P, _ring_name(k)) for k, P in enumerate(raw)]

        # orient: the outline counter-clockwise, holes clockwise (Ω on the left of every segment),
        # keeping each ring's first point first; segment tags follow their segments
        oriented, seg_tags = [], []
        for k, (P, a, t) in enumerate(zip(raw, areas, ring_tags)):
            if (a > 0) != (k == 0):
                P = np.roll(P[::-1], 1, axis=0)
                t = t[(-np.arange(len(t)) - 1) % len(t)]
            oriented.append(P)
            seg_tags.append(t)
        self._store(oriented, seg_tags, abs(areas[0]) - sum(abs(a) for a in areas[1:]))
        self._tag_names = _tag_names(names, ring_tags)
        self._regions: tuple[Domain, ...] = ()
        self._region_names: dict[int, str] = {}
        self._partition: Partition | None = None
        if regions is not None and not (isinstance(regions, (list, tuple)) and not regions):
            attach(self, regions, region_names, ring_tags, Domain)

    def _store(self, oriented: list[NDArray[np.float64]], seg_tags: list[NDArray[np.int64]],
               area: float) -> None:
        """Keep oriented rings (outline counter-clockwise, holes clockwise), their segment
        tags and Ω's area, with the seeds and segments read from them."""
        oriented = [P.copy() for P in oriented]
        for P in oriented:
            P.setflags(write=False)
        self._rings = tuple(oriented)
        seeds = np.concatenate(oriented)
        seeds.setflags(write=False)
        self._seeds = seeds
        sizes = [len(P) for P in oriented]
        self._segments = np.column_stack([np.arange(len(seeds)), _next_points(sizes)])
        self._segments.setflags(write=False)
        self._segment_tags = np.concatenate(seg_tags)
        self._segment_tags.setflags(write=False)
        self._ring_of_seed = np.repeat(np.arange(len(oriented)), sizes)
        self._area = area

    @classmethod
    def _traced(cls, outer: NDArray[np.float64], holes: Sequence[NDArray[np.float64]] = ()) -> Domain:
        """A domain of rings known to be simple, disjoint and oriented (the outline counter-
        clockwise, holes clockwise): the zones `cells.zones` traces along cell edges, whose
        checks one by one would cost more than the partition that checks them together."""
        new = object.__new__(cls)
        rings = [np.asarray(outer, float)] + [np.asarray(h, float) for h in holes]
        area = _rings.signed_area(rings[0]) + sum(_rings.signed_area(h) for h in rings[1:])
        new._store(rings, [np.full(len(P), k + 1, np.int64) for k, P in enumerate(rings)], area)
        new._tag_names, new._regions, new._region_names, new._partition = {}, (), {}, None
        return new

    @classmethod
    def from_checked_rings(cls, rings: Sequence[NDArray[np.float64]],
                           tags: Sequence[NDArray[np.int64]]) -> Domain | None:
        """`Domain(rings[0], rings[1:], tags=tags)` for rings already known simple and disjoint,
        their holes inside the outline (a face of a checked partition whose cycles share no
        vertex, points added along its edges or not): stored as that call stores them, area
        included, without its pair checks. None when a ring has fewer than 3 points, points
        that round-off cannot tell apart, zero area or the other orientation (the outline
        counter-clockwise, holes clockwise): the call itself then decides."""
        area = cls.checked_areas(rings, [len(rings)])[0]
        try:
            _check_points(list(rings))
        except QmeshError:
            return None
        if area is None:
            return None
        new = object.__new__(cls)
        new._store(list(rings), list(tags), area)
        new._tag_names, new._regions, new._region_names, new._partition = {}, (), {}, None
        return new

    @staticmethod
    def checked_areas(rings: Sequence[NDArray[np.float64]], counts: Sequence[int]) -> list[float | None]:
        """The area `from_checked_rings` stores for each run of `counts` rings (the faces of a
        partition), or None where it returns None (a ring of fewer than 3 points, of zero area or
        of the other orientation)."""
        signed = [_ring_area_or_none(R) for R in rings]
        out: list[float | None] = []
        at = 0
        for n in counts:
            a, at = signed[at:at + n], at + n
            b = [x for x in a if x is not None]
            ok = len(b) == n and b[0] >= 0 and all(x <= 0 for x in b[1:])
            out.append(abs(b[0]) - sum(abs(x) for x in b[1:]) if ok else None)
        return out

    @classmethod
    def _many(cls, rings: Sequence[Ring]) -> list[Domain] | None:
        """`[Domain(r) for r in rings]` for many small rings (≤ SMALL points each), checked all
        at once: a thousand regions checked one by one cost more than their partition. None
        when a ring is large or fails a check; `Domain(r)` one by one then says which, as before."""
        try:
            raw = [_as_points(r, "the outline") for r in rings]
        except QmeshError:
            return None
        sizes = np.array([len(P) for P in raw])
        if not len(raw) or sizes.max() > SMALL:
            return None
        try:
            _check_points(raw)
        except QmeshError:
            return None
        # each ring moved and scaled on its own, as `_normalised` does for one domain
        P = np.concatenate(raw)
        start = np.cumsum(sizes) - sizes
        lo, hi = np.minimum.reduceat(P, start), np.maximum.reduceat(P, start)
        with np.errstate(over="ignore", invalid="ignore"):
            d = (hi - lo).max(axis=1)
        if not np.isfinite(d).all():
            return None
        ring = np.repeat(np.arange(len(raw)), sizes)
        X = (P - (0.5 * lo + 0.5 * hi)[ring]) / d[ring, None]
        nxt = _next_points(list(sizes))
        # segment pairs i < j of one ring; (point, segment) pairs of one ring
        left = (start + sizes)[ring] - np.arange(len(P)) - 1
        i = np.repeat(np.arange(len(P)), left)
        j = i + 1 + np.arange(len(i)) - np.repeat(np.cumsum(left) - left, left)
        sg = np.repeat(np.arange(len(P)), sizes[ring])
        pt = start[ring][sg] + np.arange(len(sg)) - np.repeat(np.cumsum(sizes[ring]) - sizes[ring], sizes[ring])
        keep = (pt != sg) & (pt != nxt[sg])
        pt, sg = pt[keep], sg[keep]
        xlo, xhi = np.minimum.reduceat(X, start), np.maximum.reduceat(X, start)
        reach = TOUCH * (xhi - xlo).max(axis=1)
        if (len(_crossings(X, np.arange(len(P)), nxt, (i, j)))
                or (_rings.point_segment_distance(X[pt], X[sg], X[nxt[sg]]) <= reach[ring[sg]]).any()):
            return None
        out = []
        for R in raw:
            try:
                area = _check_ring_area(R, "the outline")
            except QmeshError:
                return None
            t = np.ones(len(R), np.int64)
            new = object.__new__(cls)
            new._store([R if area > 0 else np.roll(R[::-1], 1, axis=0)], [t], abs(area))
            new._tag_names, new._regions, new._region_names, new._partition = {}, (), {}, None
            out.append(new)
        return out

    @classmethod
    def from_cells(cls, x: ArrayLike, y: ArrayLike, k1: ArrayLike, k2: ArrayLike,
                   angle: ArrayLike = 0.0) -> tuple[Domain, dict[int, Anisotropy]]:
        """(Domain, {region tag: Anisotropy}) of a structured grid with per-cell k1, k2, angle
        (MODFLOW's convention), cells of equal conductivity merged into regions (`cells.zones`)."""
        outline, regions, params = cells.zones(x, y, k1, k2, angle)
        domain = cls(outline, regions=[Domain._traced(outer, holes) for outer, holes in regions])
        cond = {}
        for tag, (p, made) in enumerate(zip(params, Anisotropy.principals(params))):   # all at once
            try:
                cond[tag] = made if made is not None else Anisotropy.principal(*p)
            except QmeshError as e:
                raise QmeshError(f"{cells.cell_of_zone(x, y, k1, k2, angle, p)}: {e}") from None
        return domain, cond

    @property
    def regions(self) -> tuple[Domain, ...]:
        """The regions as given, each a `Domain` (outline and holes); region k is regions[k-1]."""
        return self._regions

    @property
    def region_names(self) -> dict[int, str]:
        """Region tag → name, for the regions given names."""
        return dict(self._region_names)

    @property
    def partition(self) -> Partition:
        """The planar partition of Ω by its regions (`partition.Partition`): the faces a medium
        is meshed by, one face per connected piece of Ω when there are no regions."""
        if self._partition is None:
            self._partition = faces_of(self)
        return self._partition

    # ------------------------------------------------------------------ what the mesher reads
    @property
    def rings(self) -> tuple[NDArray[np.float64], ...]:
        """The rings, outline first (counter-clockwise), then the holes (clockwise)."""
        return self._rings

    @property
    def holes(self) -> tuple[NDArray[np.float64], ...]:
        """The holes' rings (clockwise), in the order given."""
        return self._rings[1:]

    @property
    def seeds(self) -> NDArray[np.float64]:
        """Every input point, ring after ring: the fixed vertices of the mesh."""
        return self._seeds

    @property
    def segments(self) -> NDArray[np.int64]:
        """(S, 2) seed indices: segment k runs from seed k to the next seed of its ring."""
        return self._segments

    @property
    def segment_tags(self) -> NDArray[np.int64]:
        """(S,) the tag of every segment, which the mesh's boundary edges on it inherit."""
        return self._segment_tags

    @property
    def tag_names(self) -> dict[int, str]:
        """Boundary tag → name, for the tags given names."""
        return dict(self._tag_names)

    @property
    def ring_of_seed(self) -> NDArray[np.int64]:
        """The ring of every seed: 0 for the outline, k for hole k."""
        return self._ring_of_seed

    @property
    def segment_ends(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Start and end points (S, 2) of every segment."""
        return self._seeds[self._segments[:, 0]], self._seeds[self._segments[:, 1]]

    @property
    def edges(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Segment start points and unit tangents."""
        A, B = self.segment_ends
        E = B - A
        return A, E / np.hypot(E[:, 0], E[:, 1])[:, None]

    @property
    def area(self) -> float:
        """The area of Ω: the outline's area less the holes'."""
        return self._area

    @property
    def bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The lower-left and upper-right corners of the outline's bounding box."""
        return self._rings[0].min(axis=0), self._rings[0].max(axis=0)

    @property
    def diameter(self) -> float:
        """The larger side of the outline's bounding box."""
        lo, hi = self.bounds
        return float((hi - lo).max())

    def contains(self, P: ArrayLike, tol: float = 1e-9) -> NDArray[np.bool_]:
        """Boolean mask of points inside Ω or within tol × diameter of its boundary."""
        P = np.asarray(P, dtype=float).reshape(-1, 2)
        A, B = self.segment_ends
        ins = _rings.inside(P, A, B)
        if tol > 0:
            ins |= np.isfinite(_rings.distance(P, A, B, tol * self.diameter))
        return ins

    def scaled(self, center: ArrayLike, scale: float, area: float | None = None) -> Domain:
        """The same domain in coordinates (x − center) / scale (tags kept, no re-validation);
        its area measured on the new rings unless given."""
        new = object.__new__(type(self))               # a subclass stays itself
        new.__dict__.update(self.__dict__)
        new.__dict__.pop("_triangulation", None)        # a cache in the old coordinates
        seeds = (self._seeds - np.asarray(center, dtype=float)) / scale   # all rings at once
        seeds.setflags(write=False)
        rings = tuple(np.split(seeds, np.cumsum([len(R) for R in self._rings])[:-1]))
        new._rings, new._seeds = rings, seeds
        new._area = area if area is not None else \
            abs(_rings.signed_area(rings[0])) - sum(abs(_rings.signed_area(R)) for R in rings[1:])
        return new

    def edge_of(self, P: ArrayLike, tol: float = 1e-9) -> NDArray[np.int64]:
        """Segment each point lies on (within tol × diameter), or -1; input points report the
        segment they start."""
        A, B = self.segment_ends
        return _rings.segment_of(np.asarray(P, dtype=float).reshape(-1, 2), A, B,
                                 tol * self.diameter)

    def __repr__(self) -> str:
        return (f"Domain({len(self._rings[0])} outline points, {len(self._rings) - 1} holes, "
                f"area={self._area:.6g})")


def _tag_names(names: Names | None, ring_tags: list[NDArray[np.int64]]) -> dict[int, str]:
    if names is None:
        return {}
    if isinstance(names, dict):
        return checks.tag_names(names, "names")
    if isinstance(names, str):
        raise QmeshError("names must be a dict tag → name or one name per ring, got a string")
    names = list(names)
    if len(names) != len(ring_tags):
        raise QmeshError(f"names must have one entry per ring ({len(ring_tags)}), got {len(names)}")
    out = {}
    for k, (name, t) in enumerate(zip(names, ring_tags)):
        if not isinstance(name, str):
            raise QmeshError(f"the name of {_ring_name(k)} must be a string, got {name!r}")
        if len(np.unique(t)) != 1:
            raise QmeshError(f"{_ring_name(k)} has several tags: name them with a dict tag → name")
        out[int(t[0])] = name
    return out


def _normalised(raw: list[NDArray[np.float64]]) -> list[NDArray[np.float64]]:
    """The rings moved and scaled to about [-½, ½]², for the checks that multiply coordinates
    (their test is relative to the domain's size): 1e300 overflows a product, 1e-300 underflows."""
    pts = np.concatenate(raw)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    with np.errstate(over="ignore"):
        d = float((hi - lo).max())
    if not np.isfinite(d):
        raise QmeshError(f"the domain spans {lo.tolist()} to {hi.tolist()}: its size overflows a "
                         "floating-point number")
    c = 0.5 * lo + 0.5 * hi
    return [(P - c) / d for P in raw]


def _next_points(sizes: list[int]) -> NDArray[np.int64]:
    """For rings of `sizes` points concatenated, the index of every point's successor on its
    ring (the last point's is the ring's first)."""
    n = int(sum(sizes))
    nxt = np.arange(1, n + 1)
    ends = np.cumsum(sizes)
    nxt[ends - 1] = ends - np.asarray(sizes)
    return nxt


def _crossings(pts: NDArray[np.float64], ia: NDArray[np.int64], ib: NDArray[np.int64],
               pairs: tuple[NDArray[np.int64], NDArray[np.int64]] | None = None) -> NDArray[np.int64]:
    """`rings.crossings` of the segments pts[ia] → pts[ib]; up to SMALL points, or among the
    segment `pairs` (i < j) given, over every pair at once (the same pairs, in the same order:
    the y-sweep's set-up costs more there)."""
    if pairs is None and len(pts) > SMALL:
        return _rings.crossings(pts[ia], pts[ib], ia, ib)
    i, j = np.triu_indices(len(ia), 1) if pairs is None else pairs
    a, b, c, d = pts[ia[i]], pts[ib[i]], pts[ia[j]], pts[ib[j]]
    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    # the sweep's candidates: segments whose boxes overlap (the orientations of nearly collinear
    # segments apart along their line can round to a "crossing")
    box = np.all((np.minimum(a, b) <= np.maximum(c, d)) & (np.minimum(c, d) <= np.maximum(a, b)),
                 axis=1)
    proper = (o1 * o2 < 0) & (o3 * o4 < 0)
    touch = (((o1 == 0) & _rings._on_segment(a, b, c)) | ((o2 == 0) & _rings._on_segment(a, b, d))
             | ((o3 == 0) & _rings._on_segment(c, d, a)) | ((o4 == 0) & _rings._on_segment(c, d, b)))
    aa, ab, ba = ia[i] == ia[j], ia[i] == ib[j], ib[i] == ia[j]
    shared = aa | ab | ba | (ib[i] == ib[j])
    fold = shared & (o1 == 0) & (o2 == 0) & _rings._fold_back(a, b, c, d, aa, ab, ba)
    bad = box & np.where(shared, fold, proper | touch)
    return np.column_stack([i[bad], j[bad]])


def _near_points(pts: NDArray[np.float64], ia: NDArray[np.int64], ib: NDArray[np.int64],
                 reach: float) -> NDArray[np.int64]:
    """`rings.near_points` of pts against the segments pts[ia] → pts[ib]; up to SMALL points,
    over every (point, segment) pair at once, the first pair the same as the sweep's (the
    first segment, then its points from the lowest)."""
    if len(pts) > SMALL:
        return _rings.near_points(pts, pts[ia], pts[ib], ia, ib, reach)
    order = np.argsort(pts[:, 1], kind="stable")
    sg, pt = np.divmod(np.arange(len(ia) * len(pts)), len(pts))
    pt = order[pt]
    keep = (pt != ia[sg]) & (pt != ib[sg])
    pt, sg = pt[keep], sg[keep]
    close = _rings.point_segment_distance(pts[pt], pts[ia[sg]], pts[ib[sg]]) <= reach
    return np.column_stack([pt[close], sg[close]])


def _check_simple(raw: list[NDArray[np.float64]]) -> None:
    """No ring crosses itself or another; holes lie inside the outline and outside each other."""
    sizes = [len(P) for P in raw]
    offsets = np.cumsum([0] + sizes)
    pts = np.concatenate(raw)
    ia = np.arange(len(pts))
    ib = _next_points(sizes)
    bad = _crossings(pts, ia, ib)
    if len(bad):
        i, j = (int(v) for v in bad[0])
        ri, rj = (int(np.searchsorted(offsets, v, side="right")) - 1 for v in (i, j))
        si, sj = i - offsets[ri], j - offsets[rj]

        def seg(r: int, s: int) -> str:
            return f"segment {s} (point {s} → {(s + 1) % sizes[r]})"
        if ri == rj:
            raise QmeshError(f"{_ring_name(ri)} intersects itself: {seg(ri, si)} meets {seg(rj, sj)}")
        raise QmeshError(f"{_ring_name(rj)} crosses {_ring_name(ri)}: its {seg(rj, sj)} meets "
                         f"{seg(ri, si)} of {_ring_name(ri)}")
    # points a hair's breadth from a segment they are not an end of (rings touching, a pinch)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    near = _near_points(pts, ia, ib, TOUCH * float((hi - lo).max()))
    if len(near):
        p, s = (int(v) for v in near[0])
        rp, rs = (int(np.searchsorted(offsets, v, side="right")) - 1 for v in (p, s))
        raise QmeshError(f"point {p - offsets[rp]} of {_ring_name(rp)} touches segment "
                         f"{s - offsets[rs]} of {_ring_name(rs)} (closer than {TOUCH:g} × the "
                         f"domain's size)")
    if len(raw) == 1:
        return
    # rings neither cross nor touch: each hole lies inside or outside each other ring as a
    # whole, so its first point decides; one sweep over every (point, segment) pair sharing a
    # height, parity per (hole, ring)
    ring_of = np.repeat(np.arange(len(raw)), sizes)
    probe = offsets[1:-1]                              # first point of every hole
    P, A, B = pts[probe], pts[ia], pts[ib]
    ylo, yhi = np.minimum(A[:, 1], B[:, 1]), np.maximum(A[:, 1], B[:, 1])
    n_r = np.int64(len(raw))
    keys = []
    for pt, sg in _rings._pairs(P[:, 1], ylo, yhi):
        a, b, p = A[sg], B[sg], P[pt]
        straddle = (a[:, 1] > p[:, 1]) != (b[:, 1] > p[:, 1])
        t = np.where(straddle, (p[:, 1] - a[:, 1]) / np.where(straddle, b[:, 1] - a[:, 1], 1.0), 0.0)
        hit = straddle & (a[:, 0] + t * (b[:, 0] - a[:, 0]) > p[:, 0])
        keys.append(pt[hit] * n_r + ring_of[sg][hit])
    k = np.concatenate(keys) if keys else np.zeros(0, np.int64)
    u, count = np.unique(k, return_counts=True)
    u = u[count % 2 == 1]
    hole, ring = u // n_r + 1, u % n_r                 # hole `hole` lies inside ring `ring`
    outside = np.setdiff1d(np.arange(1, len(raw)), hole[ring == 0])
    if len(outside):
        raise QmeshError(f"{_ring_name(int(outside[0]))} is not inside the outline")
    nested = (ring > 0) & (ring != hole)
    if nested.any():
        i = int(np.flatnonzero(nested)[0])
        raise QmeshError(f"{_ring_name(int(hole[i]))} lies inside {_ring_name(int(ring[i]))}; "
                         "holes must be disjoint")


class Polygon(Domain):
    """A simple polygon (either orientation, convex or not) whose points are the fixed seeds."""

    def __init__(self, points: Ring, tags: ArrayLike | None = None, names: Names | None = None) -> None:
        super().__init__(points, (), tags=None if tags is None else [tags],
                         names=None if names is None else names)

    @property
    def points(self) -> NDArray[np.float64]:
        """The corners, counter-clockwise."""
        return self._rings[0]

    def __repr__(self) -> str:
        return f"Polygon({len(self.points)} points, area={self.area:.6g})"


def Disk(vb: int, radius: float = 1.0, center: ArrayLike = (0.0, 0.0)) -> Polygon:
    """The regular `vb`-gon inscribed in the circle: the chapter's unit-disk domain (Section 2.3.3)."""
    if isinstance(vb, bool) or not isinstance(vb, (int, np.integer)):
        raise QmeshError(f"VB must be an integer, got {vb!r}")
    if vb < 3:
        raise QmeshError(f"VB must be at least 3, got {vb}")
    if vb > MAX_POINTS:
        raise QmeshError(f"VB = {vb} is too large (the limit is {MAX_POINTS:.0e})")
    radius = checks.real(radius, "radius", low=0, low_open=True)
    try:
        c = np.asarray(center, dtype=float)
    except (TypeError, ValueError):
        raise QmeshError(f"center must be two finite numbers, got {center!r}") from None
    if c.shape != (2,) or not np.all(np.isfinite(c)):
        raise QmeshError(f"center must be two finite numbers, got {center!r}")
    t = 2 * np.pi * np.arange(vb) / vb
    return Polygon(c + radius * np.column_stack([np.cos(t), np.sin(t)]))


def as_domain(obj: object, name: str = "domain") -> Domain:
    """`obj` if it is a Domain (Polygon and Disk are), else QmeshError naming the argument."""
    if isinstance(obj, Domain):
        return obj
    raise QmeshError(f"{name} must be a qmesh.Domain, Polygon or Disk, got {type(obj).__name__}"
                     + (" (wrap an array of points as qmesh.Polygon(points))"
                        if isinstance(obj, (np.ndarray, list, tuple)) else ""))
