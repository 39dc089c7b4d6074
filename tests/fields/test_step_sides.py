"""A jump across a straight line integrated side by side (`conductivity.sides`): a triangle the
line u = 0 crosses is cut along it, and each side's mean is a smooth field's. Enclosed as the
hull of the two sides, the pieces along the line kept about 1/256 of the jump in the bound
whatever the triangle's size, and a step between two 1000 : 1 tensors was never certified."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.conductivity import sides
from qmesh.conductivity.expression import check
from tests.fields import hostile_fields as hf
from tests.fields import truth


def _norms(Q):
    return np.linalg.norm(np.asarray(Q).reshape(-1, 4), axis=1)


def test_a_tensor_step_is_certified_and_true_at_a_small_n():
    """benchmarks/cert_truth.py's "tensor step 1" (738 : 1 at 64° where u < 0, 47 : 1 at 70°
    where u > 0): enclosed as the hull, 125 edges were left failing at 300 vertices."""
    case = next(c for c in hf.drawn(np.random.default_rng(0)) if c.name == "tensor step 1")
    _, v = truth.mesh_and_check(case, 300)
    assert v.remaining == 0
    assert v.false_interior == v.false_boundary == v.outside == 0
    assert v.largest_bound < 1e-8


def test_a_crossed_triangle_gets_the_exact_mean_with_a_bound_near_round_off():
    case = hf.draw("tensor step", np.random.default_rng(3))
    (a, b, c), = case.lines                                   # a x + b y = c
    F = case.field()
    foot = np.array([a, b]) * c / (a * a + b * b)            # a point of the line
    along, normal = np.array([-b, a]), np.array([a, b])
    P = foot + np.array([-0.05 * along - 0.03 * normal, 0.06 * along - 0.02 * normal,
                         0.01 * along + 0.04 * normal]) / np.hypot(a, b)
    T = np.array([[0, 1, 2]])
    exact, own = case.means(P, T)
    for Q, err in (F.means_with_error(P, T), F.means_with_error(P, T, bound_rtol=None)):
        size = _norms(exact)
        gap = _norms(np.asarray(Q) - exact)
        assert gap[0] <= 1e-13 * size[0] + own[0]
        assert gap[0] <= err[0] + own[0]
        assert err[0] < 1e-10 * size[0]
    proven = F.enclosure_errors(P, T)
    assert proven[0] < 1e-10 * _norms(exact)[0]


def test_only_jumps_across_one_affine_line_are_taken_side_by_side():
    u = "(x + 0.3*y - 0.537)"
    line = sides.step_line([check(f"2 + abs{u}/{u}", "f")])
    assert line is not None and line.line == (1.0, 0.3, -0.537)
    assert line.below == (("+", ("num", 2.0), ("num", -1.0)),)
    curved = "(x*y - 0.2)"
    assert sides.step_line([check(f"2 + abs{curved}/{curved}", "f")]) is None
    other = "(x - 0.5)"
    assert sides.step_line([check(f"3 + abs{u}/{u} + abs{other}/{other}", "f")]) is None
    assert sides.step_line([check("2 + abs(x - 0.5)", "f")]) is None


@settings(max_examples=30, deadline=None)
@given(phi=st.floats(0.0, np.pi), offset=st.floats(-0.2, 0.2), seed=st.integers(0, 2**32 - 1),
       size=st.floats(1e-4, 0.3), angle=st.booleans())
def test_a_mean_across_a_random_line_is_within_its_bound(phi, offset, seed, size, angle):
    """Random lines through random triangles (and triangles beside them): the stored mean, its
    estimate's proven bound and the refined bound hold the exact mean (clipped along the line)."""
    rng = np.random.default_rng(seed)
    a, b = float(np.cos(phi)), float(np.sin(phi))
    c = a * 0.5 + b * 0.5 + offset
    u = f"({a!r}*x + {b!r}*y - {c!r})"
    if angle:
        F = qmesh.TensorField.principal(300.0, 1.0, f"30 + 45 - 45*abs{u}/{u}")
        case = hf.Case("angle", "angle jump", lambda: F, lambda x, y: hf.principal(
            300.0, 1.0, 30.0 + np.where(a * x + b * y - c > 0, 0.0, 90.0)), [(a, b, c)])
    else:
        F = qmesh.TensorField.from_expressions(f"5 + 4*abs{u}/{u}", f"2 + 2*abs{u}/{u}",
                                               f"3 - 1*abs{u}/{u}")

        def step(x, y):
            s = np.where(a * x + b * y - c > 0, 1.0, -1.0)
            q11, q12, q22 = 5 + 4 * s, 2 + 2 * s, 3 - s
            return np.stack([np.stack([q11, q12], -1), np.stack([q12, q22], -1)], -2)
        case = hf.Case("step", "tensor step", lambda: F, step, [(a, b, c)])
    centre = np.array([0.5, 0.5]) + rng.uniform(-0.1, 0.1, 2)
    P = centre + size * rng.uniform(-1, 1, (12, 2))
    T = np.arange(12).reshape(4, 3)
    exact, own = case.means(P, T)
    room = own + 1e-13 * _norms(exact)
    Q, err = F.means_with_error(P, T, bound_rtol=None)
    assert np.all(_norms(np.asarray(Q) - exact) <= F.enclosure_errors(P, T) + room)
    Q, err = F.means_with_error(P, T)
    assert np.all(_norms(np.asarray(Q) - exact) <= err + room)


def test_a_side_s_values_are_checked_as_the_field_s_own():
    """The sides are evaluated from their own forms: a side where Q is not positive definite is
    refused, naming the point, as the field's evaluation refuses it."""
    F = qmesh.TensorField.from_expressions("1 + 2*abs(x - 0.5)/(x - 0.5)", 0, 1)
    P = np.array([[0.45, 0.1], [0.55, 0.1], [0.5, 0.2]])
    with pytest.raises(qmesh.QmeshError, match="not positive definite at"):
        F.means_with_error(P, [[0, 1, 2]])


def test_a_flat_triangle_on_the_line_keeps_a_finite_mean_and_bound():
    """A triangle of no area across the line (a repair's candidate can be one): its mean is a
    side's, its bound finite, where a cut would leave it no piece."""
    F = qmesh.TensorField.from_expressions("2 + abs(x - 0.5)/(x - 0.5)", 0, 1)
    P = np.array([[0.4, 0.1], [0.6, 0.1], [0.5, 0.1]])
    Q, err = F.means_with_error(P, [[0, 1, 2]])
    assert np.isfinite(err[0]) and np.all(np.isfinite(Q))
    assert np.asarray(Q)[0, 0, 0] in (1.0, 3.0)
    assert np.isfinite(F.enclosure_errors(P, [[0, 1, 2]])[0])
