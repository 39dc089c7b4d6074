"""The validators of qmesh.checks: what they accept comes back unchanged, the rest is a QmeshError
that names the argument and is catchable as ValueError and as TypeError."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from qmesh import QmeshError, checks

NOT_NUMBERS = ["1", b"1", None, [1.0], (1.0,), {"x": 1}, 1 + 0j, object(), np.array([1.0, 2.0])]
NOT_FINITE = [math.nan, math.inf, -math.inf, np.float64("nan"), np.float32("inf")]
BOOLS = [True, False, np.bool_(True)]


def test_qmesh_error_is_a_value_error_and_a_type_error():
    for kind in (ValueError, TypeError):
        with pytest.raises(kind):
            checks.real("x", "alpha")


@settings(derandomize=True, max_examples=60, deadline=None)
@given(st.floats(-1e300, 1e300) | st.integers(-10**200, 10**200))
def test_real_accepts_every_finite_number(x):
    assert checks.real(x, "a") == float(x)


@settings(derandomize=True, max_examples=60, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False))
def test_real_bounds(x):
    inside = 0 < x <= 1
    if inside:
        assert checks.real(x, "alpha", low=0, high=1, low_open=True) == x
    else:
        with pytest.raises(QmeshError, match=r"alpha must be in \(0, 1\], got "):
            checks.real(x, "alpha", low=0, high=1, low_open=True)


@pytest.mark.parametrize("value", NOT_NUMBERS + NOT_FINITE + BOOLS + [10**400],
                         ids=lambda v: type(v).__name__ + ":" + repr(v)[:20])
def test_real_refuses(value):
    with pytest.raises(QmeshError, match=r"^size must be a finite number > 0, got ") as info:
        checks.real(value, "size", low=0, low_open=True)
    assert isinstance(info.value, TypeError) and isinstance(info.value, ValueError)


def test_real_none_only_when_allowed():
    assert checks.real(None, "size", none=True) is None
    with pytest.raises(QmeshError, match="size must be a finite number, got None"):
        checks.real(None, "size")


def test_real_takes_numpy_scalars_and_zero_dim_arrays():
    assert checks.real(np.float32(0.5), "a") == 0.5
    assert checks.real(np.array(2.0), "a") == 2.0
    assert type(checks.real(np.int64(3), "a")) is float


@settings(derandomize=True, max_examples=60, deadline=None)
@given(st.integers(-10**40, 10**40))
def test_integer_bounds(n):
    if 0 <= n <= 10**6:
        assert checks.integer(n, "max_iterations", low=0, high=10**6) == n
    else:
        with pytest.raises(QmeshError, match=r"^max_iterations must be an integer >= 0 and <= 1e\+06, got "):
            checks.integer(n, "max_iterations", low=0, high=10**6)


@pytest.mark.parametrize("value", NOT_NUMBERS + NOT_FINITE + BOOLS + [3.0, 2.5, np.float64(4.0)],
                         ids=lambda v: type(v).__name__ + ":" + repr(v)[:20])
def test_integer_refuses_everything_but_integers(value):
    with pytest.raises(QmeshError, match=r"^seed must be an integer >= 0, got "):
        checks.integer(value, "seed", low=0)


def test_integer_takes_numpy_integers():
    assert checks.integer(np.int32(7), "n") == 7 and type(checks.integer(np.int32(7), "n")) is int
    assert checks.integer(None, "seed", none=True) is None


def test_integer_message_shortens_huge_values():
    with pytest.raises(QmeshError, match=r"got about 1e\+30$"):
        checks.integer(10**30, "n", high=100)


@pytest.mark.parametrize("value", [0, 1, "yes", None, 1.0])
def test_boolean_refuses_non_bools(value):
    with pytest.raises(QmeshError, match="boundary_refinement must be True or False, got "):
        checks.boolean(value, "boundary_refinement")


def test_boolean_accepts_bools():
    assert checks.boolean(np.bool_(False), "b") is False and checks.boolean(True, "b") is True


def test_choice_and_function_and_text():
    assert checks.choice("dense", "method", ("auto", "dense")) == "dense"
    with pytest.raises(QmeshError, match=r"method must be one of 'auto', 'dense', got 'DENSE'"):
        checks.choice("DENSE", "method", ("auto", "dense"))
    with pytest.raises(QmeshError, match=r"method must be one of .* got 3"):
        checks.choice(3, "method", ("auto", "dense"))
    with pytest.raises(QmeshError, match="grad must be a callable, got 3"):
        checks.function(3, "grad")
    with pytest.raises(QmeshError, match="label must be a string, got 3"):
        checks.text(3, "label")


@pytest.mark.parametrize("value, message", [
    ("ab", r"Q must be an array of real numbers of shape \(2, 2\)"),
    ([[1, 0], [0, None]], "Q must be an array of real numbers"),
    ([[1, 0], [0]], "Q must be an array of real numbers"),
    ([[True, False], [False, True]], "Q must be an array of real numbers"),
    ([[1j, 0], [0, 1]], "Q must be an array of real numbers"),
    ([1, 0, 0, 1], r"Q must have shape \(2, 2\), got shape \(4,\)"),
    ([[1, 0], [0, np.nan]], r"Q has non-finite entries at row 1: \[0.0, nan\]"),
    ([[0, 0], [0, 0]], "the zero matrix"),
    ([[1, 0], [0, -1]], "symmetric positive definite"),
    ([[1, 0], [0, 1e-17]], "symmetric positive definite"),
    ([[1, 1], [1, 1]], "symmetric positive definite"),
    ([[1, 0.5], [0.4, 1]], "must be symmetric"),
])
def test_spd_matrix_refuses(value, message):
    with pytest.raises(QmeshError, match=message):
        checks.spd_matrix(value, "Q")


@settings(derandomize=True, max_examples=60, deadline=None)
@given(st.floats(-250, 250), st.floats(0, 13), st.floats(0, np.pi))
def test_spd_matrix_accepts_any_scale(log_scale, log_ratio, angle):
    """c·R diag(1, r) Rᵀ is SPD for any c > 0 in 1e-250…1e250 and ratio r up to 1e13."""
    c, r = 10.0 ** log_scale, 10.0 ** -log_ratio
    R = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    Q = c * (R @ np.diag([1.0, r]) @ R.T)
    out = checks.spd_matrix(Q, "Q")
    assert np.array_equal(out, out.T)
    assert np.allclose(out, Q, rtol=1e-12, atol=1e-12 * c)


def test_real_array_reports_first_bad_row():
    with pytest.raises(QmeshError, match=r"points has non-finite entries at row 2: \[inf, 0.0\]"):
        checks.real_array([[0, 0], [1, 1], [np.inf, 0]], "points", (None, 2))
    assert checks.real_array([[0, 1]], "points", (None, 2)).dtype == float
