"""The enclosures' speed-ups change no bit: a point [c, c] times an interval by two products is
the four-corner product (0 · ∞ and infinite ends included), the NaN check sends exactly the rows
holding a NaN to the whole line, and a level's pieces bounded in chunks get each piece's own
bound; a whole multiple by its ends alone still holds the exact product. An enclosure turns
NumPy's floating-point warnings off once, not in each of its operations, and lets none out."""

import sys
import warnings

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.conductivity import intervals
from qmesh.conductivity import means as _m
from qmesh.conductivity.expression import check

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
    with np.errstate(all="ignore"):            # as `evaluate_all` runs the operations
        got_both = (intervals.mul(point, (lo, hi)), intervals.mul((lo, hi), point))
    for got in got_both:
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
    with np.errstate(all="ignore"):            # as `evaluate_all` runs the operations
        got = intervals._clean(lo, hi)
    bad = np.isnan(lo) | np.isnan(hi)
    assert np.array_equal(got[0], np.where(bad, -np.inf, lo))
    assert np.array_equal(got[1], np.where(bad, np.inf, hi))


def test_the_nan_check_passes_empty_rows_and_lower_ends_at_infinity_untouched():
    """The check's sum of the ends' least values is NaN without a NaN where every lower end is
    +∞ and an upper one −∞ (nothing to mask then), and an empty level has no least value."""
    empty = np.zeros(0)
    lo, hi = np.array([np.inf, np.inf]), np.array([-np.inf, 2.0])
    with np.errstate(all="ignore"):            # as `evaluate_all` runs the operations
        none = intervals._clean(empty, empty)
        got = intervals._clean(lo, hi)
    assert none[0].shape == none[1].shape == (0,)
    assert np.array_equal(got[0], lo) and np.array_equal(got[1], hi)


def test_an_enclosure_sets_numpys_error_state_once_and_lets_no_warning_out(monkeypatch):
    """A text dividing by zero, a logarithm and a root reaching 0, an ∞ − ∞ (each of them a
    warning from NumPy if it were on) enclosed over boxes across them: one `np.errstate` of
    the interval module's for the whole walk (not one in each operation, thousands a piece;
    `geometry.portable`'s functions keep their own), no warning, and the whole line where
    nothing bounds the text."""
    entered = []
    errstate = np.errstate

    def counted(*args, **kwargs):
        if sys._getframe(1).f_globals.get("__name__") == intervals.__name__:
            entered.append(kwargs)
        return errstate(*args, **kwargs)

    monkeypatch.setattr(np, "errstate", counted)
    forms = [check(t, "q") for t in ("1/x + log(y) - sqrt(x*y)", "exp(1/(x - 0.25))**2 - 1/y",
                                      "180/pi*atan((y - 0.5)/(x - 0.5)) + cos(1/x)")]
    lo = np.array([-1.0, 0.0, 0.25, 0.5, 1e-300])
    X, Y = (lo, lo + 0.5), (lo - 0.5, lo + 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        nodes = intervals.evaluate_all(forms, X, Y)
    assert len(entered) == 1
    value = nodes[0][0]
    assert value[0][0] == -np.inf and value[1][0] == np.inf      # 1/x across x = 0
    for node in nodes:
        for a, b in node:
            assert not np.isnan(a).any() and not np.isnan(b).any()
            assert np.all(a <= b)


@settings(max_examples=60, deadline=None)
@given(c=st.integers(1, 6), ends=st.lists(st.tuples(ENDS, ENDS), min_size=1, max_size=20))
def test_a_whole_multiple_holds_the_exact_product_and_is_no_wider_than_a_product(c, ends):
    """`_scaled` (a Leibniz or Faà di Bruno coefficient) against the exact product of each end
    in rationals, and within the four-corner product by the point [c, c]."""
    from fractions import Fraction
    lo, hi = (np.array(v) for v in zip(*((min(a, b), max(a, b)) for a, b in ends)))
    with np.errstate(all="ignore"):            # as `evaluate_all` runs the operations
        got = intervals._scaled(c, (lo, hi))
    wide = four_corners((np.full(lo.shape, float(c)), np.full(lo.shape, float(c))), (lo, hi))
    for g, w, v, below in ((got[0], wide[0], lo, True), (got[1], wide[1], hi, False)):
        assert np.all(g >= w) if below else np.all(g <= w)
        for gi, vi in zip(g, v):
            if np.isfinite(vi) and np.isfinite(gi):
                exact = c * Fraction(float(vi))
                assert (Fraction(float(gi)) <= exact) if below else (Fraction(float(gi)) >= exact)


def test_functions_of_one_argument_share_its_products_and_values_to_the_bit(monkeypatch):
    """The sine and the cosine of one argument (a principal field's double angle), and powers
    of it, enclosed together: each product of the argument's derivatives formed once (the old
    code formed them again for each function of it), and each node the same bits as enclosed
    alone."""
    texts = ["sin(3*x*y + x*x)", "cos(3*x*y + x*x)", "(3*x*y + x*x)**3", "sin(3*x*y + x*x)**2"]
    forms = [check(t, "q") for t in texts]
    rng = np.random.default_rng(7)
    lo = rng.uniform(-2, 2, (2, 64))
    X, Y = (lo[0], lo[0] + 0.01), (lo[1], lo[1] + 0.02)
    formed = []
    product = intervals._product

    def recorded(u, factors):
        formed.append((id(u), factors))
        return product(u, factors)

    monkeypatch.setattr(intervals, "_product", recorded)
    together = intervals.evaluate_all(forms, X, Y)
    assert formed and len(formed) == len(set(formed))
    alone = [intervals.evaluate(f, X, Y) for f in forms]
    for a, b in zip(together, alone):
        for (alo, ahi), (blo, bhi) in zip(a, b):
            assert np.array_equal(alo, blo) and np.array_equal(ahi, bhi)
