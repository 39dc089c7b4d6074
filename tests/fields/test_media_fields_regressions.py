"""Media whose regions hold fields that once broke the mesher, now meshed with valid triangles
and no NumPy warning: a strong rotating field around an isotropic inclusion (a grading point
put exactly on a vertex, then flat triangles and a division by zero in the vertex step) and
a field in a layer whose lattice seeds no point (log2 of 0 in the seeding's conflict search)."""

import warnings

import numpy as np
import pytest

import qmesh
from qmesh.domain import media_cases
from qmesh.geometry.triangles import signed_areas


def background_field_around_isotropic_star():
    domain, conductivity, _ = media_cases.inclusion()
    c = dict(conductivity)
    c[0] = qmesh.TensorField.principal(1, 1e-3, "30*sin(pi*x)")
    c[1] = qmesh.Anisotropy.constant([[1e-3, 0.0], [0.0, 1e-3]])
    return domain, c


def field_in_the_first_layer():
    domain, conductivity, _ = media_cases.layered()
    return domain, {**conductivity, 0: qmesh.TensorField.principal(1, 1e-2, "40*x")}


@pytest.mark.parametrize("case", [background_field_around_isotropic_star, field_in_the_first_layer])
def test_meshed_with_valid_triangles_and_no_numpy_warning(case):
    domain, conductivity = case()
    with warnings.catch_warnings(record=True) as said, np.errstate(all="raise"):
        warnings.simplefilter("always")
        mesh = qmesh.mesh(domain, conductivity, target_vertices=1500)
    assert not [w for w in said if not issubclass(w.category, qmesh.QmeshWarning)]
    assert np.all(signed_areas(mesh.points, mesh.triangles) > 0)
    assert len(np.unique(mesh.points, axis=0)) == mesh.n_vertices
