"""A holed plate meshed by qmesh (outline "wall", hole "hole", Q = principal(1, 50, 30)), the
same mesh cut into two named regions, and the two-region plate with element means of a rotating
field: what the FEM round trips and the format tests write."""

import numpy as np
import pytest

import qmesh

Q_PLATE = qmesh.Anisotropy.principal(1, 50, 30)


@pytest.fixture(scope="session")
def plate():
    domain = qmesh.Domain([[0, 0], [2, 0], [2, 1], [0, 1]], holes=[[[0.8, 0.3], [1.2, 0.3], [1.2, 0.7], [0.8, 0.7]]],
                          names={1: "wall", 2: "hole"})
    return qmesh.mesh(domain, Q_PLATE, target_vertices=300)


@pytest.fixture(scope="session")
def two_regions(plate):
    """The plate with region 1 "left part" (centroid x < 1) and region 4 "right" (the rest)."""
    x = plate.points[plate.triangles].mean(axis=1)[:, 0]
    return qmesh.Mesh(plate.points, plate.triangles, plate.fixed, boundary_edges=plate.boundary_edges,
                      boundary_tags=plate.boundary_tags, tag_names=plate.tag_names,
                      region_tags=np.where(x < 1, 1, 4), region_names={1: "left part", 4: "right"})




@pytest.fixture(scope="session")
def with_means(two_regions):
    """The two-region plate with `conductivity`: the element means of Q = principal(1, 50, 30° + 40° x)."""
    field = qmesh.TensorField.principal(1, 50, "30 + 40*x")
    m = two_regions
    return qmesh.Mesh(m.points, m.triangles, m.fixed, boundary_edges=m.boundary_edges, boundary_tags=m.boundary_tags,
                      tag_names=m.tag_names, region_tags=m.region_tags, region_names=m.region_names,
                      conductivity=field.means(m.points, m.triangles))
