"""The proven error bound of a text's element means to third order (`means.enclosure_bound`):
it holds against converged references on random formulas, including jumps and kinks, falls as
the fourth power of a piece's size on smooth ones, and a piece whose children's enclosures
already prove it is not split."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.errors import QmeshError
from tests.fields import reference as ref
from tests.fields.test_bounded_means import expressions

SMOOTH = [("2 + sin(3*x + 2*y)", "0.3*cos(4*x)*y", "3 + x**2*y + cos(5*y)"),
          ("1e-4 + (1 - 1e-4)*(4*(y - 0.5))**2/((2*(x - 0.5))**2 + (4*(y - 0.5))**2)",
           "-(1 - 1e-4)*(2*(x - 0.5))*(4*(y - 0.5))/((2*(x - 0.5))**2 + (4*(y - 0.5))**2)",
           "1e-4 + (1 - 1e-4)*(2*(x - 0.5))**2/((2*(x - 0.5))**2 + (4*(y - 0.5))**2)")]
SPIRAL = ("1", "1e-3", "180/pi*(atan((y - 0.5)/(x - 0.5)) + 4*pi*sqrt((x - 0.5)**2 + (y - 0.5)**2))")


def _field(which):
    return (qmesh.TensorField.principal(*SPIRAL) if which == "spiral"
            else qmesh.TensorField.from_expressions(*SMOOTH[which]))


def _triangle(rng, centre, size):
    """A triangle of about `size` around `centre`, of any shape and orientation, not flat."""
    while True:
        P = centre + size * rng.uniform(-1, 1, (3, 2))
        u, v = P[1] - P[0], P[2] - P[0]
        if abs(u[0] * v[1] - u[1] * v[0]) > 0.1 * size ** 2:
            return P


@settings(max_examples=30, deadline=None)
@given(which=st.sampled_from([0, 1, "spiral"]), seed=st.integers(0, 2**32 - 1))
def test_the_bound_falls_as_the_fourth_power_of_the_piece_s_size(which, seed):
    """Halving a piece about its centroid divides its proven bound by about 16 (the cubic
    Taylor remainder's h⁴), not 8 (the quadratic's h³): at least 12 on pieces a fiftieth of
    the fields' scale, away from the plasma's and the spiral's centre."""
    rng = np.random.default_rng(seed)
    angle = rng.uniform(0, 2 * np.pi)
    centre = 0.5 + rng.uniform(0.2, 0.45) * np.array([np.cos(angle), np.sin(angle)])
    P = _triangle(rng, centre, 0.02)
    half = P.mean(axis=0) + 0.5 * (P - P.mean(axis=0))
    bound = _field(which)._enclosure()
    big, small = (bound(*(X[None, k] for k in range(3)))[0] for X in (P, half))
    assert np.isfinite(big) and big > 1e-9
    assert big / small >= 12, big / small


def test_a_triangle_its_children_prove_is_not_split(monkeypatch):
    """Asked for a bound its 4 children's enclosures already give (`enclosure_errors`), the
    proven means take the rule on the triangle and on its children alone: 35 points of Q."""
    F = qmesh.TensorField.principal(*SPIRAL)
    P = np.array([[0.8, 0.5], [0.83, 0.52], [0.79, 0.535]])
    T = np.array([[0, 1, 2]])
    proven = F.enclosure_errors(P, T)[0]
    Q, _ = F.means_with_error(P, T, rtol=1.0, bound_rtol=None)
    rtol = 1.001 * proven / np.linalg.norm(Q[0])
    points = []
    evaluate = F._evaluate
    monkeypatch.setattr(F, "_evaluate", lambda X: points.append(len(X)) or evaluate(X))
    Q, err = F.means_with_error(P, T, rtol=1.0, bound_rtol=rtol)
    assert err[0] <= rtol * np.linalg.norm(Q[0])
    assert sum(points) == 35


def _reference(F, P, levels):
    """The mean of F over the triangle P by a collapsed Gauss rule on 4**levels pieces."""
    return ref.fine_mean(lambda x, y: F(np.column_stack([x, y])), P, levels=levels, n=8)


@settings(max_examples=40, deadline=None)
@given(text=expressions, seed=st.integers(0, 2**32 - 1), size=st.sampled_from([0.3, 0.05, 0.01]))
def test_the_bound_holds_on_random_formulas(text, seed, size):
    """A random formula (sums, products, quotients, abs and its jumps, the whitelisted
    functions) squashed into q11 = 2 + tanh(f) > 0, on a random triangle: the proven means are
    within their bound of a reference of 4096 pieces, give or take how far the reference moved
    from 1024 pieces (it converges slowly only where f has a kink or a jump)."""
    F = qmesh.TensorField.from_expressions(f"2 + tanh({text})", "0.1", "1")
    rng = np.random.default_rng(seed)
    P = _triangle(rng, rng.uniform(-1, 1, 2), size)
    try:
        Q, err = F.means_with_error(P, [[0, 1, 2]])
        fine, finer = _reference(F, P, 4), _reference(F, P, 5)
    except QmeshError:                        # f undefined somewhere on the triangle
        assume(False)
    assume(np.all(np.isfinite(finer)))
    slack = 2 * np.linalg.norm(finer - fine) + 1e-12
    assert np.linalg.norm(Q[0] - finer) <= err[0] + slack


@pytest.mark.parametrize("which", [0, 1, "spiral"])
def test_a_smooth_text_s_proven_means_agree_with_the_reference(which):
    """Proven to 1e-6 of ‖Q̄_T‖ on triangles a tenth of the fields' scale: the means are within
    that of a converged reference, and the bound is within it."""
    F = _field(which)
    rng = np.random.default_rng(5)
    for _ in range(4):
        angle = rng.uniform(0, 2 * np.pi)
        P = _triangle(rng, 0.5 + 0.35 * np.array([np.cos(angle), np.sin(angle)]), 0.1)
        Q, err = F.means_with_error(P, [[0, 1, 2]], bound_rtol=1e-6)
        exact = _reference(F, P, 4)
        assert err[0] <= 1e-6 * np.linalg.norm(Q[0]) * (1 + 1e-9)
        assert np.linalg.norm(Q[0] - exact) <= err[0] + 1e-12
