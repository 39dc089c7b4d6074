"""Planar geometry of polygonal rings, vectorised: areas, inside tests, distances, crossings.

A domain's boundary is a set of directed segments a→b (Ω on the left). Point queries pair each
point only with the segments whose y-range holds it (points sorted by y, each segment taking a
contiguous run of them), so a query costs O(points × segments met by a horizontal line), not
O(points × segments). Every coordinate difference is taken before any product, so far-off or
tiny rings lose no more than round-off relative to their own size.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from qmesh.geometry.orientation import orient
from qmesh.geometry.portable import arctan2, ceil_log2
from qmesh.geometry.topology import sorted_unique
from qmesh.geometry.triangles import extent

MAX_PAIRS = 262_144     # candidate pairs handled at once (~150 bytes each: bounds the temporary memory)


def signed_area(ring: np.ndarray) -> float:
    """Shoelace area of one closed ring (> 0 counter-clockwise), taken about its first point."""
    d = ring - ring[0]
    x, y = d[:, 0], d[:, 1]
    # np.roll(·, -1) written out: the same arrays, without its overhead (a call per ring of a
    # medium); NumPy's pairwise sums, not BLAS's dot, whose last bits depend on the CPU
    xy = (x * np.concatenate([y[1:], y[:1]])).sum()
    return 0.5 * float(xy - (y * np.concatenate([x[1:], x[:1]])).sum())


def _pairs(py: np.ndarray, ylo: np.ndarray, yhi: np.ndarray, order: np.ndarray | None = None):
    """All (point, segment) index pairs with ylo[seg] ≤ py[point] ≤ yhi[seg], chunked.

    Yields arrays (pt, seg) of at most about MAX_PAIRS pairs each (at least one segment's).
    """
    order = np.argsort(py, kind="stable") if order is None else order
    ys = py[order]
    start = np.searchsorted(ys, ylo, side="left")
    count = np.maximum(np.searchsorted(ys, yhi, side="right") - start, 0)
    for seg, at in _runs(start, count):
        yield order[at], seg


def inside(P: np.ndarray, A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Even-odd test of points P against closed rings given as segments A→B (holes included)."""
    P = np.asarray(P, dtype=float)
    odd = np.zeros(len(P), bool)
    ylo, yhi = np.minimum(A[:, 1], B[:, 1]), np.maximum(A[:, 1], B[:, 1])
    for pt, sg in _pairs(P[:, 1], ylo, yhi):
        a, b, p = A[sg], B[sg], P[pt]
        straddle = (a[:, 1] > p[:, 1]) != (b[:, 1] > p[:, 1])
        t = np.where(straddle, (p[:, 1] - a[:, 1]) / np.where(straddle, b[:, 1] - a[:, 1], 1.0), 0.0)
        xc = a[:, 0] + t * (b[:, 0] - a[:, 0])
        hit = straddle & (xc > p[:, 0])
        odd ^= np.bincount(pt[hit], minlength=len(P)) % 2 == 1
    return odd


def distance(P: np.ndarray, A: np.ndarray, B: np.ndarray, reach: float) -> np.ndarray:
    """Distance from each point to the nearest segment A→B, or inf where none is within `reach`.

    Many points, or y-bands that would pair each point with many segments (rings side by
    side): a grid first rules out the points far from every segment (`_grid`), and pairs each
    point of the band along the boundary with the segments that pass near its cell only (or,
    where that list would be long, with the segments of its y-band); fewer points than segments
    (a lattice in a face with a thousand holes) pair by balls around the segments' pieces
    instead (`_ball_pairs`: a tree of the points, no grid over the segments). Every way, the
    same distances."""
    P = np.asarray(P, dtype=float)
    size = len(P) + len(A)
    order = None if size >= GRID_MIN else np.argsort(P[:, 1], kind="stable")
    many = order is None or _band_pairs(P[order, 1], A, B, reach) > GRID_PAIRS * size
    if many and len(P) < len(A):
        cand = _ball_pairs(P, A, B, reach)
        if cand is not None:
            return _nearest(P, A, B, reach, *cand)
    grid = _grid(P, A, B, reach) if many else None
    if grid is None:
        return _distance(P, A, B, reach, order)
    far, cell, reg_cell, reg_seg = grid
    out = np.full(len(P), np.inf)
    near = np.flatnonzero(~far)
    if reg_cell is None:
        out[near] = _distance(P[near], A, B, reach)
        return out
    best = np.full(len(near), np.inf)
    c = cell[near]
    start = np.searchsorted(reg_cell, c, side="left")
    count = np.searchsorted(reg_cell, c, side="right") - start
    for pt, at in _runs(start, count):
        np.minimum.at(best, pt, point_segment_distance(P[near[pt]], A[reg_seg[at]], B[reg_seg[at]]))
    out[near] = np.where(best <= reach, best, np.inf)
    return out


def _nearest(P: np.ndarray, A: np.ndarray, B: np.ndarray, reach: float, pt: np.ndarray,
             sg: np.ndarray) -> np.ndarray:
    """`distance` from candidate pairs (pt, sg) holding every point-segment pair within reach:
    each point's least distance over its pairs, inf where it exceeds reach (or no pair)."""
    by = np.argsort(pt, kind="stable")
    pt, sg = pt[by], sg[by]
    out = np.full(len(P), np.inf)
    if not len(pt):
        return out
    first = np.flatnonzero(np.r_[True, pt[1:] != pt[:-1]])
    best = np.minimum.reduceat(point_segment_distance(P[pt], A[sg], B[sg]), first)
    out[pt[first]] = np.where(best <= reach, best, np.inf)
    return out


GRID_MIN = 20_000       # points and segments from which `distance` uses the grid
BAND_MIN = 2_000        # segments from which crossings and near_points count their y-bands' pairs
GRID_PAIRS = 8          # ... or fewer, when the y-bands would pair them this many times over
REGISTER_MAX = 4        # cell registrations (25 per cell a segment passes) per point and segment
REGISTER_FLOOR = 4_000_000   # registrations allowed whatever the counts (32 MB of keys)


def _runs(start: np.ndarray, count: np.ndarray):
    """(owner, index) pairs for the runs start[i] … start[i] + count[i] − 1, in chunks of
    about MAX_PAIRS pairs (at least one run a chunk)."""
    csum = np.cumsum(count)
    i0 = 0
    while i0 < len(count):
        base = int(csum[i0 - 1]) if i0 else 0
        i1 = max(i0 + 1, int(np.searchsorted(csum, base + MAX_PAIRS, side="right")))
        c = count[i0:i1]
        n = int(c.sum())
        if n:
            owner = np.repeat(np.arange(i0, i1), c)
            yield owner, np.repeat(start[i0:i1], c) + np.arange(n) - np.repeat(np.cumsum(c) - c, c)
        i0 = i1


def _grid(P: np.ndarray, A: np.ndarray, B: np.ndarray, reach: float):
    """(far, cell, reg_cell, reg_seg), or None where the grid would not pay or not be exact.

    far: mask of the points certainly farther than `reach` from every segment. Cells of side
    c ≥ reach/1.5; points every c/2 along the segments mark their cell and the two rings of
    cells around it. A point in an unmarked cell is more than 2c from every such point, so more
    than 2c − c/4 ≥ 1.17·reach from every segment. The same marks register each segment in
    those cells (reg_cell sorted, reg_seg: the segment): a segment within `reach` of a point
    has a sample within 1.5c + c/4 of it, at most two cells away, so it is registered in the
    point's cell `cell`. reg_cell is None where the registrations would be too many."""
    (p_lo, p_hi), (a_lo, a_hi), (b_lo, b_hi) = extent(P), extent(A), extent(B)
    lo = np.minimum(p_lo, np.minimum(a_lo, b_lo))
    hi = np.maximum(p_hi, np.maximum(a_hi, b_hi))
    ext = hi - lo
    n = len(P) + len(A)          # the grid's budget: cells, samples, registrations per item
    c = max(reach / 1.5, float(np.sqrt(ext[0] * ext[1] / (2 * n))), float(ext.max()) / (4 * n))
    scale = float(np.abs(np.concatenate([lo, hi])).max())
    if not (np.isfinite(c) and np.isfinite(ext).all() and c > 1e-12 * scale and c > 0):
        return None
    nx, ny = int(ext[0] / c) + 1, int(ext[1] / c) + 1
    length = np.hypot(*(B - A).T)
    k = np.ceil(2.0 * length / c).astype(np.int64) + 1           # samples per segment, ends included
    if nx * ny > 8 * n + 1024 or k.sum() > 4 * n:
        return None
    seg = np.repeat(np.arange(len(A)), k)
    t = (np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k)) / np.repeat(k - 1, k)
    S = A[seg] + t[:, None] * (B[seg] - A[seg])
    width = nx + 4
    sx = np.clip(((S[:, 0] - lo[0]) / c).astype(np.int64), 0, nx - 1) + 2
    sy = np.clip(((S[:, 1] - lo[1]) / c).astype(np.int64), 0, ny - 1) + 2
    px = np.clip(((P[:, 0] - lo[0]) / c).astype(np.int64), 0, nx - 1) + 2
    py = np.clip(((P[:, 1] - lo[1]) / c).astype(np.int64), 0, ny - 1) + 2
    cell = py * width + px
    around = (np.arange(-2, 3)[:, None] * width + np.arange(-2, 3)).ravel()   # the 5×5 block
    marked = np.zeros((ny + 4) * width, bool)
    own = sorted_unique((sy * width + sx) * len(A) + seg)       # (cell, segment) of the samples
    if 25 * len(own) > max(REGISTER_MAX * n, REGISTER_FLOOR):
        for d in around:
            marked[sy * width + sx + d] = True
        return ~marked[cell], cell, None, None
    key = sorted_unique((own[:, None] + around * len(A)).ravel())
    reg_cell, reg_seg = np.divmod(key, len(A))
    marked[reg_cell] = True
    return ~marked[cell], cell, reg_cell, reg_seg


def _band_pairs(ys: np.ndarray, A: np.ndarray, B: np.ndarray, reach: float) -> int:
    """How many (point, segment) pairs `_distance` would test: the sorted point ordinates `ys`
    inside each segment's y-range widened by `reach` (many rings side by side: many per point)."""
    ylo = np.minimum(A[:, 1], B[:, 1]) - reach
    yhi = np.maximum(A[:, 1], B[:, 1]) + reach
    return int(np.maximum(np.searchsorted(ys, yhi, side="right") - np.searchsorted(ys, ylo, side="left"), 0).sum())


def _distance(P: np.ndarray, A: np.ndarray, B: np.ndarray, reach: float,
              order: np.ndarray | None = None) -> np.ndarray:
    best = np.full(len(P), np.inf)
    ylo = np.minimum(A[:, 1], B[:, 1]) - reach
    yhi = np.maximum(A[:, 1], B[:, 1]) + reach
    for pt, sg in _pairs(P[:, 1], ylo, yhi, order):
        np.minimum.at(best, pt, point_segment_distance(P[pt], A[sg], B[sg]))
    return np.where(best <= reach, best, np.inf)


def point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Euclidean distance from points p to segments a–b, row by row."""
    ab, ap = b - a, p - a
    L2 = np.einsum("ij,ij->i", ab, ab)
    t = np.clip(np.einsum("ij,ij->i", ap, ab) / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
    d = ap - t[:, None] * ab
    return np.hypot(d[:, 0], d[:, 1])


def _on_segment(a, b, p):
    """p collinear with a–b lies within its bounding box."""
    return ((np.minimum(a[:, 0], b[:, 0]) <= p[:, 0]) & (p[:, 0] <= np.maximum(a[:, 0], b[:, 0]))
            & (np.minimum(a[:, 1], b[:, 1]) <= p[:, 1]) & (p[:, 1] <= np.maximum(a[:, 1], b[:, 1])))


def crossings(A: np.ndarray, B: np.ndarray, ia: np.ndarray, ib: np.ndarray) -> np.ndarray:
    """Pairs (i, j), i < j, of segments A→B that touch or cross, other than at a shared endpoint.

    `ia`, `ib` are the point indices of each segment's ends: two segments that share an endpoint
    index (neighbours in a ring) are reported only if they overlap along a line (a spike).
    Candidate pairs come from overlapping y-ranges, then x-ranges; the test is the usual
    orientation predicate with collinear overlaps counted.
    """
    ylo, yhi = np.minimum(A[:, 1], B[:, 1]), np.maximum(A[:, 1], B[:, 1])
    xlo, xhi = np.minimum(A[:, 0], B[:, 0]), np.maximum(A[:, 0], B[:, 0])
    found = []
    # segment j meets segment i's y-range if ylo[j] lies in [ylo[i], yhi[i]] or j starts below i
    # and reaches it; counting each pair from the one with the lower ylo covers both cases.
    # Where the y-bands hold many segments each (rings side by side), balls around the
    # segments' pieces give the candidates instead: the same test on them, the same pairs.
    cand = None
    if len(A) >= BAND_MIN:
        order = np.argsort(ylo, kind="stable")
        if _band_pairs(ylo[order], A, B, 0.0) > GRID_PAIRS * len(A):
            cand = _ball_segment_pairs(A, B)
    chunks = _pairs(ylo, ylo, yhi) if cand is None else _chunks(*cand)
    for i, j in chunks:
        keep = (i != j) & ((ylo[i] > ylo[j]) | ((ylo[i] == ylo[j]) & (i > j)))
        i, j = i[keep], j[keep]                 # ylo[j] ≤ ylo[i] ≤ yhi[j]: y-ranges overlap
        keep = (xlo[i] <= xhi[j]) & (xlo[j] <= xhi[i])
        i, j = i[keep], j[keep]
        a, b, c, d = A[i], B[i], A[j], B[j]
        o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
        proper = (o1 * o2 < 0) & (o3 * o4 < 0)
        touch = (((o1 == 0) & _on_segment(a, b, c)) | ((o2 == 0) & _on_segment(a, b, d))
                 | ((o3 == 0) & _on_segment(c, d, a)) | ((o4 == 0) & _on_segment(c, d, b)))
        shared = (ia[i] == ia[j]) | (ia[i] == ib[j]) | (ib[i] == ia[j]) | (ib[i] == ib[j])
        # neighbours touch at their shared end; they are wrong only when collinear and folding back
        fold = shared & (o1 == 0) & (o2 == 0) & _fold_back(a, b, c, d, ia[i] == ia[j], ia[i] == ib[j],
                                                             ib[i] == ia[j])
        bad = np.where(shared, fold, proper | touch)
        found.append(np.column_stack([np.minimum(i, j)[bad], np.maximum(i, j)[bad]]))
    if not found:
        return np.empty((0, 2), np.int64)
    out = np.concatenate(found)
    return out[np.lexsort((out[:, 1], out[:, 0]))]


def _fold_back(a, b, c, d, aa, ab, ba):
    """Collinear segments a–b and c–d sharing an end (a = c, a = d, b = c, else b = d) overlap:
    walked away from the shared point, both go the same way."""
    s = np.where((aa | ab)[:, None], a, b)                        # the shared point
    u = np.where((aa | ab)[:, None], b, a) - s                    # segment i away from it
    v = np.where((aa | ba)[:, None], d, c) - s                    # segment j away from it
    return np.einsum("ij,ij->i", u, v) > 0


def scanline_intervals(y: np.ndarray, A: np.ndarray, B: np.ndarray):
    """Where each horizontal line y[r] is inside the rings A→B: arrays (row, x_start, x_end).

    Crossings of each line with the segments, sorted along the line, taken in pairs (even-odd).
    """
    y = np.asarray(y, dtype=float)
    ylo, yhi = np.minimum(A[:, 1], B[:, 1]), np.maximum(A[:, 1], B[:, 1])
    rows, xs = [], []
    for r, sg in _pairs(y, ylo, yhi):
        a, b = A[sg], B[sg]
        straddle = (a[:, 1] > y[r]) != (b[:, 1] > y[r])
        r, a, b = r[straddle], a[straddle], b[straddle]
        t = (y[r] - a[:, 1]) / (b[:, 1] - a[:, 1])
        rows.append(r)
        xs.append(a[:, 0] + t * (b[:, 0] - a[:, 0]))
    if not rows:
        return np.empty(0, np.int64), np.empty(0), np.empty(0)
    r, x = np.concatenate(rows), np.concatenate(xs)
    order = np.lexsort((x, r))
    r, x = r[order], x[order]
    # with the half-open straddle rule every line meets each ring an even number of times
    return r[0::2], x[0::2], x[1::2]


def near_points(P: np.ndarray, A: np.ndarray, B: np.ndarray, ia: np.ndarray, ib: np.ndarray,
                reach: float) -> np.ndarray:
    """Pairs (point, segment) with the point within `reach` of a segment it is not an end of,
    by segment, then by the points' ordinates (as the y-sweep meets them).

    Where the y-bands would pair each point with many segments (rings side by side: a raster's
    rows of cells), the candidates come from balls around the segments' pieces instead
    (`_ball_pairs`); the same test then keeps the same pairs, sorted into the sweep's order."""
    size = len(P) + len(A)
    order = np.argsort(P[:, 1], kind="stable")
    if size >= BAND_MIN and _band_pairs(P[order, 1], A, B, reach) > GRID_PAIRS * size:
        cand = _ball_pairs(P, A, B, reach)
        if cand is not None:
            pt, sg = cand
            keep = (pt != ia[sg]) & (pt != ib[sg])
            pt, sg = pt[keep], sg[keep]
            close = point_segment_distance(P[pt], A[sg], B[sg]) <= reach
            pt, sg = pt[close], sg[close]
            rank = np.empty(len(P), np.int64)
            rank[order] = np.arange(len(P))
            by = np.lexsort((rank[pt], sg))
            return np.column_stack([pt[by], sg[by]])
    ylo = np.minimum(A[:, 1], B[:, 1]) - reach
    yhi = np.maximum(A[:, 1], B[:, 1]) + reach
    found = []
    for pt, sg in _pairs(P[:, 1], ylo, yhi, order):
        keep = (pt != ia[sg]) & (pt != ib[sg])
        pt, sg = pt[keep], sg[keep]
        close = point_segment_distance(P[pt], A[sg], B[sg]) <= reach
        found.append(np.column_stack([pt[close], sg[close]]))
    return np.concatenate(found) if found else np.empty((0, 2), np.int64)


def _pieces(A: np.ndarray, B: np.ndarray, n: int):
    """Segments cut into pieces no longer than about the median segment: (segment, centre,
    class q) per piece, each piece within 2**(q - 1) of its centre; None if not finite."""
    L = np.hypot(*(B - A).T)
    scale = float(np.abs(np.concatenate([A, B])).max()) if len(A) else 0.0
    if not (np.isfinite(L).all() and np.isfinite(scale)) or not len(A):
        return None
    h = max(float(np.median(L)), float(L.sum()) / (4 * n), 1e-300)
    k = np.maximum(np.ceil(L / h), 1).astype(np.int64)
    seg = np.repeat(np.arange(len(A)), k)
    t = (np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k) + 0.5) / k[seg]
    C = A[seg] + t[:, None] * (B[seg] - A[seg])
    ell = np.maximum(L / k, max(h * 1e-12, 4 * np.finfo(float).eps * scale, 1e-300))[seg]
    q = ceil_log2(ell)
    return seg, C, q, 8 * np.finfo(float).eps * scale


def _ball_pairs(P: np.ndarray, A: np.ndarray, B: np.ndarray, reach: float):
    """(point, segment) pairs, each once, among which every point within `reach` of a segment:
    balls around the pieces of `_pieces`, one radius a class (a point that near a segment is
    that near one of its pieces, so within half the piece's length plus `reach` of its centre);
    None where the pieces are not finite."""
    cut = _pieces(A, B, len(P) + len(A))
    if cut is None or not len(P) or not np.isfinite(P).all():
        return None
    seg, C, q, slack = cut
    tree = cKDTree(P)
    pts, sgs = [], []
    for cls in np.unique(q):
        mine = np.flatnonzero(q == cls)
        r = (float(2.0 ** (cls - 1)) + reach) * (1 + 1e-9) + slack
        hit = tree.sparse_distance_matrix(cKDTree(C[mine]), r, output_type="ndarray")
        pts.append(hit["i"].astype(np.int64))
        sgs.append(seg[mine[hit["j"]]])
    key = sorted_unique(np.concatenate(sgs) * np.int64(len(P)) + np.concatenate(pts))
    return key % len(P), key // len(P)


def _ball_segment_pairs(A: np.ndarray, B: np.ndarray):
    """Segment pairs (i, j), each pair both ways, among which every pair that touches: pieces
    of `_pieces` whose balls meet, a class's pieces against the pieces of its class or below."""
    cut = _pieces(A, B, len(A))
    if cut is None:
        return None
    seg, C, q, slack = cut
    tree = cKDTree(C)
    keys = []
    for cls in np.unique(q):
        mine = np.flatnonzero(q == cls)
        r = float(2.0 ** cls) * (1 + 1e-9) + slack
        hit = tree.sparse_distance_matrix(cKDTree(C[mine]), r, output_type="ndarray")
        other, me = hit["i"].astype(np.int64), mine[hit["j"]]
        low = q[other] <= cls
        a, b = seg[me[low]], seg[other[low]]
        keys.append(np.concatenate([a * np.int64(len(A)) + b, b * np.int64(len(A)) + a]))
    key = sorted_unique(np.concatenate(keys))
    return key // len(A), key % len(A)


def _chunks(i: np.ndarray, j: np.ndarray):
    """The pairs (i, j) in chunks of MAX_PAIRS."""
    for k in range(0, len(i), MAX_PAIRS):
        yield i[k:k + MAX_PAIRS], j[k:k + MAX_PAIRS]


def segment_of(P: np.ndarray, A: np.ndarray, B: np.ndarray, reach: float) -> np.ndarray:
    """Index of a segment A→B each point lies on (within `reach`), or -1; a point on two
    segments (a corner) reports the one it is nearer the start of."""
    P = np.asarray(P, dtype=float)
    best_t = np.full(len(P), np.inf)
    out = np.full(len(P), -1, np.int64)
    ylo = np.minimum(A[:, 1], B[:, 1]) - reach
    yhi = np.maximum(A[:, 1], B[:, 1]) + reach
    for pt, sg in _pairs(P[:, 1], ylo, yhi):
        a, b, p = A[sg], B[sg], P[pt]
        ab = b - a
        L = np.hypot(ab[:, 0], ab[:, 1])
        along = np.einsum("ij,ij->i", p - a, ab) / L
        across = np.abs(ab[:, 0] * (p - a)[:, 1] - ab[:, 1] * (p - a)[:, 0]) / L
        on = (across <= reach) & (along >= -reach) & (along <= L + reach)
        pt, sg, along = pt[on], sg[on], along[on]
        if not len(pt):
            continue
        order = np.lexsort((along, pt))                     # per point, smallest distance along
        pt, sg, along = pt[order], sg[order], along[order]
        first = np.r_[True, pt[1:] != pt[:-1]]
        pt, sg, along = pt[first], sg[first], along[first]
        better = along < best_t[pt]
        best_t[pt[better]] = along[better]
        out[pt[better]] = sg[better]
    return out


def convex_width(V: np.ndarray) -> float:
    """Minimum width of the convex polygon V (its vertices in order, either orientation).

    The width across edge i is the largest distance of a vertex from its line; that vertex is
    the polygon's support point in the direction of the inward normal, found by a binary search
    of the edges' sorted normal angles (rotating calipers, vectorised): O(V log V), where the
    all-pairs test costs O(V²). Written with few NumPy calls (np.roll, np.unwrap spelled out,
    the same operations): a medium asks it of every face.
    """
    V = np.asarray(V, dtype=float)
    if len(V) < 3:
        return 0.0
    if signed_area(V) < 0:
        V = V[::-1]
    n = len(V)
    E = np.concatenate([V[1:], V[:1]]) - V
    theta = arctan2(-E[:, 0], E[:, 1])                   # outward normals (E_y, −E_x), ccw
    dd = np.diff(theta)                                     # np.unwrap(theta), as NumPy takes it
    ddmod = np.mod(dd + np.pi, 2 * np.pi) - np.pi
    ddmod[(ddmod == -np.pi) & (dd > 0)] = np.pi
    fix = ddmod - dd
    fix[np.abs(dd) < np.pi] = 0
    theta[1:] += fix.cumsum()
    theta = np.concatenate([theta, theta + 2 * np.pi, theta + 4 * np.pi])
    j = np.searchsorted(theta, theta[:n] + np.pi) % n      # vertex j supports between θ_{j−1}, θ_j
    inward = np.empty((n, 2))
    inward[:, 0], inward[:, 1] = -E[:, 1], E[:, 0]
    inward /= np.hypot(E[:, 0], E[:, 1])[:, None]
    k = (j[:, None] + np.arange(-1, 2)) % n                 # neighbours too: ties in angle
    d = np.einsum("kmi,kmi->km", inward[:, None, :], V[k] - V[:, None, :])
    return float(np.maximum(0.0, d.max(axis=1).min()))
