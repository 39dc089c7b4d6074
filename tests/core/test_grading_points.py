"""Ruppert's points of the insert stage (`insert._grading_points`) never land on a vertex.

Where the triangulation is not Delaunay in a bad triangle's metric (a metric that varies, as a
field's), another vertex may lie inside its circumcircle, even at its centre: a point put there
duplicated that vertex, and the flat triangles around the pair made the vertex step divide by
zero (a medium whose background held a rotating 1000:1 field, around an isotropic inclusion)."""

import numpy as np

from qmesh.geometry import topology
from qmesh.mesher.insert import _grading_points


def test_a_circumcentre_on_a_vertex_is_not_inserted():
    # a, b: a short boundary edge; c: the obtuse triangle's far apex; d: exactly at the metric
    # (here Euclidean) circumcentre of abc, across bc
    a, b, c = (0.0, 0.0), (0.1, 0.0), (-0.3, 0.5)
    centre = (0.05, 0.37)
    P = np.array([a, b, c, centre])
    T = np.array([[0, 1, 2], [2, 1, 3]])
    twin = topology.twins(T)
    H = np.broadcast_to(np.eye(2), (2, 2, 2))
    grade = np.array([True, False])
    quality = np.array([0.1, 0.5])
    tri, points, host = _grading_points(P, T, twin, H, quality, grade, budget=5)
    assert len(points) == 0 or np.min(np.linalg.norm(points[:, None] - P[None], axis=2)) > 0.1


def test_a_circumcentre_clear_of_the_vertices_is_still_inserted():
    """The same triangle with the fourth vertex moved well away: its circumcentre is used."""
    a, b, c = (0.0, 0.0), (0.1, 0.0), (-0.3, 0.5)
    P = np.array([a, b, c, (0.6, 0.6)])
    T = np.array([[0, 1, 2], [2, 1, 3]])
    twin = topology.twins(T)
    H = np.broadcast_to(np.eye(2), (2, 2, 2))
    tri, points, host = _grading_points(P, T, twin, H, np.array([0.1, 0.5]),
                                        np.array([True, False]), budget=5)
    assert np.allclose(points, [[0.05, 0.37]])
