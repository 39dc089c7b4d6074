"""The Q-Delaunay triangulation: the lower convex hull of the points lifted onto z = s(x).

MATH.md "Connectivity" and the chapter's (2.74)–(2.75): the lower hull is the regular triangulation
with weights w_i = |x_i|² − s(x_i); for constant Q it is the Delaunay triangulation of the points
mapped by H^{1/2}, and then every interior stiffness off-diagonal q_ij is ≥ 0.

Three constructions:
- `lower_hull` builds it from scratch with Qhull (scipy.spatial.ConvexHull): the reference;
- `first_triangulation`, the mesher's initial one: beyond a few thousand points the lower hull
  of the points lifted by a metric (H for a constant Q, the mean Hessian for a varying s) with
  heights perturbed by 1e-9, so that its cost follows N whatever the input's ties (points on
  one metric circle, as on Disk(30000) with Q = I, make Qhull's exact modes quadratic),
  then `restore`;
- `restore` repairs a valid triangulation whose vertices moved or were split in, by Lawson flips
  of locally non-regular edges (Lawson 1977; Edelsbrunner & Shah 1996 for the weighted case),
  in parallel batches. Because s is strictly convex every lifted point is a hull vertex and
  every locally non-regular edge has a convex quadrilateral, so flipping terminates at the lower
  hull. Cost per round is O(M) array work with no sort.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, Delaunay, QhullError

from qmesh.conductivity.anisotropy import Anisotropy, adj2
from qmesh.geometry import topology
from qmesh.errors import QmeshError
from qmesh.geometry.portable import cholesky2, cov2, eigh2, eigvalsh2, matmul2, moments2, times2
from qmesh.geometry.triangles import chunks, columns, signed_areas

class Crowded(QmeshError):
    """Points closer than round-off allows: no valid triangulation of them can be told apart."""


FLIP_TOL = 1e-10   # relative violation below which an edge counts as regular (ties stay put)
VERTICAL = 1e-6   # |n_z| of a lifted facet below this: vertical (collinear points on the hull), not lower


def lifted_heights(P: np.ndarray, anisotropy) -> np.ndarray:
    """Heights z = s(x) with an affine function removed (the lower hull does not see it)."""
    c = P.mean(axis=0)
    if anisotropy.is_constant:
        d = P - c
        return 0.5 * np.einsum("ni,ij,nj->n", d, anisotropy.H, d)
    z = np.asarray(anisotropy.s(P), dtype=float)
    g = np.asarray(anisotropy.grad(c[None]), dtype=float)[0]
    return z - times2(P - c, g[:, None])[:, 0]


def orient_ccw(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Triangles reordered counter-clockwise where they were clockwise."""
    T = np.array(T, dtype=np.int64, copy=True)
    cw = signed_areas(P, T) < 0
    T[cw] = T[cw][:, [0, 2, 1]]
    return T


def lower_hull(P: np.ndarray, anisotropy) -> np.ndarray:
    """The Q-Delaunay triangulation of P from scratch (Qhull), counter-clockwise.

    Every input point stays a vertex: Qhull would drop a point only if it were not on the lower
    hull, which a strictly convex s rules out. Where the lifted points are (nearly) on one
    plane — points on one ellipse of the metric and nothing else, so every triangulation of
    them is regular — Qhull may fail or drop points; then a constant Q takes the metric
    Delaunay triangulation (Qhull's 2-D handles co-circular points) and a varying s a joggled
    hull. A point still dropped means a duplicate or an s that is not convex, and is reported.
    """
    P = np.asarray(P, dtype=float)
    if len(P) == 3:                                     # one triangle: Qhull needs four points
        return orient_ccw(P, np.array([[0, 1, 2]]))
    scale = np.ptp(P, axis=0).max()
    z = lifted_heights(P, anisotropy)
    zs = np.ptp(z)
    T = None
    if zs > 1e-12 * (np.abs(z).max() + scale * scale):
        X = np.column_stack([(P - P.mean(axis=0)) / scale, z / zs])
        T = _valid(P, _lower_facets(X, "Qt"))
        if T is None and not anisotropy.is_constant:
            T = _valid(P, _lower_facets(X, "Qt QJ"))
    if T is None:
        L = cholesky2(anisotropy.H) if anisotropy.is_constant else np.eye(2)
        T = _valid(P, _delaunay(times2(P, L)))
    if T is None:
        raise QmeshError("some points are not vertices of the lower hull (duplicate points, or "
                         "s is not strictly convex there)")
    return T


def _lower_facets(X: np.ndarray, options: str) -> np.ndarray | None:
    """The downward facets of the 3-D hull of X (vertical ones lie along the hull's boundary)."""
    try:
        hull = ConvexHull(X, qhull_options=options)
    except QhullError:
        return None
    return hull.simplices[hull.equations[:, 2] < -VERTICAL]


def _valid(P: np.ndarray, T: np.ndarray | None) -> np.ndarray | None:
    """T counter-clockwise without flat triangles, if it still uses every point; else None."""
    if T is None:
        return None
    T = orient_ccw(P, T)
    T = T[signed_areas(P, T) > 0]
    used = np.zeros(len(P), bool)
    used[T.ravel()] = True
    return T if used.all() else None


def _delaunay(X: np.ndarray, options: str | None = None) -> np.ndarray:
    try:
        return Delaunay(X, qhull_options=options).simplices
    except QhullError as err:
        raise QmeshError(f"Qhull could not triangulate the points: {err}") from None


def q_delaunay(P: np.ndarray, anisotropy) -> np.ndarray:
    """The Q-Delaunay triangulation from scratch, by the cheapest exact route.

    For a constant Q it is the Delaunay triangulation of the points mapped by Lᵀ (LLᵀ = H),
    which Qhull builds in 2-D several times faster than the 3-D lower hull; a varying s takes
    `lower_hull`. Ties (co-circular points) may be split either way.
    """
    if not anisotropy.is_constant:
        return lower_hull(P, anisotropy)
    X = times2(P, cholesky2(anisotropy.H))
    try:
        tri = Delaunay(X)
    except QhullError as err:
        raise QmeshError(f"Qhull could not triangulate the points: {err}") from None
    if len(tri.coplanar):
        raise QmeshError(f"{len(tri.coplanar)} points are not vertices of the triangulation "
                         "(duplicate points?)")
    return orient_ccw(P, tri.simplices)


EXACT_MAX = 4000     # up to this many points the first triangulation is Qhull's exact hull
FIRST_ROUNDS = 100_000   # flip rounds allowed (only a defect could need them all)
METRIC_ROUNDS = 2000     # flip rounds in a metric without s, where flips may cycle ...
WATCH = 200              # ... and past this round an edge flipped away a second time (a cycle)
                         # is kept
VIOLATION_CHUNK = 16_384    # edges tested at once (bounds the temporary memory; 2^17 was 15% slower)
THIN = 100.0         # a point set this many times longer than wide is joggled for Qhull (_thin)
PERTURB = 1e-9       # lifted heights (range 1) raised by up to this: ties broken, cost O(N log N)


def first_triangulation(P: np.ndarray, anisotropy, boundary: np.ndarray | None = None,
                        closed_form=None) -> tuple[np.ndarray, np.ndarray]:
    """The Q-Delaunay triangulation of P from scratch, and its twins; cost O(N log N) always.

    Up to EXACT_MAX points, `lower_hull` (Qhull's exact modes: ties are split as they always
    were). Beyond, or where that hull loses points, the lower hull of the points mapped by
    x ↦ x L (LLᵀ = H, or the mean shape of the Hessian over P for a varying s) lifted to
    ½|xL|², the heights of the `boundary` points (default: all) perturbed by 1e-9 of their
    range: Qhull's exact modes are quadratic on ties (Disk(30000) with Q = I: its lifted
    boundary is one plane); the perturbation breaks them at random (points closer than
    √1e-9 may then leave the hull: there, Qhull's exact 2-D Delaunay of the mapped points, and
    for a metric without s, where that folds too, the lower hull of its mean quadratic).
    `restore` then flips every edge left locally non-regular (for a constant Q only the
    perturbed points' stars can be), with the local tangent-plane test (2.74)–(2.75), which
    needs no global precision (s = exp(20x) + exp(20y) spans 1e17 in curvature over Disk(32),
    beyond any global lifting).

    `closed_form(hull_of)`, beyond EXACT_MAX points, may give the perturbed hull's triangles
    and their twins without building all of it (lattice_delaunay.py: the lattice's interior
    in closed form);
    `hull_of(among)` is the perturbed hull of the points in the mask `among`, lifted exactly as
    in the whole set's. It returns None where it cannot; the whole hull is built then.
    """
    P = np.asarray(P, dtype=float)
    if len(P) == 3:
        T = orient_ccw(P, np.array([[0, 1, 2]]))
        return T, topology.twins(T)
    T = _exact_lower_hull(P, anisotropy) if len(P) <= EXACT_MAX else None
    candidates = twin = None
    if T is None:
        perturbed = np.ones(len(P), bool) if boundary is None else np.asarray(boundary, bool)
        L = _mean_factor(P, anisotropy)
        built = None if closed_form is None else closed_form(
            lambda among: _perturbed_hull(P, L, perturbed, among))
        if built is None:
            T = _perturbed_hull(P, L, perturbed)
        else:
            T, twin = built
        if anisotropy.is_constant:      # the rest is exact: only the perturbed points' stars
            near = topology.touching(T, perturbed)
            candidates = (3 * np.flatnonzero(near)[:, None] + np.arange(3)).ravel()
    # from a start this far off, the flips may run along a needle of the metric for many rounds
    # (660 for exp(20x) + exp(20y)); later rounds touch only the last round's triangles
    try:
        twin = topology.twins(T) if twin is None else twin
    except ValueError:      # round-off decided the orientation of a flat triangle: exact 2-D
        (T, twin), candidates = _fallback(P, anisotropy), None
    T, twin, _ = restore(P, T, twin, anisotropy, candidates=candidates, owned=True)
    return T, twin


def _exact_lower_hull(P: np.ndarray, anisotropy) -> np.ndarray | None:
    """`lower_hull`, or None where it fails (or there is no s to lift by)."""
    if not anisotropy.potential:
        return None
    try:
        return lower_hull(P, anisotropy)
    except QmeshError:
        return None


def _fallback(P: np.ndarray, anisotropy) -> tuple[np.ndarray, np.ndarray]:
    """A triangulation (and its twins) where the lifted hull's is not one: Qhull's exact 2-D
    Delaunay of the mapped points, the same along their principal axes, then, for a metric
    without s, the lower hull of its mean quadratic; Crowded where none is (a constant Q or an
    s: the 2-D one's lost points said as they are)."""
    routes = [_exact_delaunay, _aligned_delaunay]
    if not anisotropy.potential:
        routes.append(_mean_lower_hull)
    lost = None          # the exact route's lost points, said as they are (a constant Q or an s)
    for route in routes:
        try:
            T = route(P, anisotropy)
            return T, topology.twins(T)
        except QmeshError as e:
            if route is _exact_delaunay and anisotropy.potential:
                lost = e
        except ValueError:
            pass
    if lost is not None:
        raise lost
    raise Crowded("the points the boundary needs are closer than round-off allows there")


def _exact_delaunay(P: np.ndarray, anisotropy, aligned: bool = False) -> np.ndarray:
    """Qhull's exact 2-D Delaunay triangulation of the points mapped by the (mean) metric
    factor: the fallback where the perturbed lifted hull leaves a flat triangle whose
    orientation round-off decided (a sliver corner's concentric shells); `restore` then
    makes it regular for a varying s. `aligned`: the mapped points turned to their principal
    axes first (`_aligned_delaunay`)."""
    X = times2(P - P.mean(axis=0), _mean_factor(P, anisotropy))
    if aligned:
        _, V = eigh2(moments2(X, np.ones(len(X))))
        X = times2(X, V[:, ::-1])                          # the longest direction first
    T = _valid(P, _delaunay(X / np.abs(X).max()))
    if T is None:
        raise QmeshError("some points are not vertices of the triangulation (duplicate points?)")
    return T


def _aligned_delaunay(P: np.ndarray, anisotropy) -> np.ndarray:
    """`_exact_delaunay` along the points' principal axes: a sliver a few tenths of a degree
    wide in the metric lies at a slant in the mapped plane, where Qhull's Delaunay of its
    matched sides (isosceles trapezoids, each cyclic, a few 1e-6 of the domain apart near the
    apex) can leave flat triangles; along an axis it did not, in the cases seen."""
    return _exact_delaunay(P, anisotropy, aligned=True)


def _mean_lower_hull(P: np.ndarray, anisotropy) -> np.ndarray:
    """`lower_hull` of the points lifted onto the quadratic of the mean metric (`_mean_factor`),
    the route a constant Q takes: the last resort where Qhull's 2-D Delaunay folds (the points
    of a straight side of a polygon 300 times longer than wide, nearly in line, for a metric
    without s); `restore` then makes it regular."""
    L = _mean_factor(P, anisotropy)
    return lower_hull(P, Anisotropy.constant(adj2(matmul2(L, L.T))))


def _mean_factor(P: np.ndarray, anisotropy) -> np.ndarray:
    """L with LLᵀ the metric (constant Q) or the mean Hessian over (up to 4096 of) the points."""
    if anisotropy.is_constant:
        return cholesky2(anisotropy.H)
    sample = P[:: max(1, len(P) // 4096)]
    with np.errstate(all="ignore"):
        H = np.asarray(anisotropy.hessian(sample), dtype=float)
    H = H[np.isfinite(H).all(axis=(1, 2))]
    # each Hessian by its own norm: the mean then follows the shapes, not the steepest place
    if len(H):
        H = (H / np.abs(H).max(axis=(1, 2))[:, None, None]).mean(axis=0)
    L = cholesky2(0.5 * (H + H.T)) if np.shape(H) == (2, 2) else np.full((2, 2), np.nan)
    return L if np.isfinite(L).all() and L[0, 0] > 0 and L[1, 1] > 0 else np.eye(2)


def _perturbed_hull(P: np.ndarray, L: np.ndarray, perturbed: np.ndarray,
                    among: np.ndarray | None = None) -> np.ndarray:
    """The lower hull of the points mapped by L and lifted to ½|xL|², the heights of the
    `perturbed` points (the boundary's: where ties live) raised by a fixed random PERTURB share
    of the lifted range: no four lifted points are coplanar, so Qhull's cost follows N, and the
    positions stay exact, so collinear hull points give vertical facets, never slivers.
    With the mask `among`: the hull of those points only, each lifted as in the whole set."""
    X = times2(P - P.mean(axis=0), L)
    X /= np.abs(X).max()
    z = 0.5 * np.einsum("ni,ni->n", X, X)
    z /= max(z.max(), 1e-300)
    u = np.random.default_rng(0).random(len(P)) * perturbed
    idx = np.arange(len(P)) if among is None else np.flatnonzero(among)
    X, z, u, Q = X[idx], z[idx], u[idx], P[idx]
    lifted = np.column_stack([X, z + PERTURB * u])
    T = None
    if _thin(X):        # nearly one curve once lifted: Qhull's exact merging takes seconds per
        # 1e4 points, its joggle a hundredth. The 2-D joggled Delaunay first: the joggled lifted
        # hull tilts the vertical facets of a straight side's points into flat lower facets
        # and loses the points the joggle moved off the line (most strips thin in a strong
        # metric), a whole build for nothing; `restore` settles what either joggle decided
        try:
            T = _valid(Q, _delaunay(X, "QJ"))
        except QmeshError:
            T = None
        if T is None:
            T = _valid(Q, _lower_facets(lifted, "QJ"))
    if T is None:
        T = _valid(Q, _lower_facets(lifted, "Qt"))
    if T is None:       # points closer than the perturbation allows: the exact 2-D route
        T = _valid(Q, _delaunay(X))
    if T is None:
        raise QmeshError("some points are not vertices of the triangulation (duplicate points?)")
    return idx[T]


def _thin(X: np.ndarray) -> bool:
    """Whether the points X (metric coordinates) spread THIN times further along one direction
    than across it: a strip of the domain thin in the metric. Their lifted points are nearly
    one curve, a near-degenerate input Qhull's exact mode resolves slowly; its joggled mode
    ("QJ", input moved by ~1e-11) is fast, and `restore`'s exact local test then settles
    every edge the joggle decided."""
    if len(X) < 3:
        return False
    w = eigvalsh2(cov2(X))
    return bool(w[0] <= 0 or w[1] > THIN**2 * w[0])


def _violation(P, T, twin, h, anisotropy, s, g):
    """`_violation_chunk` over h in chunks of VIOLATION_CHUNK (its ~25 temporaries per edge
    took 660 bytes per vertex at once: the mesher's peak memory at 1e6)."""
    xy = columns(P)                                     # once, not for every chunk
    if len(h) <= VIOLATION_CHUNK:
        return _violation_chunk(xy, T, twin, h, anisotropy, s, g)
    return np.concatenate([_violation_chunk(xy, T, twin, h[k:k + VIOLATION_CHUNK], anisotropy, s, g)
                           for k in range(0, len(h), VIOLATION_CHUNK)])


def _violation_chunk(xy, T, twin, h, anisotropy, s, g):
    """Relative lifted in-circle test of half-edges h: > 0 means locally non-regular; `xy` the
    points' `columns`.

    For the edge u→v of triangle (u, v, a) with b opposite across it, the sign of
    det[[x_r − x_b, y_r − y_b, z_r]]_{r = u, v, a}, with z the lifted height minus b's tangent
    plane, says whether b lies below the plane through the lifted u, v, a ((2.74)–(2.75)).
    """
    Tf = T.ravel()
    g2 = twin[h]
    e2 = g2 % 3
    b = np.take(Tf, g2 - e2 + topology.PRV[e2])
    e1 = h % 3
    base1 = h - e1
    cols = (np.take(Tf, h), np.take(Tf, base1 + topology.NXT[e1]),
            np.take(Tf, base1 + topology.PRV[e1]))
    Px, Py = xy
    xb, yb = np.take(Px, b), np.take(Py, b)
    dx = [np.take(Px, c) - xb for c in cols]                              # u, v, a
    dy = [np.take(Py, c) - yb for c in cols]
    if anisotropy.is_constant:
        (h00, h01), (_, h11) = anisotropy.H
        z = [_lifted(x, y, h00, h01, h11) for x, y in zip(dx, dy)]
    elif not anisotropy.potential:
        # a metric without s: the in-ellipse test in the metric at the quadrilateral's centre,
        # the same for both of its diagonals, so a flip is never undone by its own test
        cx = 0.25 * (Px[cols[0]] + Px[cols[1]] + Px[cols[2]] + xb)
        cy = 0.25 * (Py[cols[0]] + Py[cols[1]] + Py[cols[2]] + yb)
        Hq = np.asarray(anisotropy.hessian(np.column_stack([cx, cy])), dtype=float)
        h00, h01, h11 = Hq[:, 0, 0], Hq[:, 0, 1], Hq[:, 1, 1]
        z = [_lifted(x, y, h00, h01, h11) for x, y in zip(dx, dy)]
    else:
        gb = g[b]
        z = [s[c] - s[b] - gb[:, 0] * x - gb[:, 1] * y for c, x, y in zip(cols, dx, dy)]
    m = []
    for r in range(3):
        m.append(dx[(r + 1) % 3] * dy[(r + 2) % 3])
        m[r] -= dx[(r + 2) % 3] * dy[(r + 1) % 3]
    # the flip must leave two counter-clockwise triangles (u, b, a) and (b, v, a):
    # dx_u dy_a − dy_u dx_a < 0 and dx_v dy_a − dy_v dx_a > 0, which are m[1] > 0 and m[0] > 0
    # (a rounded difference changes sign exactly with its operands)
    convex = (m[1] > 0) & (m[0] > 0)
    p = [zr * mr for zr, mr in zip(z, m)]
    det = p[0] + p[1]
    det += p[2]
    scale = np.abs(p[0])
    scale += np.abs(p[1])
    scale += np.abs(p[2])
    rel = det / np.where(scale > 0, scale, 1.0)
    return np.where(convex, rel, -1.0)


def _lifted(x, y, h00, h01, h11):
    """½ (h00 x² + 2 h01 x y + h11 y²): the height of (x, y) on the metric's paraboloid, in
    place (the same operations, in the same order, as the expression)."""
    z = h00 * x
    z *= x
    t = (2.0 * h01) * x
    t *= y
    z += t
    t = h11 * y
    t *= y
    z += t
    z *= 0.5
    return z


def _canonical(twin: np.ndarray, h: np.ndarray | None = None) -> np.ndarray:
    """One half-edge per interior edge among h (default: all), the smaller id of each pair,
    sorted and unique; O(len(h) log len(h)), no pass over the whole mesh for a few edges."""
    if h is None:          # a block at a time (an arange as long as twin was 48 MB at 1e6)
        return np.concatenate([np.flatnonzero(twin[c] > np.arange(c.start, c.stop)) + c.start
                               for c in chunks(len(twin))])
    tw = twin[h]
    h = np.minimum(h, tw)[tw >= 0]
    return topology.sorted_unique(h)


def _edge_keys(T: np.ndarray, h: np.ndarray, n: int) -> np.ndarray:
    """One number per edge of the half-edges h, from its two vertices (the same both ways)."""
    k = h % 3
    u, v = T[h // 3, k], T[h // 3, topology.NXT[k]]
    return np.minimum(u, v) * n + np.maximum(u, v)


def restore(P: np.ndarray, T: np.ndarray, twin: np.ndarray, anisotropy,
            candidates: np.ndarray | None = None, max_rounds: int | None = None,
            rewritten: list | None = None, owned: bool = False):
    """Flip locally non-regular edges until the triangulation is Q-Delaunay.

    Returns (T, twin, number of flips). Each round flips the edges that are the most violated
    in both of their triangles, so no triangle takes part in two flips of one round. With an
    s, flipping terminates (Lawson): the rounds are capped only against a defect
    (FIRST_ROUNDS; a flip wave along a boundary of 20,000 points in a needle-thin metric takes
    thousands, each touching only the last round's triangles). A metric without s has no
    global lifting, so flips may cycle: past WATCH rounds an edge (its two vertices) flipped
    away a second time is kept (a cycle of one flip a round along a raster's 1 : 10⁴ needle ran
    to the cap, METRIC_ROUNDS, 24 times in one run: 21 of its 23 s), and after METRIC_ROUNDS
    the triangulation is kept as it is (the tensor field's certification decides its edges on
    the element means).
    `rewritten`: a list that receives, each round, the rows of T its flips rewrite.
    `owned`: T and twin are the caller's own, just made (no Step or other array shares them):
    they are flipped in place, not copied first (96 MB at 1e6 vertices).
    """
    if max_rounds is None:
        max_rounds = FIRST_ROUNDS if anisotropy.potential else METRIC_ROUNDS
    s = g = None
    if not anisotropy.is_constant and anisotropy.potential:
        s = np.asarray(anisotropy.s(P), dtype=float)
        g = np.asarray(anisotropy.grad(P), dtype=float)
    cand = _canonical(twin, candidates)
    flips = 0       # after the first round T and twin are restore's own arrays
    flipped = kept = np.empty(0, np.int64)     # past WATCH, without s: edges flipped away, kept
    for rounds in range(max_rounds):
        if len(kept):
            cand = cand[~np.isin(_edge_keys(T, cand, len(P)), kept)]
        if len(cand) == 0:
            return T, twin, flips
        viol = _violation(P, T, twin, cand, anisotropy, s, g)
        bad = cand[viol > FLIP_TOL]
        if len(bad) == 0:
            return T, twin, flips
        rank = np.empty(len(bad))
        rank[np.argsort(viol[viol > FLIP_TOL], kind="stable")] = np.arange(1, len(bad) + 1)
        # the best rank in each triangle that holds a bad edge (only those: a round touches few)
        tris, at = np.unique(np.concatenate([bad // 3, twin[bad] // 3]), return_inverse=True)
        tri_best = np.zeros(len(tris))
        np.maximum.at(tri_best, at, np.concatenate([rank, rank]))
        sel = (tri_best[at[:len(bad)]] == rank) & (tri_best[at[len(bad):]] == rank)
        h = bad[sel]
        tri = np.concatenate([h // 3, twin[h] // 3])
        if rewritten is not None:
            rewritten.append(tri)
        if rounds >= WATCH and not anisotropy.potential:
            key = _edge_keys(T, h, len(P))
            kept = np.union1d(kept, key[np.isin(key, flipped)])
            flipped = np.union1d(flipped, key)
        T, twin = topology.flip(T, twin, h, copy=not owned)
        flips, owned = flips + len(h), True
        touched = (3 * tri[:, None] + np.arange(3)).ravel()
        cand = _canonical(twin, np.concatenate([bad[~sel], touched]))
    if not anisotropy.potential:
        return T, twin, flips
    raise QmeshError("edge flipping did not converge; please report this mesh")
