"""A constant TensorField (numbers only) is the constant Q it holds: meshed on the constant Q's
own path, it gives `Anisotropy.constant`'s mesh, certified, with Q as every element's mean."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh


@settings(max_examples=6, deadline=None)
@given(k2=st.floats(1e-3, 1.0), angle=st.floats(0.0, 180.0), n=st.integers(150, 600))
def test_a_constant_field_meshes_as_its_anisotropy(k2, angle, n):
    domain = qmesh.Domain([(0, 0), (2, 0), (2, 1), (0, 1)], [qmesh.Disk(12, 0.3, (1.0, 0.5))])
    field = qmesh.TensorField.principal(1.0, k2, angle)
    Q = field.constant_matrix
    assert Q is not None and np.allclose(Q, field(np.array([[0.3, 0.7]]))[0], rtol=0, atol=1e-15)
    a = qmesh.mesh(domain, qmesh.Anisotropy.constant(Q), target_vertices=n)
    b = qmesh.mesh(domain, field, target_vertices=n)
    assert np.array_equal(b.points, a.points) and np.array_equal(b.triangles, a.triangles)
    assert np.array_equal(b.conductivity, np.broadcast_to(Q, (b.n_triangles, 2, 2)))
    steps = list(qmesh.iterate(domain, field, target_vertices=n))
    assert steps[-1].converged and not any(s.converged for s in steps[:-1])


def test_a_varying_field_has_no_constant_matrix():
    assert qmesh.TensorField.from_expressions("1 + x", "0", "1").constant_matrix is None
    assert qmesh.TensorField(lambda x, y: np.broadcast_to(np.eye(2), np.shape(x) + (2, 2))
                             ).constant_matrix is None
