"""The enclosure bound of a piece counts the mean of the Taylor remainder over the piece, not
twice its largest value: still above the rule's actual error on a smooth field, and 5/8 of the
range bound on the third-order term."""

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.conductivity import means as _m

SMOOTH = ("2 + sin(3*x + 2*y) + exp(x*y)", "0.3*cos(4*x)*y", "3 + x**2*y + cos(5*y)")


def reference_means(field, A, B, C, levels=4):
    """Means of the 7-point rule on the 4**levels midpoint pieces: the rule's error shrinks 64×
    a level, far below the bounds compared with."""
    for _ in range(levels):
        A, B, C = _m._children(A, B, C)
    k = len(A) // 4 ** levels
    q = _m.rule_averages(field._evaluate, A, B, C)
    return q.reshape(4 ** levels, k, 3).mean(axis=0)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), size=st.floats(1e-3, 0.4))
def test_the_bound_holds_the_error_of_the_rule_on_the_four_children(seed, size):
    rng = np.random.default_rng(seed)
    A = rng.uniform(-1, 1, (16, 2))
    B, C = A + size * rng.uniform(-1, 1, (16, 2)), A + size * rng.uniform(-1, 1, (16, 2))
    area = np.abs((B - A)[:, 0] * (C - A)[:, 1] - (B - A)[:, 1] * (C - A)[:, 0])
    assume(np.all(area > 1e-2 * size ** 2))
    field = qmesh.TensorField.from_expressions(*SMOOTH)
    bound = field._enclosure()(A, B, C)
    fine = _m._fine(_m.rule_averages(field._evaluate, *_m._children(A, B, C)))
    error = _m.frobenius(fine - reference_means(field, A, B, C))
    assert np.all(error <= bound), (error / bound).max()


def test_the_third_order_term_is_five_eighths_of_the_range_bound():
    # q11 = 1 + 10x + x⁴ on the corner triangle of legs h: ∂xxx q11 = 24x spans 24h over the
    # box, r_x = 2h/3, so the range bound (1/6) w r³ is 32h⁴/27 and the mean's 5/48 w r³ is
    # 20h⁴/27 (the second-order one 5h⁴/3, the first-order one 3h²/2 + ..., the value's width
    # 10h + h⁴); a relative 1e-13 of |q11| for the rule's round-off: its error is 0 here
    h = 1e-2
    field = qmesh.TensorField.from_expressions("1 + 10*x + x**4", "0", "1")
    A, B, C = np.array([[0.0, 0.0]]), np.array([[h, 0.0]]), np.array([[0.0, h]])
    bound = field._enclosure()(A, B, C)[0]
    third = 20 * h ** 4 / 27
    assert third <= bound <= third * (1 + 1e-6) + 1e-13 * (1 + 10 * h + h ** 4) * 1.01
