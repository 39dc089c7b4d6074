"""A step spelled as a quotient — the Heaviside (u + abs(u))/(2*u), abs(u)/(2*u),
sqrt(u**2)/u — is enclosed as the step it is (`intervals.step_of`): its value between the two
sides' across u = 0, its own side's elsewhere. Enclosed as a quotient by an interval holding 0,
its value was unbounded on every piece the jump crosses: the proof fell back on the rule's
samples there, and took several times as long."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.conductivity import intervals
from qmesh.conductivity.expression import check, parse_function
from tests.fields import hostile_fields as hf
from tests.fields import truth
from tests.fields.reference import principal

U = "(x + 0.3*y - 0.537)"
SPELLINGS = {   # text of u → the step's value below and above u = 0
    "({u} + abs{u})/(2*{u})": (0.0, 1.0),
    "abs{u}/(2*{u})": (-0.5, 0.5),
    "(abs{u} - {u})/({u}*4)": (-0.5, 0.0),
    "-(3*abs{u} + {u})/(2*{u})": (1.0, -2.0),
    "sqrt({u}**2)/{u}": (-1.0, 1.0),
}


@pytest.mark.parametrize("spelling", SPELLINGS)
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_a_step_s_enclosure_holds_its_values_and_is_its_side_s_away_from_the_jump(spelling, seed):
    rng = np.random.default_rng(seed)
    text = spelling.format(u=U)
    below, above = SPELLINGS[spelling]
    k = 16
    lo = rng.uniform(0, 1, (k, 2))
    hi = lo + 10.0 ** rng.uniform(-4, -0.5, (k, 2))
    (vl, vh), gx, *_ = intervals.evaluate(check(text, "f"), (lo[:, 0], hi[:, 0]), (lo[:, 1], hi[:, 1]))
    corners = np.stack([lo, hi, np.column_stack([lo[:, 0], hi[:, 1]]),
                        np.column_stack([hi[:, 0], lo[:, 1]])])
    u = corners[..., 0] + 0.3 * corners[..., 1] - 0.537
    across = (u.min(axis=0) <= 0) & (u.max(axis=0) >= 0)
    side = np.where(u.max(axis=0) < 0, below, above)
    tol = 1e-14
    assert np.all(vl[across] <= min(below, above) + tol) and np.all(vh[across] >= max(below, above) - tol)
    assert np.all(vh[across] - vl[across] <= abs(above - below) * (1 + 1e-12) + 1e-299)
    assert np.allclose(vl[~across], side[~across], rtol=1e-14, atol=1e-299)
    assert np.allclose(vh[~across], side[~across], rtol=1e-14, atol=1e-299)
    assert np.all(gx[0][across] == -np.inf) and np.all(gx[1][across] == np.inf)
    X = rng.uniform(lo, hi)
    v = parse_function(text, "f")(X)
    inside = (v >= vl - tol) & (v <= vh + tol)
    assert inside.all(), (X[~inside], v[~inside])


def _heaviside_case():
    def base(x, y):
        return principal(1.0 + 99.0 * (x + 0.3 * y - 0.537 > 0), 1.0, 30.0)
    return hf.Case("Heaviside as a quotient", "tensor step",
                   lambda: qmesh.TensorField.principal(f"1 + 99*({U} + abs{U})/(2*{U})", 1, 30),
                   base, [(1.0, 0.3, 0.537)])


def test_a_heaviside_quotient_has_a_proven_bound_on_a_triangle_across_its_jump():
    """The enclosures of the triangle's 4 children bound its mean (it was ∞: unbounded)."""
    P = np.array([[0.4, 0.3], [0.6, 0.35], [0.5, 0.6]])
    T = np.array([[0, 1, 2]])
    F = _heaviside_case().field()
    bound = F.enclosure_errors(P, T)[0]
    Q, _ = F.means_with_error(P, T, bound_rtol=None)
    exact, _ = _heaviside_case().means(P, T)
    assert np.isfinite(bound) and bound < 99
    assert np.linalg.norm(Q[0] - exact[0]) <= bound


def test_a_heaviside_quotient_meshes_certified_and_true():
    """Meshed, every edge passes its certificate and the exact means."""
    _, v = truth.mesh_and_check(_heaviside_case(), 300)
    assert v.remaining == 0 and v.false_interior == v.false_boundary == v.outside == 0
