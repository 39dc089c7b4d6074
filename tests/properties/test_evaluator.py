"""The evaluator itself: a correct mesh built by hand passes every invariant, and each kind of
corruption is caught under its own category (so a green property suite means something)."""

import numpy as np
import pytest

import invariants
import qmesh

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
# the unit square with its centre: four right isosceles triangles, every q_ij ≥ 0 for Q = I
POINTS = np.vstack([SQUARE, [[0.5, 0.5]]])
TRIANGLES = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
FIXED = np.array([True, True, True, True, False])


def mesh(points=POINTS, triangles=TRIANGLES, fixed=FIXED):
    return qmesh.Mesh(points, triangles, fixed=fixed)


def categories(m, rings=(SQUARE,), **kw):
    return {invariants.category(d) for d in invariants.defects(m, list(rings), **kw)}


def test_a_correct_mesh_passes():
    assert invariants.defects(mesh(), [SQUARE], Q=np.eye(2), target=5) == []


def test_far_from_the_origin_round_off_is_allowed():
    shift = np.array([1e6, -3e5])
    assert invariants.defects(mesh(POINTS + shift), [SQUARE + shift], Q=np.eye(2)) == []


@pytest.mark.parametrize("change, expected", [
    # (a NaN vertex cannot be built any more: qmesh.Mesh refuses it, see test_measure_args.py)
    (lambda P, T, F: (P, T[:, [0, 2, 1]], F), {"orientation", "area"}),
    (lambda P, T, F: (P, T[:3], F), {"area", "boundary"}),          # still a disk: Euler holds
    (lambda P, T, F: (P + [[0, 0], [0, 0], [0, 0], [0, 0], [0.7, 0]], T, F), {"orientation", "inside"}),
    (lambda P, T, F: (P, T, np.ones(5, bool)), {"fixed"}),
    (lambda P, T, F: (P * [1, 1 + 1e-12], T, F), {"inputs"}),      # off by 1e-12: not bit-exact
])
def test_each_corruption_is_caught(change, expected):
    P, T, F = change(POINTS.copy(), TRIANGLES.copy(), FIXED.copy())
    found = categories(mesh(P, T, F), Q=np.eye(2))
    assert expected <= found, found


def test_repeated_vertex_and_unused_vertex():
    T = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 3]])
    found = categories(mesh(POINTS, T), Q=None)
    assert {"repeated", "unused"} <= found


def test_negative_weight_on_a_boundary_edge():
    """Move the centre towards the bottom edge: the bottom triangle's angle at the centre turns
    obtuse, so for Q = I the bottom edge's weight ½ cot θ is negative; the spokes stay ≥ 0."""
    P = POINTS.copy()
    P[4] = [0.5, 0.1]
    assert categories(mesh(P), Q=np.eye(2)) == {"q_ij-boundary"}


def test_target_count():
    assert categories(mesh(), target=10) == {"count"}
    assert categories(mesh(), target=5) == set()


def test_holes_change_the_expected_euler_characteristic():
    hole = np.array([[0.4, 0.4], [0.4, 0.6], [0.6, 0.6], [0.6, 0.4]])
    assert "euler" in categories(mesh(), rings=(SQUARE, hole))


def test_difference_matches_vertices_by_position():
    m = mesh()
    order = np.array([4, 3, 2, 1, 0])
    inverse = np.argsort(order)
    renumbered = qmesh.Mesh(POINTS[order] * 2 + 7, inverse[TRIANGLES], fixed=FIXED[order])
    assert invariants.difference(m, renumbered, shift=(7, 7), scale=2) is None
    moved = POINTS.copy()
    moved[4] += 0.01
    assert "not where" in invariants.difference(m, mesh(moved))


def test_negative_weight_on_an_interior_edge():
    """A flat rhombus cut along its long diagonal: both angles facing the diagonal are obtuse,
    so its weight ½(cot θ + cot θ') is negative; cut along the short one, every weight is ≥ 0."""
    P = np.array([[0.0, 0.0], [2.0, 0.0], [1.0, 0.2], [1.0, -0.2]])
    ring = P[[0, 3, 1, 2]]
    long_cut = qmesh.Mesh(P, [[0, 1, 2], [1, 0, 3]], fixed=np.ones(4, bool))
    short_cut = qmesh.Mesh(P, [[0, 3, 2], [3, 1, 2]], fixed=np.ones(4, bool))
    assert categories(long_cut, rings=(ring,), Q=np.eye(2)) == {"q_ij-interior"}
    assert categories(short_cut, rings=(ring,), Q=np.eye(2)) == set()
