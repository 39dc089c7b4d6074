"""The orientation predicate is exact (geometry.orientation): its sign is the real determinant's,
so it does not change when the same three points come in another order, and the two crossing
tests of a ring (pair by pair up to SMALL points, the y-sweep beyond) find the same pairs on
points exactly in line, where the rounded cross product can take either sign."""

from fractions import Fraction

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from qmesh.domain import domain as D
from qmesh.geometry import rings as R
from qmesh.geometry.orientation import orient

coordinate = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


def _sign(a, b, c):
    ax, ay, bx, by, cx, cy = (Fraction(float(z)) for z in (*a, *b, *c))
    det = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return (det > 0) - (det < 0)


@settings(max_examples=300, deadline=None)
@given(a=st.tuples(coordinate, coordinate), b=st.tuples(coordinate, coordinate),
       share=st.floats(-3, 3), nudge=st.integers(-3, 3))
def test_the_sign_is_the_real_determinants_in_every_order(a, b, share, nudge):
    a, b = np.array(a), np.array(b)
    c = a + share * (b - a)                       # in line but for rounding, then a few ulps off
    c[1] = c[1] + nudge * np.spacing(c[1])
    want = _sign(a, b, c)
    rows = lambda *z: [np.array([p]) for p in z]  # noqa: E731
    for turn, sign in (((a, b, c), 1), ((b, c, a), 1), ((c, a, b), 1), ((b, a, c), -1),
                       ((a, c, b), -1), ((c, b, a), -1)):
        assert orient(*rows(*turn))[0] == sign * want


def test_points_in_line_on_a_slant_are_in_line_in_every_order():
    P = np.array([0.0, 1.0, 0.5, 0.25])[:, None] * np.array([np.cos(1.0), np.sin(1.0)])
    for i, j, k in ((0, 1, 3), (3, 0, 1), (1, 3, 0)):
        assert orient(P[[i]], P[[j]], P[[k]])[0] == 0


# points t·(cos θ, sin θ) with t a power of two (exact products): in line in the reals
steps = st.sampled_from([0.0, 0.125, -0.125, 0.25, -0.25, 0.5, -0.5, 1.0, -1.0, 2.0])


@settings(max_examples=200, deadline=None)
@given(t=st.lists(steps, min_size=3, max_size=9), angle=st.floats(0.01, 3.1),
       off=st.lists(st.tuples(st.integers(-4, 4), st.integers(-4, 4)), max_size=4))
def test_the_pairwise_crossings_are_the_sweeps_on_slanted_spikes(t, angle, off):
    P = np.concatenate([np.array(t)[:, None] * np.array([np.cos(angle), np.sin(angle)]),
                        np.array(off, float).reshape(-1, 2) / 4.0])
    ia = np.arange(len(P))
    ib = D._next_points([len(P)])
    assert np.array_equal(D._crossings(P, ia, ib), R.crossings(P[ia], P[ib], ia, ib))
