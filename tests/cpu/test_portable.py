"""qmesh.geometry.portable: the functions agree with the C library's (Python's math module) to a
few units in the last place over their whole range, and the 2 × 2 algebra with numpy.linalg to
round-off; only then is "the same bits on every CPU" worth having."""

import math

import numpy as np
from hypothesis import given, settings, strategies as st

from qmesh.geometry import portable

finite = dict(allow_nan=False, allow_infinity=False)


def _ulps(got: float, want: float) -> float:
    if want == got:
        return 0.0
    return abs(got - want) / math.ulp(want) if want != 0 else abs(got) / math.ulp(0.0)


@settings(max_examples=300)
@given(st.floats(-745, 709.7, **finite))
def test_exp(x):
    assert _ulps(float(portable.exp(x)), math.exp(x)) <= 2 or math.exp(x) < 1e-300


@settings(max_examples=300)
@given(st.floats(1e-300, 1e300, **finite))
def test_log(x):
    assert _ulps(float(portable.log(x)), math.log(x)) <= 3


@settings(max_examples=200)
@given(st.floats(-0.999, 1e6, **finite))
def test_log1p(x):
    assert _ulps(float(portable.log1p(x)), math.log1p(x)) <= 4


@settings(max_examples=300)
@given(st.floats(-1e8, 1e8, **finite))
def test_arctan(x):
    assert _ulps(float(portable.arctan(x)), math.atan(x)) <= 4


@settings(max_examples=300)
@given(st.floats(-1e6, 1e6, **finite), st.floats(-1e6, 1e6, **finite))
def test_arctan2(y, x):
    assert _ulps(float(portable.arctan2(y, x)), math.atan2(y, x)) <= 4 or abs(math.atan2(y, x)) < 1e-290


@settings(max_examples=200)
@given(st.floats(-30, 30, **finite))
def test_hyperbolic(x):
    assert _ulps(float(portable.sinh(x)), math.sinh(x)) <= 3
    assert _ulps(float(portable.cosh(x)), math.cosh(x)) <= 3
    assert _ulps(float(portable.tanh(x)), math.tanh(x)) <= 4


@settings(max_examples=300)
@given(st.floats(1e-3, 1e3, **finite), st.sampled_from([-3, -2, -1, -0.5, 0.5, 1.5, 2, 3, 7, 0.37, 2.5, -1.3]))
def test_power(b, e):
    assert _ulps(float(portable.power(np.array([b]), e)[0]), b ** e) <= 16


def test_power_of_negative_bases_and_special_values():
    b = np.array([-2.0, -2.0, 0.0, 4.0])
    assert portable.power(b, 3).tolist() == [-8.0, -8.0, 0.0, 64.0]
    assert np.isnan(portable.power(np.array([-2.0]), 0.5)).all()
    assert portable.power(np.array([-2.0, 2.0]), np.array([3.0, 0.0])).tolist() == [-8.0, 1.0]
    assert portable.exp(np.array([np.inf, -np.inf, 710.0, -800.0])).tolist() == [np.inf, 0.0, np.inf, 0.0]
    assert np.isnan(portable.log(np.array([-1.0, np.nan]))).all() and portable.log(0.0) == -np.inf


@settings(max_examples=200)
@given(st.floats(1e-200, 1e200, **finite))
def test_exact_logarithms_of_two(x):
    """floor/ceil/round of log₂ x and of steps·log₂ x by the exponent: equal to math.log2's where
    log₂ x is not within round-off of the step."""
    l2 = math.log2(x)
    if abs(l2 - round(l2)) > 1e-9:
        assert portable.floor_log2(x) == math.floor(l2) and portable.ceil_log2(x) == math.ceil(l2)
    if abs(l2 - math.floor(l2) - 0.5) > 1e-9:
        assert portable.round_log2(x) == round(l2)
    for steps in (2, 4):
        if abs(steps * l2 - round(steps * l2)) > 1e-9:
            assert portable.floor_log2_steps(x, steps) == math.floor(steps * l2)
            up = portable.ceil_pow2_steps(x, steps)
            assert x <= up < x * 2 ** (1 / steps) * (1 + 1e-15)


def test_powers_of_two_are_exact():
    for k in range(-60, 60):
        assert portable.floor_log2(2.0 ** k) == k == portable.ceil_log2(2.0 ** k) == portable.round_log2(2.0 ** k)


spd = st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(-0.999, 0.999)).map(
    lambda t: (lambda a, c, r: np.array([[a, r * np.sqrt(a * c)], [r * np.sqrt(a * c), c]]))(10 ** t[0], 10 ** t[1], t[2]))


@settings(max_examples=200)
@given(spd)
def test_two_by_two_algebra_matches_numpy_linalg(H):
    if np.linalg.cond(H) > 1e10:
        return
    scale = np.abs(H).max()
    L = portable.cholesky2(H)
    assert np.allclose(L, np.linalg.cholesky(H), rtol=1e-12, atol=1e-12 * np.sqrt(scale))
    assert np.allclose(portable.inv2(H) @ H, np.eye(2), atol=1e-9)
    assert np.isclose(portable.det2(H), np.linalg.det(H), rtol=1e-9, atol=1e-14 * scale ** 2)
    w, V = portable.eigh2(H)
    assert np.allclose(w, np.linalg.eigvalsh(H), rtol=1e-10, atol=1e-14 * scale)
    assert np.allclose(V @ np.diag(w) @ V.T, H, atol=1e-12 * scale) and np.isclose(np.linalg.det(V), 1.0)
    b = np.array([1.0, -2.0])
    assert np.allclose(H @ portable.solve2(H, b), b, rtol=1e-8, atol=1e-8 * np.abs(b).max())
    assert np.allclose(portable.matmul2(H, H.T), H @ H.T, rtol=1e-14, atol=1e-14 * scale ** 2)


def test_stacks_give_every_member_its_own_bits():
    rng = np.random.default_rng(3)
    M = rng.normal(size=(50, 2, 2))
    H = portable.matmul2(M, np.swapaxes(M, 1, 2)) + np.eye(2)
    one = np.array([portable.eigh2(h)[1] for h in H])
    assert np.array_equal(portable.eigh2(H)[1], one)
    assert np.array_equal(portable.cholesky2(H), np.array([portable.cholesky2(h) for h in H]))
    D, w = rng.normal(size=(4, 9, 2)), rng.random((4, 9))
    assert np.array_equal(portable.moments2(D, w), np.array([portable.moments2(d, v) for d, v in zip(D, w)]))


def test_gauss_legendre_matches_numpy():
    for n in (1, 2, 3, 5, 8, 16, 40):
        x, w = portable.gauss_legendre(n)
        x0, w0 = np.polynomial.legendre.leggauss(n)
        assert np.allclose(x, x0, atol=1e-15) and np.allclose(w, w0, atol=1e-14)
        assert np.isclose((w * x ** (2 * n - 2)).sum(), 2 / (2 * n - 1), rtol=1e-13)
