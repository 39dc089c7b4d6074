"""A corner of 0.1°–1° in a field's metric meshes at the target, as it does under a constant Q:
both sides split at matching metric distances from the apex (mesher/corners.py). Its ordinary
splits halved towards the apex past any target: a quadrilateral with a 0.15° corner in
principal(1, 900, "30 + 5*x") was refused at 300 and 1000 vertices ("needs 1338")."""

import math

import numpy as np
from hypothesis import example, given
from hypothesis import strategies as st

import invariants
import qmesh
from strategies import Case, ConductivitySpec, examples, polygon_spec


def one_corner(theta: float, k: float, angle: float) -> np.ndarray:
    """A quadrilateral whose corner at the origin is theta degrees wide in the metric of
    principal(1, k, angle) (sides 1 and ½ there, its other corners wide), in user coordinates:
    x = H^{-1/2} X for the metric H = adj Q, computed here from Q's principal axes."""
    t = math.radians(theta)
    X = np.array([[0, 0], [1, 0], [1, 1], [0.5 * math.cos(t), 0.5 * math.sin(t)]])
    a = math.radians(angle)
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    # adj Q = R diag(k, 1) Rᵀ for Q = R diag(1, k) Rᵀ; its inverse square root maps X to x
    root = R @ np.diag([k ** -0.5, 1.0]) @ R.T
    P = X @ root.T
    return P / np.abs(P).max()


def field_case(theta, k, angle, turn, n) -> Case:
    P = one_corner(theta, k, angle)
    text = f"{angle!r} + {turn!r}*x"

    def build():
        return qmesh.TensorField.principal(1.0, k, text)

    cond = ConductivitySpec(f"qmesh.TensorField.principal(1.0, {k!r}, {text!r})", build, None,
                            {0: lambda X: np.asarray(build()(X))})
    return Case(polygon_spec("star", P), cond, dict(target_vertices=n))


@examples(0.03)
@given(log_theta=st.floats(-1.0, 0.0), k=st.floats(1.0, 1000.0), angle=st.floats(0.0, 180.0),
       turn=st.floats(0.0, 10.0), n=st.integers(200, 1000))
@example(log_theta=math.log10(0.15), k=900.0, angle=30.0, turn=5.0, n=300)
def test_a_corner_of_a_tenth_of_a_degree_in_a_field_meshes(log_theta, k, angle, turn, n):
    case = field_case(10.0 ** log_theta, k, angle, turn, n)
    out = invariants.run(case)
    assert not out.defects and out.error is None, (out.defects, out.error, case.reproducer())
    assert np.isclose(out.sharpest, 10.0 ** log_theta, rtol=1e-6)     # the corner is what it claims
