"""Q^p (`qmesh.conductivity.power`): Q's eigenvectors, its eigenvalues raised to p, for formulas,
callables, constants and rasters; p = 1 gives Q back, p = 0 the identity."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.conductivity.power import power, principal

P = np.array([[0.1, 0.2], [0.7, 0.4], [0.3, 0.9], [0.95, 0.05]])


def fields(k1, ratio, angle):
    """Q(x) of each kind: a formula, the same formula as a callable, a constant and a raster."""
    formula = qmesh.TensorField.principal(f"{k1} * (1 + x)", f"{k1 / ratio} * (1 + y)",
                                          f"{angle} + 40 * x * y")
    return {"formula": formula,
            "callable": qmesh.TensorField(lambda x, y: formula(np.column_stack([x, y]))),
            "constant": qmesh.TensorField.principal(k1, k1 / ratio, angle),
            "raster": qmesh.TensorField.from_raster([0, 0.5, 1], [0, 0.5, 1],
                                                    [[k1, 2 * k1], [k1 / 3, k1]],
                                                    [[k1 / ratio, k1 / 7], [k1 / ratio, k1]],
                                                    [[angle, 0], [-angle, 90]])}


@settings(deadline=None)                  # the first draw compiles the formulas
@given(k1=st.floats(1e-3, 1e3), ratio=st.floats(1.0, 1e4), angle=st.floats(-180, 180),
       p=st.floats(-1.5, 1.5))
def test_same_eigenvectors_eigenvalues_powered(k1, ratio, angle, p):
    for kind, Q in fields(k1, ratio, angle).items():
        A, B = Q(P), power(Q, p)(P)
        scale = np.abs(A).max() * np.abs(B).max()
        assert np.allclose(B @ A, A @ B, rtol=1e-9, atol=1e-9 * scale), kind
        k, V = np.linalg.eigh(A)
        # Vᵀ Q^p V = diag(k^p): Q's eigenvectors carry the powered eigenvalues
        D = np.swapaxes(V, 1, 2) @ B @ V
        assert np.allclose(np.diagonal(D, axis1=1, axis2=2), k ** p, rtol=1e-8), kind
        assert np.allclose(D[:, 0, 1], 0, atol=1e-8 * np.abs(D).max()), kind


@settings(deadline=None)
@given(k1=st.floats(1e-3, 1e3), ratio=st.floats(1.0, 1e4), angle=st.floats(-180, 180))
def test_one_gives_q_zero_gives_identity(k1, ratio, angle):
    for kind, Q in fields(k1, ratio, angle).items():
        assert np.allclose(power(Q, 1)(P), Q(P), rtol=1e-12, atol=1e-12 * np.abs(Q(P)).max()), kind
        assert np.allclose(power(Q, 0)(P), np.eye(2), rtol=0, atol=1e-12), kind


def test_kinds_kept_and_means_of_the_power():
    Q = fields(10.0, 100.0, 30.0)
    assert power(Q["constant"], 0.5).means_exact and power(Q["raster"], 0.5).is_raster
    assert not power(Q["formula"], 0.5).means_exact
    # a raster's Q^p is a raster of the powered cells: its exact means are the cells' powers
    R = power(Q["raster"], 0.5)
    cell = power(qmesh.TensorField.principal(10.0, 0.1, 30.0), 0.5)
    tri = [[0.1, 0.1], [0.4, 0.1], [0.1, 0.4]]             # inside the lower-left cell
    assert np.allclose(R.means(tri, [[0, 1, 2]]), cell(np.array([[0.2, 0.2]])), rtol=1e-12)


def test_every_kind_labelled_as_a_power():
    """The label a report and the viewer print says which power of which field was meshed."""
    for kind, field in fields(10.0, 100.0, 30.0).items():
        label = power(field, 0.5).label
        assert label == f"({field.label})^0.5", (kind, label)


@given(q=st.tuples(st.floats(1e-3, 1e3), st.floats(-1, 1), st.floats(1e-3, 1e3)))
def test_principal_rebuilds_q(q):
    a, c = q[0], q[2]
    b = q[1] * 0.999 * np.sqrt(a * c)
    k1, k2, t = principal(np.array([a, b, c]))
    R = np.array([[np.cos(np.radians(t)), -np.sin(np.radians(t))],
                  [np.sin(np.radians(t)), np.cos(np.radians(t))]])
    assert k1 >= k2 > 0
    assert np.allclose(R @ np.diag([k1, k2]) @ R.T, [[a, b], [b, c]], rtol=1e-9, atol=1e-12 * k1)


def test_refusals_name_the_argument():
    Q = fields(1.0, 10.0, 0.0)["formula"]
    for bad in (float("nan"), float("inf"), "0.5", True, None):
        with pytest.raises(qmesh.QmeshError, match="^p must be"):
            power(Q, bad)
    with pytest.raises(qmesh.QmeshError, match="^field must be a qmesh.TensorField"):
        power(np.eye(2), 0.5)
    with pytest.raises(qmesh.QmeshError, match=r"\^1e\+06: Q is not finite at \(x, y\)"):
        power(Q, 1e6)(P)
