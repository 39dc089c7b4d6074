"""Corners sharp in the metric: their two sides split at matching distances from the apex.

In a wedge of metric angle θ the diametral ellipse of a subsegment of length ℓ at distance r
from the apex reaches the other side as soon as ℓ ≳ 2rθ, so a boundary point on one side
encroaches the other side's subsegment. Split at its midpoint, the new point encroaches the first
side in turn, and so on: the splits stop only when every subsegment is shorter than ~2rθ, 1/θ
points per octave of r (thousands below 1°, past the run's budget). Points on the two sides at
the same metric distance from the apex do not encroach each other's subsegments (the triangle
apex–a–c they make is isosceles with base angles 90° − θ/2, so the point of the other side sees
each neighbouring subsegment under at most 90° + θ/2 − α with α ≥ θ/2); the wedge is then a
chain of isosceles trapezoids, each cyclic (q_ij = 0 on its diagonal, ≥ 0 on its other edges)
— the concentric shells of Ruppert-style refinement, laid across the corner.

So the run starts from boundary points laid at the same distances on both sides of every sharp
corner (matched_boundary_points), and a subsegment encroached by a boundary point c on the other
side of a sharp corner is split at c's own metric distance from the apex (its *mirror*), not at
its midpoint: the one split matches c and ends the exchange. A mirror within MARGIN of an end of
its subsegment is not made (the trapezoid it leaves would be short against its width, and
round-off could tip its q_ij = 0 diagonal below zero): the ordinary split halves towards it.
For a constant Q, where the metric is affine and a mirror exact; corners of SHARP degrees
or more keep the ordinary splits (the meshes of domains without such corners are unchanged).
A field's metric (its shape, no s) is taken at the apex, where a smooth field is nearly
constant over the small subsegments beside a sharp corner, for corners under SHARP_SHARED
degrees: their ordinary splits crowd past any target (a random polygon's 0.12° corner in
1 : 900 was refused at 6 000 vertices, asking for 13 500). A varying s keeps the ordinary
splits (its encroachment is the lifted test, not the metric's ellipse).

A medium's faces (MEDIA.md §2) take the same matching in their own region's metric for corners
under SHARP_SHARED degrees (between it and SHARP their ordinary splits stop within a few dozen
points, and matched tips of 2–3° made small triangles that raised the inclusion preset's κ2 by
half): a side of a corner is the run of segments on one partition edge (side_runs), since the
points that faces meshed before shared on it are the face's seeds; and a point a face meshed
later puts on a side of a finished face's corner is matched there by its mirror
(mirrored_in_face), handed back across the interface.
"""

from __future__ import annotations

import math

import numpy as np

SHARP = 3.0        # degrees: corners below this in the metric (at the apex) split by mirrors
COS_SHARP = math.cos(math.radians(SHARP))
MARGIN = 0.1       # a mirror this close (share of the subsegment) to an end is not made
SHARP_SHARED = 1.0  # degrees: below this, a point a neighbour puts on a corner's side is mirrored
COS_SHARP_SHARED = math.cos(math.radians(SHARP_SHARED))


def metric_at(anisotropy, X: np.ndarray) -> np.ndarray:
    """The metric ∇²s at the points X, (len(X), 2, 2)."""
    if anisotropy.is_constant:
        return np.broadcast_to(anisotropy.H, (len(X), 2, 2))
    return np.asarray(anisotropy.hessian(X), dtype=float)


def _into(domain) -> np.ndarray:
    """The segment that ends at each seed (segment k starts at seed k)."""
    into = np.empty(len(domain.segments), np.int64)
    into[domain.segments[:, 1]] = np.arange(len(domain.segments))
    return into


def _sides(domain) -> tuple[np.ndarray, np.ndarray]:
    """From every seed, the vectors to the previous and to the next seed of its ring."""
    A, B = domain.segment_ends
    return A[_into(domain)] - domain.seeds, B - domain.seeds


def corner_cosines(domain, anisotropy) -> np.ndarray:
    """The cosine of the metric angle of the domain at every seed, measured with the metric
    there, between its incoming and outgoing segment."""
    a, b = _sides(domain)
    H = metric_at(anisotropy, domain.seeds)
    return np.einsum("ki,kij,kj->k", a, H, b) / np.sqrt(
        np.einsum("ki,kij,kj->k", a, H, a) * np.einsum("ki,kij,kj->k", b, H, b))


def corner_angles(domain, anisotropy) -> np.ndarray:
    """The metric angle (degrees) of the domain at every seed (corner_cosines)."""
    cos = np.clip(corner_cosines(domain, anisotropy), -1.0, 1.0)
    return np.degrees(np.arccos(cos))                    # measures only


def sharp_seeds(domain, anisotropy) -> np.ndarray:
    """Mask of the seeds that are convex corners below SHARP degrees in the metric of a constant
    Q (where the metric is affine and a mirror exact), or below SHARP_SHARED in a field's metric
    at the apex (decided on the cosine, so that no CPU-dispatched function reads the decision's
    last bits). A reflex corner (a slit's tip) has Ω on the far side of its small angle: it is
    not one."""
    if (anisotropy.potential and not anisotropy.is_constant) or not len(domain.segments):
        return np.zeros(len(domain.seeds), bool)
    a, b = _sides(domain)
    convex = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] < 0          # Ω on the left: a left turn
    # a medium's face: only under SHARP_SHARED (a star's tips of 2–3° keep their ordinary
    # splits: matched, their small triangles raised κ2 of the inclusion preset by half)
    # a field's metric (no s: its shape, smooth near the apex): only under SHARP_SHARED too, the
    # corners whose ordinary splits crowd past any target (0.12° in 1 : 900 needed 13 500 vertices)
    shared = getattr(domain, "media_face", False) or not anisotropy.is_constant
    limit = COS_SHARP_SHARED if shared else COS_SHARP
    return convex & (corner_cosines(domain, anisotropy) > limit)


def side_runs(domain) -> tuple[np.ndarray, np.ndarray]:
    """For every segment, the first and the last segment of its *side*: the run of segments it
    lies in that continue one another on one straight edge. A medium's face (`media_face`) has
    the points its neighbours share on its edges as seeds, so one edge of the partition (its
    segments' tag) is several segments; elsewhere every segment is a side of its own."""
    k = np.arange(len(domain.segments))
    if not getattr(domain, "media_face", False) or not len(k):
        return k, k
    prev = _into(domain)[domain.segments[:, 0]]
    A, B = domain.segment_ends
    E = B - A
    tags = domain.segment_tags
    same = (tags[prev] == tags) & (np.einsum("ki,ki->k", E[prev], E) > 0)   # straight on
    head, tail = np.where(same, prev, k), np.full(len(k), -1, np.int64)
    tail[prev[same]] = k[same]
    tail = np.where(tail >= 0, tail, k)
    while True:                                     # pointer doubling: log(side length) steps
        h2, t2 = head[head], tail[tail]
        if np.array_equal(h2, head) and np.array_equal(t2, tail):
            return head, tail
        head, tail = h2, t2


def mirrored(P, a, b, c, edge_id, is_seed, new, domain, sharp, anisotropy):
    """`new` (the split points of the subsegments a[k]→b[k], encroached by the points c[k]) with
    the mirror of c in place of the ordinary point where c is a boundary point on the other side
    of a sharp corner (`sharp`: sharp_seeds) that a→b's side shares: the point of a→b at c's
    metric distance from the apex, measured with the metric at the apex; and the mask of the
    mirrors made. `edge_id[i]`: the segment of a boundary point i that is not a seed
    (`is_seed[i]`: seed i starts segment i). A side is a run of straight segments (`side_runs`)."""
    made = np.zeros(len(a), bool)
    if not len(a) or not sharp.any():
        return new, made
    seg = domain.segments
    into = _into(domain)
    head, tail = side_runs(domain)
    seg_ab = np.where(is_seed[a], a, edge_id[a])                 # a→b runs along its segment
    c_seed = is_seed[c]
    on = c_seed | (edge_id[c] >= 0)
    cs = np.where(c_seed, c, 0)
    # the sides of c: a seed lies on the one its segment starts and the one it ends
    first = head[np.where(c_seed, cs, np.maximum(edge_id[c], 0))]
    second = np.where(c_seed, head[into[cs]], first)
    ends = np.column_stack([seg[head, 0], seg[tail, 1]])         # a side's first and last seed
    side_ab = head[seg_ab]
    apex = np.full(len(a), -1, np.int64)
    for o in (ends[side_ab, 0], ends[side_ab, 1]):
        shares = np.zeros(len(a), bool)
        for s in (first, second):
            shares |= (s != side_ab) & ((ends[s, 0] == o) | (ends[s, 1] == o))
        shares &= on & sharp[o] & ~(c_seed & (c == o)) & (apex < 0)
        apex = np.where(shares, o, apex)
    k = np.flatnonzero(apex >= 0)
    if not len(k):
        return new, made
    O = domain.seeds[apex[k]]
    far = np.where(ends[side_ab[k], 0] == apex[k], ends[side_ab[k], 1], ends[side_ab[k], 0])
    U = domain.seeds[far] - O
    H = metric_at(anisotropy, O)
    norm = lambda V: np.sqrt(np.einsum("ki,kij,kj->k", V, H, V))          # noqa: E731
    rc, ra, rb = norm(P[c[k]] - O), norm(P[a[k]] - O), norm(P[b[k]] - O)
    lo, hi = np.minimum(ra, rb), np.maximum(ra, rb)
    inside = (rc > lo + MARGIN * (hi - lo)) & (rc < hi - MARGIN * (hi - lo))
    out = np.array(new, dtype=float)
    k = k[inside]
    out[k] = O[inside] + (rc[inside] / norm(U)[inside])[:, None] * U[inside]
    made[k] = True
    return out, made


def matched_boundary_points(domain, anisotropy, points: np.ndarray, seg: np.ndarray):
    """The boundary points (points on segments seg) with both sides of every sharp corner split
    at the same metric distances from its apex: up to the length R of its shorter side, the
    longer side takes the shorter side's distances (and R itself) in place of its own points,
    so the mirrors of the conformity find the corner matched (one corner after another; what a
    later corner undoes of an earlier one the mirrors mend)."""
    sharp = np.flatnonzero(sharp_seeds(domain, anisotropy))
    if not len(sharp) or not len(points):
        return points, seg
    S = domain.segments
    into = _into(domain)
    X = domain.seeds
    for o in sharp.tolist():                  # a loop over the sharp corners, not the points
        H = metric_at(anisotropy, X[o:o + 1])[0]
        sides = (o, int(into[o]))             # outgoing (starts at o) and incoming (ends at o)
        far = (S[o, 1], S[into[o], 0])
        U = [X[f] - X[o] for f in far]
        length = [float(np.sqrt(np.einsum("i,ij,j->", u, H, u))) for u in U]
        radius = [_radii(points, seg, e, X[o], U[i], length[i]) for i, e in enumerate(sides)]
        s = int(length[1] < length[0])        # the shorter side, g the longer
        g = 1 - s
        R = length[s]
        on_g = seg == sides[g]
        count = int(on_g.sum())
        spacing = length[g] / (count + 1)
        r_new = radius[s][seg == sides[s]]
        if length[g] - R > 0.25 * spacing:
            r_new = np.append(r_new, R)
        drop = on_g.copy()
        drop[on_g] = radius[g][on_g] < R + 0.5 * spacing
        new = X[o] + (np.sort(r_new) / length[g])[:, None] * U[g]
        points = np.concatenate([points[~drop], new])
        seg = np.concatenate([seg[~drop], np.full(len(new), sides[g], seg.dtype)])
    return points, seg


def _radii(points, seg, e, apex, u, length):
    """Metric distance from the apex (along u, of metric length `length`) of the points on
    segment e (the others: +inf)."""
    r = np.full(len(points), np.inf)
    on = seg == e
    r[on] = np.einsum("ki,i->k", points[on] - apex, u) / (u[0] * u[0] + u[1] * u[1]) * length
    return r


def mirrored_in_face(P, u, v, w, out, at_part, part, anisotropy, x):
    """`x` (the split points of the boundary edges u[k]→v[k] of a finished face mesh of a medium,
    encroached by w[k]) with the mirror of w in place of the ordinary point where w is a point
    of the face's boundary on the other side of a corner sharp in the face's constant metric:
    the point of u→v at w's metric distance from the corner. A point a neighbour put on an
    interface by that corner (MEDIA.md §2) is then matched by one split, as the face's own run
    matches them (`mirrored`), not by splits that halve towards the corner without end.
    `out[i]`: the partition edge of the boundary edge leaving vertex i; `at_part[i]`: whether i
    is a partition point (its edge is then ambiguous). The wedge is the face's own: the
    triangle u, v, w lies in the face and between the corner's two sides."""
    if not len(u) or not anisotropy.is_constant:
        return x
    e, ew = out[u], np.where(at_part[w], -1, out[w])
    ends, H = part.edges, np.asarray(anisotropy.H, float)
    norm = lambda V: np.sqrt(np.einsum("ki,ij,kj->k", V, H, V))           # noqa: E731
    out_x = np.array(x, dtype=float)
    for j in (0, 1):                            # the corner at either end of u→v's edge
        o = ends[e, j]
        meets = (ends[np.maximum(ew, 0)] == o[:, None]).any(axis=1)     # w's edge ends at o too
        k = np.flatnonzero((ew >= 0) & (ew != e) & meets)
        if not len(k):
            continue
        O = part.points[o[k]]
        U = part.points[ends[e[k], 1 - j]] - O
        far_w = np.where(ends[ew[k], 0] == o[k], ends[ew[k], 1], ends[ew[k], 0])
        V = part.points[far_w] - O
        sharp = np.einsum("ki,ij,kj->k", U, H, V) > COS_SHARP_SHARED * norm(U) * norm(V)
        rc, ra, rb = norm(P[w[k]] - O), norm(P[u[k]] - O), norm(P[v[k]] - O)
        lo, hi = np.minimum(ra, rb), np.maximum(ra, rb)
        ok = sharp & (rc > lo + MARGIN * (hi - lo)) & (rc < hi - MARGIN * (hi - lo))
        out_x[k[ok]] = O[ok] + (rc[ok] / norm(U)[ok])[:, None] * U[ok]
    return out_x
