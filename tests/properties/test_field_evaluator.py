"""The evaluator's field and media checks: q_ij ≥ 0 with one conductivity per triangle (each
interface share on its own), and a corner's angle in the metric, on hand-made cases whose answer
is known without qmesh."""

import math

import numpy as np
import pytest

from field_invariants import corner_angles, q_defects, refused_corner, shares

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
POINTS = np.vstack([SQUARE, [[0.5, 0.5]]])
TRIANGLES = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
I4 = np.broadcast_to(np.eye(2), (4, 2, 2))


def test_shares_are_half_the_cotangents_for_q_identity():
    # right isosceles triangles: 90° at the centre (its opposite edge, a side: cot = 0), 45° at
    # the corners (cot = 1, share ½)
    np.testing.assert_allclose(shares(POINTS, TRIANGLES, I4), [[0.5, 0.5, 0.0]] * 4, atol=1e-15)


def test_the_square_passes_and_a_stretched_q_fails_on_its_sides():
    assert q_defects(POINTS, TRIANGLES, I4) == []
    # Q = diag(1, 100): in adj Q = diag(100, 1) the centre's angle over each side is obtuse
    Q = np.broadcast_to(np.diag([1.0, 100.0]), (4, 2, 2))
    assert {d.split(":")[0] for d in q_defects(POINTS, TRIANGLES, Q)} == {"q_ij-boundary"}


def test_an_interface_share_is_judged_on_its_own():
    # the square cut along its diagonal 0–2 into two triangles; in one Q = [[1, .9], [.9, 1]],
    # in the other [[1, -.9], [-.9, 1]]: the diagonal's two shares have opposite signs and sum
    # to 0, which passes as an interior edge and fails as an interface
    T = np.array([[0, 1, 2], [0, 2, 3]])
    Q = np.stack([np.array([[1, 0.9], [0.9, 1]]), np.array([[1, -0.9], [-0.9, 1]])])
    q = shares(SQUARE, T, Q)
    diagonal = np.array([q[0, 1], q[1, 2]])       # opposite corner 1 of the first, 2 of the second
    assert diagonal.min() < 0 < diagonal.max()
    np.testing.assert_allclose(diagonal.sum(), 0.0, atol=1e-15)
    as_interior = {d.split(":")[0] for d in q_defects(SQUARE, T, Q, np.array([0, 0]))}
    as_interface = {d.split(":")[0] for d in q_defects(SQUARE, T, Q, np.array([0, 1]))}
    assert "q_ij-interface" in as_interface and not {"q_ij-interface", "q_ij-interior"} & as_interior


@pytest.mark.parametrize("h1, h2", [(1.0, 1.0), (1.0, 100.0), (900.0, 1.0)])
def test_corner_angles_in_a_diagonal_metric(h1, h2):
    # the square's corner at the origin cut by region 1 (the triangle 0, 1, 2): in the metric
    # adj Q = diag(h1, h2) the angle between (1, 0) and (1, 1) is atan √(h2/h1), the one
    # between (1, 1) and (0, 1) atan √(h1/h2)
    Q = np.diag([h2, h1])
    const = (lambda P: np.broadcast_to(Q, (len(P), 2, 2)))
    region = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    got = {r: a for a, r in corner_angles([0.0, 0.0], [SQUARE], [region], {0: const, 1: const})}
    np.testing.assert_allclose([got[1], got[0]], np.degrees([math.atan(math.sqrt(h2 / h1)),
                                                            math.atan(math.sqrt(h1 / h2))]), rtol=1e-9)


def test_a_corner_refusal_is_read_from_its_message():
    text = "the corner at (0.5, -2) is 0.0371° in the metric: too sharp"
    assert refused_corner(text) == (0.5, -2.0, 0.0371)
    assert refused_corner("target_vertices = 10 is too few") is None


@pytest.mark.parametrize("turn", np.linspace(0.1, 3.0, 12))
def test_a_right_angle_s_round_off_is_not_a_failure(turn):
    # the square with its centre, turned: the centre's right angles give shares of ±eps beside
    # shares of ½, which is round-off, not an obtuse angle
    R = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    assert q_defects(POINTS @ R.T + [3.0, -7.0], TRIANGLES, I4) == []
