"""A principal field whose angle is a polar angle, `180/pi*atan((y - b)/(x - a))` plus a smooth
term: atan jumps by π across x = a, the tensor does not (it has period 180° in the angle). Its
enclosures must hold the field's values and derivatives on every box, and stay bounded on a box
across that line, or the proof of its means can never finish there."""

import math

import numpy as np
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from qmesh.conductivity import intervals
from qmesh.conductivity.expression import _to_sympy, check
from tests.fields.test_bounded_means import assert_enclosed, taylor_parts


def _reference(k1, k2, angle):
    """For q11, q12, q22 of R diag(k1, k2) Rᵀ, R the rotation by the text `angle` in degrees:
    their value, gradient, Hessian and third derivatives as functions, by SymPy (independent of
    `intervals`)."""
    theta, x, y = _to_sympy(check(angle, "angle"))
    t = sp.pi / 180 * theta
    c, s = sp.cos(t), sp.sin(t)
    out = []
    for q in (k1 * c**2 + k2 * s**2, (k1 - k2) * c * s, k1 * s**2 + k2 * c**2):
        parts = taylor_parts(q, x, y)
        out.append([sp.lambdify((x, y), p, "numpy") for p in parts])
    return out


def _forms(k1, k2, angle):
    return intervals.principal_forms(check(k1, "k1"), check(k2, "k2"), check(angle, "angle"))


@settings(max_examples=25, deadline=None)
@given(a=st.floats(-1, 1), b=st.floats(-1, 1), turns=st.sampled_from([1, -1, 2, 0.5, 1.5]),
       rate=st.floats(-5, 5), ratio=st.floats(1, 1e3), seed=st.integers(0, 2**32 - 1))
def test_the_enclosures_hold_the_field_on_every_box(a, b, turns, rate, ratio, seed):
    """Boxes anywhere (across x = a too, away from the centre): every value, gradient and Hessian
    of q11, q12, q22 at points of the box, by SymPy on the texts with their jump, lies in the
    enclosure. Half turns of 0.5 or 1.5 are not a period of Q: those are enclosed as jumps."""
    angle = f"{turns * 180}/pi*atan((y - {b})/(x - {a})) + {rate}*(x + 2*y)"
    forms = _forms("1", f"{1 / ratio}", angle)
    rng = np.random.default_rng(seed)
    k = 8
    centre = np.column_stack([a + rng.uniform(-0.05, 0.05, k), b + rng.choice([-1, 1], k)
                              * rng.uniform(0.2, 1.0, k)])
    half = 10.0 ** rng.uniform(-4, -1.5, (k, 2))
    X = (centre[:, 0] - half[:, 0], centre[:, 0] + half[:, 0])
    Y = (centre[:, 1] - half[:, 1], centre[:, 1] + half[:, 1])
    nodes = intervals.evaluate_all(forms, X, Y)
    for node, funcs in zip(nodes, _reference(1.0, 1.0 / ratio, angle)):
        assert_enclosed(node, funcs, centre, half, rng, angle, draws=5)


def test_a_box_across_the_polar_angle_s_jump_is_bounded():
    """The spiral of the field benchmark, a box of width 0.02 across x = ½ above the centre: the
    enclosures of Q and of its derivatives are finite and narrow (the jump of atan, seen as a
    jump, made its gradient unbounded and its value [0, 1] wide)."""
    angle = "180/pi*(atan((y - 0.5)/(x - 0.5)) + 4*pi*sqrt((x - 0.5)**2 + (y - 0.5)**2))"
    X, Y = (np.array([0.49]), np.array([0.51])), (np.array([0.80]), np.array([0.82]))
    for node in intervals.evaluate_all(_forms("1", "0.001", angle), X, Y):
        assert all(np.isfinite(lo).all() and np.isfinite(hi).all() for lo, hi in node)
        lo, hi = node[0]
        assert hi[0] - lo[0] < 0.4                           # the value: not the whole [0, 1]
    # half a half turn is no period of Q: the jump stays a jump, its slope unbounded
    half_turn = "90/pi*atan((y - 0.5)/(x - 0.5))"
    (_, (lo, hi), *_), *_ = intervals.evaluate_all(_forms("1", "0.001", half_turn), X, Y)
    assert lo[0] == -math.inf or hi[0] == math.inf
