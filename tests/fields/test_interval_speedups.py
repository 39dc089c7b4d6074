"""The enclosures' speed-ups change no bit: a point [c, c] times an interval by two products is
the four-corner product (0 · ∞ and infinite ends included), the NaN check sends exactly the rows
holding a NaN to the whole line, and a level's pieces bounded in chunks get each piece's own
bound; a whole multiple by its ends alone still holds the exact product."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.conductivity import intervals
from qmesh.conductivity import means as _m

ENDS = st.one_of(st.floats(allow_nan=False), st.sampled_from([0.0, -0.0, np.inf, -np.inf, 5e-324]))


def four_corners(a, b):
    """`intervals.mul` as it reads without the point's shortcut."""
    with np.errstate(all="ignore"):
        p = [a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1]]
        return intervals._round(np.fmin(np.fmin(p[0], p[1]), np.fmin(p[2], p[3])),
                                np.fmax(np.fmax(p[0], p[1]), np.fmax(p[2], p[3])))


@settings(max_examples=60, deadline=None)
@given(c=ENDS, ends=st.lists(st.tuples(ENDS, ENDS), min_size=1, max_size=20))
def test_a_point_times_an_interval_is_the_four_corner_product(c, ends):
    lo, hi = (np.array(v) for v in zip(*((min(a, b), max(a, b)) for a, b in ends)))
    point = intervals._const(c, lo.shape)
    assert point[0] is point[1]
    want = four_corners((point[0].copy(), point[1].copy()), (lo, hi))
    for got in (intervals.mul(point, (lo, hi)), intervals.mul((lo, hi), point)):
        for g, w in zip(got, want):
            assert np.array_equal(g, w, equal_nan=True)
            assert np.array_equal(np.signbit(g), np.signbit(w))


def test_pieces_bounded_in_chunks_get_their_own_bounds():
    field = qmesh.TensorField.principal("1 + x*x", "0.01*exp(y)", "40*sin(2*x + y)")
    bound = field._enclosure()
    rng = np.random.default_rng(3)
    n = 2 * _m.CHUNK + 17
    A = rng.uniform(0, 1, (n, 2))
    B, C = A + rng.normal(0, 0.01, (n, 2)), A + rng.normal(0, 0.01, (n, 2))
    chunked = _m._bound_chunked(bound, A, B, C)
    assert np.array_equal(chunked, bound(A, B, C))
    some = rng.choice(n, 50, replace=False)
    assert np.array_equal(chunked[some], bound(A[some], B[some], C[some]))


@settings(max_examples=60, deadline=None)
@given(ends=st.lists(st.tuples(ENDS | st.just(np.nan), ENDS | st.just(np.nan)), min_size=1,
                     max_size=20))
def test_only_a_row_holding_nan_becomes_the_whole_line(ends):
    lo, hi = (np.array(v) for v in zip(*ends))
    got = intervals._clean(lo, hi)
    bad = np.isnan(lo) | np.isnan(hi)
    assert np.array_equal(got[0], np.where(bad, -np.inf, lo))
    assert np.array_equal(got[1], np.where(bad, np.inf, hi))


@settings(max_examples=60, deadline=None)
@given(c=st.integers(1, 6), ends=st.lists(st.tuples(ENDS, ENDS), min_size=1, max_size=20))
def test_a_whole_multiple_holds_the_exact_product_and_is_no_wider_than_a_product(c, ends):
    """`_scaled` (a Leibniz or Faà di Bruno coefficient) against the exact product of each end
    in rationals, and within the four-corner product by the point [c, c]."""
    from fractions import Fraction
    lo, hi = (np.array(v) for v in zip(*((min(a, b), max(a, b)) for a, b in ends)))
    got = intervals._scaled(c, (lo, hi))
    wide = four_corners((np.full(lo.shape, float(c)), np.full(lo.shape, float(c))), (lo, hi))
    for g, w, v, below in ((got[0], wide[0], lo, True), (got[1], wide[1], hi, False)):
        assert np.all(g >= w) if below else np.all(g <= w)
        for gi, vi in zip(g, v):
            if np.isfinite(vi) and np.isfinite(gi):
                exact = c * Fraction(float(vi))
                assert (Fraction(float(gi)) <= exact) if below else (Fraction(float(gi)) >= exact)
