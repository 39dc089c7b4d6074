"""Small rings checked pair by pair, and many regions checked at once (qmesh.domain.domain).

The brute-force crossing and touching tests of up to SMALL points must find what the y-sweep
of `geometry.rings` finds (the same pairs; the same first pair, which the messages name), and
`Domain._many` must make exactly the domains `Domain(ring)` makes one by one, or None where one
of them refuses its ring (the regions are then checked one by one, which names it).
"""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.domain import domain as D
from qmesh.geometry import rings as R


def _ring(draw_points, star, flip, repeat):
    P = np.array(draw_points, float)
    if star:                                    # a star-shaped (simple) polygon
        c = P.mean(axis=0)
        P = P[np.argsort(np.arctan2(*(P - c).T[::-1]))]
    if flip:
        P = P[::-1]
    if repeat and len(P) > 3:
        P[1] = P[0]
    return P


points = st.lists(st.tuples(st.integers(-8, 8), st.integers(-8, 8)), min_size=3, max_size=14,
                  unique=True)
rings = st.builds(_ring, points, st.booleans(), st.booleans(),
                  st.sampled_from([False] * 5 + [True]))


@settings(max_examples=150, deadline=None)
@given(P=points)
def test_pairwise_crossings_and_touches_are_the_sweeps(P):
    P = np.array(P, float) / 8.0
    ia = np.arange(len(P))
    ib = D._next_points([len(P)])
    assert np.array_equal(D._crossings(P, ia, ib), R.crossings(P[ia], P[ib], ia, ib))
    reach = 0.3
    mine, sweep = D._near_points(P, ia, ib, reach), R.near_points(P, P[ia], P[ib], ia, ib, reach)
    assert {tuple(r) for r in mine} == {tuple(r) for r in sweep}
    if len(sweep):
        assert tuple(mine[0]) == tuple(sweep[0])


@settings(max_examples=120, deadline=None)
@given(many=st.lists(rings, min_size=2, max_size=6))
def test_many_rings_make_the_domains_one_by_one_would(many):
    one_by_one = []
    for P in many:
        try:
            one_by_one.append(qmesh.Domain(P))
        except qmesh.QmeshError:
            one_by_one = None
            break
    out = D.Domain._many(many)
    if one_by_one is None:
        assert out is None
        return
    assert out is not None and len(out) == len(one_by_one)
    for a, b in zip(out, one_by_one):
        assert np.array_equal(a.seeds, b.seeds)
        assert np.array_equal(a.segments, b.segments)
        assert np.array_equal(a.segment_tags, b.segment_tags)
        assert np.array_equal(a.ring_of_seed, b.ring_of_seed)
        assert a.area == b.area and a.tag_names == b.tag_names and a.regions == b.regions


def test_a_bad_region_among_many_is_named_as_before():
    hexes = [np.array([[np.cos(t), np.sin(t)] for t in np.pi / 3 * np.arange(6)]) * 0.04 + c
             for c in np.stack(np.meshgrid(np.linspace(0.1, 0.9, 6), np.linspace(0.1, 0.9, 6)), -1).reshape(-1, 2)]
    bow = hexes[7][[0, 3, 1, 4, 2, 5]]          # region 8 crosses itself
    try:
        qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=hexes[:7] + [bow] + hexes[8:])
    except qmesh.QmeshError as e:
        assert str(e).startswith("region 8: its outline intersects itself")
    else:
        raise AssertionError("a self-crossing region was accepted")
    d = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=hexes)
    assert len(d.partition.faces) == len(hexes) + 1


def _raster_segments(n, seed, jitter):
    """A raster's cell edges (each edge once) with its corners, corners nudged by `jitter`
    cell sizes and some edges bent onto neighbours: many segments per horizontal band."""
    rng = np.random.default_rng(seed)
    g = np.linspace(0.0, 1.0, n + 1)
    X, Y = np.meshgrid(g, g)
    P = np.column_stack([X.ravel(), Y.ravel()]) + jitter / n * rng.standard_normal(((n + 1) ** 2, 2))
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    ia = np.concatenate([idx[:, :-1].ravel(), idx[:-1, :].ravel()])
    ib = np.concatenate([idx[:, 1:].ravel(), idx[1:, :].ravel()])
    bent = rng.random(len(ia)) < 0.01                 # some edges reach past a neighbour
    ib = np.where(bent, np.minimum(ib + 2, len(P) - 1), ib)
    long = rng.choice(len(ia), 20, replace=False)     # and a few long ones across the raster
    ib[long] = rng.choice(len(P), 20)
    keep = ia != ib
    return P, ia[keep], ib[keep]


@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 1000), jitter=st.sampled_from([0.0, 1e-10, 0.02]),
       offset=st.sampled_from([0.0, 1e8]), scale=st.sampled_from([1.0, 1e-9]))
def test_raster_balls_find_what_the_sweep_finds(seed, jitter, offset, scale):
    """Rasters are many segments a band: candidates from balls around the segments' pieces,
    then the sweep's test, must give the sweep's pairs in the sweep's order."""
    P, ia, ib = _raster_segments(110, seed, jitter)
    P = (P + offset) * scale                          # far off, or tiny cells
    reach = 1e-9 * scale + 0.01 * scale / 110 * (jitter > 0.01)
    A, B = P[ia], P[ib]
    size = len(P) + len(A)
    assert size >= R.GRID_MIN                          # the balls' route, not the sweep's
    order = np.argsort(P[:, 1], kind="stable")
    assert R._band_pairs(P[order, 1], A, B, reach) > R.GRID_PAIRS * size
    near, cross = R.near_points(P, A, B, ia, ib, reach), R.crossings(A, B, ia, ib)
    saved = R.GRID_MIN
    R.GRID_MIN = 10 ** 12                              # the y-sweep alone
    try:
        near0, cross0 = R.near_points(P, A, B, ia, ib, reach), R.crossings(A, B, ia, ib)
    finally:
        R.GRID_MIN = saved
    assert len(cross0) and np.array_equal(cross, cross0)
    assert np.array_equal(near, near0)
    if jitter > 0.01:
        assert len(near0)


def test_a_star_whose_sides_are_nearly_in_line_is_simple():
    """Sides 1 and 5 of this octagon lie 0.019 apart on nearly one line: no crossing in exact
    arithmetic, and none found."""
    P = [[-0.2734029056701845, 0.001656238180632702], [-0.001656238180632702, -0.2734029056701845],
         [0.12899685514850548, -0.1443232386126474], [-0.03405114534522561, 0.020712247697842922],
         [-0.02029818815268475, 0.03429958107232051], [0.14274981234104633, -0.1307359052381698],
         [0.2734029056701845, -0.001656238180632702], [0.001656238180632702, 0.2734029056701845]]
    assert np.isclose(qmesh.Polygon(P).area, 0.145019, rtol=1e-5)
