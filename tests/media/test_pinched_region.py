"""Two regions touching in one point inside a third pinch it: refused, naming the pinch (the
README's Limits say so)."""

import pytest

import qmesh


def test_two_regions_touching_at_a_corner_inside_the_background_are_refused():
    A = qmesh.Anisotropy.constant
    dom = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)],
                       regions=[[(0.5, 0.5), (0.8, 0.5), (0.8, 0.8), (0.5, 0.8)],
                                [(0.2, 0.2), (0.5, 0.2), (0.5, 0.5), (0.2, 0.5)]])
    cond = {0: A([[1, 0], [0, 1]]), 1: A([[2, 0], [0, 1]]), 2: A([[1, 0], [0, 3]])}
    with pytest.raises(qmesh.QmeshError, match="touch in a single point pinch") as e:
        qmesh.mesh(dom, cond, target_vertices=200)
    assert "region 0" in str(e.value) and "please report" not in str(e.value)


def test_the_same_regions_apart_mesh():
    A = qmesh.Anisotropy.constant
    dom = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)],
                       regions=[[(0.55, 0.55), (0.8, 0.55), (0.8, 0.8), (0.55, 0.8)],
                                [(0.2, 0.2), (0.45, 0.2), (0.45, 0.45), (0.2, 0.45)]])
    cond = {0: A([[1, 0], [0, 1]]), 1: A([[2, 0], [0, 1]]), 2: A([[1, 0], [0, 3]])}
    m = qmesh.mesh(dom, cond, target_vertices=300)
    assert set(m.region_tags.tolist()) == {0, 1, 2}
    assert qmesh.measure.report(m, cond)["q_nonnegative_fraction"] == 1.0
