"""Two regions touching in one point inside a third pinch it: refused, naming the pinch (the
README's Limits say so); the same regions apart mesh."""

import pytest

import qmesh

A = qmesh.Anisotropy.constant
COND = {0: A([[1, 0], [0, 1]]), 1: A([[2, 0], [0, 1]]), 2: A([[1, 0], [0, 3]])}


def _two_squares(gap: float) -> qmesh.Domain:
    """The unit square with two squares inside, corner to corner at (0.5, 0.5) when gap = 0."""
    lo, hi = 0.5 - gap, 0.5 + gap
    return qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)],
                        regions=[[(hi, hi), (0.8, hi), (0.8, 0.8), (hi, 0.8)],
                                 [(0.2, 0.2), (lo, 0.2), (lo, lo), (0.2, lo)]])


def test_two_regions_touching_at_a_corner_inside_the_background_are_refused():
    with pytest.raises(qmesh.QmeshError, match="touch in a single point pinch") as e:
        qmesh.mesh(_two_squares(0.0), COND, target_vertices=200)
    assert "region 0" in str(e.value) and "please report" not in str(e.value)


def test_the_same_regions_apart_mesh():
    m = qmesh.mesh(_two_squares(0.05), COND, target_vertices=300)
    assert set(m.region_tags.tolist()) == {0, 1, 2}
    assert qmesh.measure.report(m, COND)["q_nonnegative_fraction"] == 1.0
