"""Apexes pushed out of a boundary edge's diametral ellipse (`conform.restore_conformity`)
keep every triangle of their stars, also when a triangle holds two of them and only one may
move: both were judged moved together, and the one kept alone could fold the triangle."""

import numpy as np

from qmesh.geometry.triangles import signed_areas
from qmesh.mesher.conform import _kept_pushes


def test_a_push_judged_beside_a_refused_one_is_judged_again_alone():
    P = np.array([(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (2.0, 0.0), (2.0, 1.0)])
    T = np.array([[0, 1, 2],        # holds both pushed apexes: fine when both move
                  [1, 3, 4]])       # folds when apex 1 moves: its push is refused
    c = np.array([1, 2])
    to = np.array([(3.0, -1.5), (2.0, -0.5)])
    assert np.all(signed_areas(np.array([P[0], to[0], to[1]]), np.array([[0, 1, 2]])) > 0)
    k, Pn, _ = _kept_pushes(P, T, np.arange(2), c, to)
    assert np.all(signed_areas(Pn, T) > 0)
    assert len(k) == 0               # apex 2 alone would fold the first triangle


def test_pushes_that_fold_nothing_are_all_kept():
    P = np.array([(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (2.0, 0.0), (2.0, 1.0)])
    T = np.array([[0, 1, 2], [1, 3, 4]])
    k, Pn, star = _kept_pushes(P, T, np.arange(2), np.array([1, 2]), np.array([(1.1, 0.1), (0.1, 1.1)]))
    assert list(k) == [0, 1] and np.allclose(Pn[[1, 2]], [(1.1, 0.1), (0.1, 1.1)])
    assert list(star) == [0, 1]      # the rows of T around the pushed apexes, for the flips
