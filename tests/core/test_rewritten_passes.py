"""The mesher's passes over every triangle, edge or point, rewritten to make fewer and smaller
temporaries (blocks, in-place arithmetic, one copy of T and twin where there were several),
give the bits of the formulas they replace: each is checked against that formula, written out
here, on random input."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

import qmesh
from qmesh.geometry import topology, triangles
from qmesh.geometry.portable import times2
from qmesh.geometry.triangles import (extent, metric_hessians, metric_measures, rounded,
                                      signed_areas)
from qmesh.mesher import adjust, conform, insert, triangulate

SETTINGS = settings(max_examples=30, deadline=None)
CHAPTER = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
VARYING = qmesh.Anisotropy.from_expression("exp(x) + y**2")


def same_bits(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def random_mesh(n: int, seed: int, jitter: float = 0.0, grid: bool = False):
    """Points in the unit square, their Delaunay triangulation (counter-clockwise) and twins,
    then the points moved by up to `jitter` (so that some edges are no longer regular).
    `grid`: the points and their moves on a grid of step 1/4 (points in line and on one circle:
    minors and determinants that are exactly 0)."""
    rng = np.random.default_rng(seed)
    P = np.unique(rng.integers(0, 5, (n, 2)), axis=0) / 4.0 if grid else rng.random((n, 2))
    T = triangulate.orient_ccw(P, Delaunay(P).simplices)
    move = jitter * (rng.random(P.shape) - 0.5)
    return P + (np.round(4.0 * move) / 4.0 if grid else move), T, topology.twins(T)


@pytest.fixture(scope="module", autouse=True)
def small_blocks():
    """Blocks of 7 triangles (5 edges for the flip test), so that every pass here runs over
    many of them."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(triangles, "CHUNK", 7)
        mp.setattr(triangulate, "VIOLATION_CHUNK", 5)
        yield


@SETTINGS
@given(n=st.integers(0, 40), k=st.sampled_from([1, 2, 3]), extra=st.sampled_from([(), (3,)]),
       seed=st.integers(0, 10**6))
def test_times2_is_the_broadcast_product(n, k, extra, seed):
    rng = np.random.default_rng(seed)
    X, M = rng.normal(size=(n, *extra, 2)) * 10.0 ** rng.integers(-5, 5), rng.normal(size=(2, k))
    assert same_bits(times2(X, M), X[..., :1] * M[0] + X[..., 1:] * M[1])


@SETTINGS
@given(n=st.integers(1, 40), seed=st.integers(0, 10**6), nan=st.booleans())
def test_extent_is_the_reduction_along_the_points(n, seed, nan):
    P = np.random.default_rng(seed).normal(size=(n, 2))
    if nan:
        P[n // 2, 1] = np.nan
    lo, hi = extent(P)
    assert same_bits(lo, P.min(axis=0)) and same_bits(hi, P.max(axis=0))


@SETTINGS
@given(n=st.integers(4, 60), seed=st.integers(0, 10**6),
       anisotropy=st.sampled_from([CHAPTER, VARYING]))
def test_measures_rounded_by_block_are_the_rounded_measures(n, seed, anisotropy):
    P, T, _ = random_mesh(n, seed)
    Hm = metric_hessians(anisotropy, P, T)
    for got, want in zip(metric_measures(P, T, Hm, rounding=True),
                         map(rounded, metric_measures(P, T, Hm))):
        assert same_bits(got, want)


@SETTINGS
@given(rows=st.lists(st.lists(st.sampled_from([0.0, -0.0, 1.0, 2.0, np.inf, np.nan]),
                              min_size=3, max_size=3), min_size=1, max_size=40))
def test_longest_and_shortest_are_numpys_argmax_and_argmin(rows):
    """Ties (the first of equals), zeros of both signs, infinities and NaN (the first NaN)."""
    L2 = np.array(rows)
    longest, shortest = insert._longest_shortest(L2)
    assert same_bits(longest, np.argmax(L2, axis=1)) and same_bits(shortest, np.argmin(L2, axis=1))


@SETTINGS
@given(n=st.integers(4, 60), seed=st.integers(0, 10**6))
def test_local_maxima_by_block_are_the_whole_meshs(n, seed):
    P, T, twin = random_mesh(n, seed)
    rng = np.random.default_rng(seed)
    prio = np.where(rng.random(len(T)) < 0.2, -np.inf, rng.integers(0, 4, len(T)).astype(float))
    ext = np.append(prio, -np.inf)
    nb = twin.reshape(-1, 3) // 3
    want = ((prio >= ext[nb[:, 0]]) & (prio >= ext[nb[:, 1]]) & (prio >= ext[nb[:, 2]])
            & np.isfinite(prio))
    assert same_bits(insert._local_max(T, twin, prio), want)


@SETTINGS
@given(n=st.integers(4, 60), seed=st.integers(0, 10**6),
       anisotropy=st.sampled_from([CHAPTER, VARYING]))
def test_newton_rhs_sums_as_one_bincount_does(n, seed, anisotropy):
    """The terms added block after block (np.add.at) are the sums of one bincount over the
    whole mesh's corners, in its order."""
    P, T, _ = random_mesh(n, seed)
    F = triangles.Frame(P, T)
    s_at = grad_at = None
    if not anisotropy.is_constant:
        s_at, grad_at = anisotropy.s(P), anisotropy.grad(P)
    S = adjust._corner_brackets(T, anisotropy, F, s_at, grad_at)
    star = np.bincount(T.ravel(), np.repeat(F.A, 3), minlength=n)
    B = np.column_stack([np.bincount(T.ravel(), (F.gx * S).ravel(), minlength=n),
                         np.bincount(T.ravel(), (F.gy * S).ravel(), minlength=n)])
    b, got_star = adjust.newton_rhs(P, T, anisotropy)
    assert same_bits(got_star, star)
    assert same_bits(b, -B / np.where(star > 0, star, 1.0)[:, None])


def _violation_as_written(P, T, twin, h, H):
    """The lifted in-circle test of a constant metric H as the chapter's determinant reads."""
    g = twin[h]
    b = T.ravel()[g - g % 3 + topology.PRV[g % 3]]
    t, e = h // 3, h % 3
    cols = (T[t, e], T[t, topology.NXT[e]], T[t, topology.PRV[e]])
    dx = [P[c, 0] - P[b, 0] for c in cols]
    dy = [P[c, 1] - P[b, 1] for c in cols]
    (h00, h01), (_, h11) = H
    z = [0.5 * (h00 * x * x + 2.0 * h01 * x * y + h11 * y * y) for x, y in zip(dx, dy)]
    m = [dx[(r + 1) % 3] * dy[(r + 2) % 3] - dx[(r + 2) % 3] * dy[(r + 1) % 3] for r in range(3)]
    det = z[0] * m[0] + z[1] * m[1] + z[2] * m[2]
    scale = np.abs(z[0] * m[0]) + np.abs(z[1] * m[1]) + np.abs(z[2] * m[2])
    rel = det / np.where(scale > 0, scale, 1.0)
    convex = (dx[0] * dy[2] - dy[0] * dx[2] < 0) & (dx[1] * dy[2] - dy[1] * dx[2] > 0)
    return np.where(convex, rel, -1.0)


@SETTINGS
@given(n=st.integers(6, 80), seed=st.integers(0, 10**6), jitter=st.sampled_from([0.0, 0.05, 0.5]),
       grid=st.booleans())
def test_the_flip_test_is_the_determinant_as_written(n, seed, jitter, grid):
    """Every interior edge, regular or not, convex quadrilateral or not (points moved by up to
    half the square fold triangles), in general position or on a grid."""
    P, T, twin = random_mesh(n, seed, jitter, grid)
    h = triangulate._canonical(twin)
    assert same_bits(h, np.flatnonzero(twin > np.arange(len(twin))))
    got = triangulate._violation(P, T, twin, h, CHAPTER, None, None)
    assert same_bits(got, _violation_as_written(P, T, twin, h, CHAPTER.H))


@pytest.mark.parametrize("twice", [False, True], ids=["distinct", "a triangle listed twice"])
def test_triangles_are_put_in_the_stable_order_of_their_keys(twice):
    """_canonical_order sorts by NumPy's default argsort where the triangles' keys are distinct
    (the stable order then); rows listing one triangle twice (equal keys) take the stable sort."""
    P, T, twin = random_mesh(300, 3)
    rows = np.random.default_rng(0).permutation(len(T))
    if twice:
        rows = np.concatenate([rows, rows[::3]])
    out, _ = conform._canonical_order(T, twin, rows)
    r = np.argmin(T[rows], axis=1)
    rotated = np.take_along_axis(T[rows], (r[:, None] + np.arange(3)) % 3, axis=1)
    n = int(T.max()) + 1
    order = np.argsort((rotated[:, 0] * n + rotated[:, 1]) * n + rotated[:, 2], kind="stable")
    assert same_bits(out, rotated[order])


@SETTINGS
@given(n=st.integers(6, 80), seed=st.integers(0, 10**6))
def test_splits_into_grown_rows_are_the_appending_splits(n, seed):
    """insert's splits written into the rows `grow` made leave T and twin as the appending
    splits do, and twin as a sort of the new mesh's edges finds it."""
    P, T, twin = random_mesh(n, seed)
    rng = np.random.default_rng(seed)
    hb = np.flatnonzero(twin < 0)
    hb = hb[np.unique(hb // 3, return_index=True)[1]][:2]             # one per triangle
    free = np.ones(len(T), bool)
    free[hb // 3] = False
    hi = np.flatnonzero((twin > np.arange(len(twin))) & free[np.arange(len(twin)) // 3]
                        & free[np.maximum(twin, 0) // 3])
    hi = insert._independent(T, twin, hi[rng.permutation(len(hi))[:3]], np.zeros(min(3, len(hi))))
    free[hi // 3] = free[twin[hi] // 3] = False
    tri = np.flatnonzero(free)[:2]
    p0, p1, p2 = n + np.arange(len(hb)), n + len(hb) + np.arange(len(hi)), \
        n + len(hb) + len(hi) + np.arange(len(tri))
    Ta, ta = topology.split_boundary_edges(T, twin, hb, p0)
    Ta, ta = topology.split_edges(Ta, ta, hi, p1)
    Ta, ta = topology.split_triangles(Ta, ta, tri, p2)
    m0, m1, m2 = len(T), len(T) + len(hb), len(T) + len(hb) + 2 * len(hi)
    Tg, tg = topology.grow(T, twin, len(hb) + 2 * len(hi) + 2 * len(tri))
    Tg, tg = topology.split_boundary_edges(Tg, tg, hb, p0, rows=np.arange(m0, m1))
    Tg, tg = topology.split_edges(Tg, tg, hi, p1, rows=np.arange(m1, m2))
    Tg, tg = topology.split_triangles(Tg, tg, tri, p2, rows=np.arange(m2, len(Tg)))
    assert same_bits(Tg, Ta) and same_bits(tg, ta)
    assert same_bits(tg, topology.twins(Tg))


@SETTINGS
@given(n=st.integers(4, 80), seed=st.integers(0, 10**6))
def test_flips_in_place_are_the_flips_on_a_copy(n, seed):
    """restore(owned=True) rewrites the arrays it is given, and ends where restore on copies
    ends; without it the caller's arrays are left as they were."""
    P0, T, twin = random_mesh(n, seed)
    move = (np.random.default_rng(seed + 1).random(P0.shape) - 0.5) * 0.05
    while not np.all(signed_areas(P0 + move, T) > 0):       # moved, nothing folded
        move *= 0.5
    P = P0 + move
    T0, twin0 = T.copy(), twin.copy()
    T1, twin1, flips = triangulate.restore(P, T, twin, CHAPTER)
    assert same_bits(T, T0) and same_bits(twin, twin0)
    T2, twin2, flips2 = triangulate.restore(P, T0, twin0, CHAPTER, owned=True)
    assert same_bits(T1, T2) and same_bits(twin1, twin2) and flips == flips2
    assert same_bits(twin2, topology.twins(T2)) and np.all(signed_areas(P, T2) > 0)
    if flips:
        assert T2 is T0 and twin2 is twin0


METRIC_ONLY = qmesh.Anisotropy.metric_only(
    lambda X: np.stack([np.stack([1.0 + X[:, 0] ** 2, 0.3 * X[:, 1]], -1),
                        np.stack([0.3 * X[:, 1], 2.0 + X[:, 1]], -1)], -2))


def _shape_step_as_written(P, T, anisotropy, movable, on_boundary):
    """adjust.shape_step as its formulas read: (M, 3, 2) stacks of edges, the gradient ∇S by
    einsum, one bincount per sum over the movable corners only."""
    from qmesh.geometry.topology import NXT, PRV, touching
    T = T[touching(T, movable)]
    if not len(T):
        return np.zeros((len(P), 2))
    F = triangles.Frame(P, T)
    Hm = metric_hessians(anisotropy, P, T)
    sq = np.sqrt(Hm[:, 0, 0] * Hm[:, 1, 1] - Hm[:, 0, 1] * Hm[:, 1, 0])
    E, A = F.E, sq * F.A
    l2 = triangles.quadratic_form(E, Hm)
    S = l2.sum(axis=1)
    wt = None
    if on_boundary is not None:
        ob = on_boundary[T]
        lb2 = l2[np.arange(len(T)), np.argmin(ob, axis=1)]
        wt = np.where(ob.sum(axis=1) == 2, np.clip(3.0 * lb2 / S, adjust.FAN_WEIGHT, 1.0), 1.0)[:, None]
    U = E[:, NXT] - E[:, PRV]
    dS = 2.0 * (times2(U, Hm[0].T) if Hm.strides[0] == 0 else np.einsum("mij,mcj->mci", Hm, U))
    dA = sq[:, None, None] * np.stack([F.gx, F.gy], axis=-1)
    iA = 1.0 / A[:, None, None]
    g = dS * iA - (S[:, None, None] * iA * iA) * dA
    ia = iA[:, :, 0]
    c1, c2 = 2.0 * S[:, None] * (ia * ia * ia), ia * ia
    (sx, sy), (ax, ay) = np.moveaxis(dS, -1, 0), np.moveaxis(dA, -1, 0)
    h00 = 4.0 * Hm[:, None, 0, 0] * ia - 2.0 * c2 * sx * ax + c1 * ax * ax
    h11 = 4.0 * Hm[:, None, 1, 1] * ia - 2.0 * c2 * sy * ay + c1 * ay * ay
    h01 = 4.0 * Hm[:, None, 0, 1] * ia - c2 * (sx * ay + sy * ax) + c1 * ax * ay
    if wt is not None:
        g, h00, h01, h11 = g * wt[..., None], h00 * wt, h01 * wt, h11 * wt
    v = T.ravel()
    on = movable[v]
    idx = np.flatnonzero(movable)
    local = np.full(len(P), -1, np.int64)
    local[idx] = np.arange(len(idx))
    gx, gy, k00, k01, k11 = (np.bincount(local[v[on]], x.ravel()[on], minlength=len(idx))
                             for x in (g[..., 0], g[..., 1], h00, h01, h11))
    det = k00 * k11 - k01 * k01
    ok = det > 0
    det = np.where(ok, det, 1.0)
    d = np.zeros((len(P), 2))
    d[idx] = np.where(ok[:, None], -np.column_stack([k11 * gx - k01 * gy, k00 * gy - k01 * gx])
                      / det[:, None], 0.0)
    return d


@SETTINGS
@given(n=st.integers(3, 60), seed=st.integers(0, 10**6), share=st.sampled_from([0.0, 0.3, 1.0]),
       anisotropy=st.sampled_from([CHAPTER, VARYING, METRIC_ONLY]), fans=st.booleans())
def test_the_shape_step_on_columns_is_the_step_as_written(n, seed, share, anisotropy, fans):
    """Corner by corner on (M, 3) columns, the star sums over every corner with one spare bin
    for the corners that do not move: the bits of the stacked formulas."""
    P, T, _ = random_mesh(n, seed)
    rng = np.random.default_rng(seed)
    movable = rng.random(len(P)) < share
    on_boundary = (rng.random(len(P)) < 0.3) if fans else None
    assert same_bits(adjust.shape_step(P, T, anisotropy, movable, on_boundary),
                     _shape_step_as_written(P, T, anisotropy, movable, on_boundary))
