"""Stitching face meshes: vertices a round-off apart from different faces are one vertex; two
such vertices in one face are a crack, refused."""

import numpy as np
import pytest

from qmesh.errors import QmeshError
from qmesh.media.stitch import _merged


def test_a_chain_of_near_vertices_from_different_faces_is_one_vertex():
    x = 0.3
    U = np.array([[0.0, 0.0], [x, 0.5], [np.nextafter(x, 1), 0.5], [np.nextafter(np.nextafter(x, 1), 1), 0.5],
                  [1.0, 1.0]])
    vid = np.array([0, 1, 4, 2, 3, 4])                 # face 0: 0, 1, 4; face 1: 2; face 2: 3, 4
    face_of = np.array([0, 0, 0, 1, 2, 2])
    pairs = np.array([[1, 2], [2, 3], [1, 3]])
    V, w = _merged(U, vid, pairs, face_of)
    assert V.tolist() == [[0.0, 0.0], [x, 0.5], [1.0, 1.0]]
    assert w.tolist() == [0, 1, 2, 1, 1, 2]


def test_two_near_vertices_of_one_face_are_refused():
    U = np.array([[0.0, 0.0], [0.3, 0.5], [np.nextafter(0.3, 1), 0.5]])
    vid, face_of = np.array([0, 1, 2]), np.array([0, 0, 0])
    with pytest.raises(QmeshError, match="round-off apart"):
        _merged(U, vid, np.array([[1, 2]]), face_of)
