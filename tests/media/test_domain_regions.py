"""Domain(regions=...): what is accepted, and bad regions refused naming the region and segment."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import qmesh

SQUARE = [(0, 0), (2, 0), (2, 1), (0, 1)]
HOLE = [(0.2, 0.2), (0.4, 0.2), (0.3, 0.4)]


def test_regions_and_names_are_kept():
    d = qmesh.Domain(SQUARE, regions=[[(1, 0), (2, 0), (2, 1), (1, 1)]], region_names=["right"])
    assert len(d.regions) == 1 and d.region_names == {1: "right"}
    assert d.regions[0].area == pytest.approx(1.0)
    assert sorted(f.region for f in d.partition.faces) == [0, 1]


def test_a_region_with_a_hole_filled_by_another_region():
    ring = qmesh.Domain([(1, 0.2), (1.8, 0.2), (1.8, 0.8), (1, 0.8)], [[(1.2, 0.4), (1.4, 0.4), (1.3, 0.6)]])
    d = qmesh.Domain(SQUARE, [HOLE], regions=[ring, [(1.2, 0.4), (1.4, 0.4), (1.3, 0.6)]])
    faces = d.partition.faces
    assert sorted(f.region for f in faces) == [0, 1, 2]
    assert [len(f.cycles) for f in faces if f.region == 1] == [2]      # region 1 keeps its hole


def test_a_corner_on_another_regions_edge_splits_it():
    # region 2's corners (1, 0.3) and (1, 0.6) lie on region 1's left edge
    d = qmesh.Domain(SQUARE, regions=[[(1, 0), (2, 0), (2, 1), (1, 1)],
                                      [(0.5, 0.3), (1, 0.3), (1, 0.6), (0.5, 0.6)]])
    part = d.partition
    x1 = np.isclose(part.points[part.edges[:, 0], 0], 1) & np.isclose(part.points[part.edges[:, 1], 0], 1)
    assert x1.sum() == 3                          # x = 1 cut into three edges
    assert part.interface[x1].all()


@pytest.mark.parametrize("regions, words", [
    ([[(1, 0.2), (3, 0.2), (3, 0.8), (1, 0.8)]], ["region 1", "outline", "segment"]),
    ([[(0.5, 0.5), (1.5, 0.5), (1, 0.8)], [(0.5, 0.6), (1.5, 0.6), (1, 0.9)]], ["region 1", "region 2", "segment"]),
    ([[(0.1, 0.1), (0.5, 0.1), (0.5, 0.5), (0.1, 0.5)]], ["hole 1", "region 1", "segment"]),
    ([[(0.25, 0.25), (0.35, 0.25), (0.3, 0.3)]], ["region 1", "outside"]),
    ([[(0.5, 0.5), (0.7, 0.5), (0.6, 0.6)], [(0.1, 0.1) , (1.9, 0.1), (1.9, 0.9), (0.1, 0.9)]], ["region 2"]),
    ([[(3, 3), (4, 3), (4, 4)]], ["region 1", "outside"]),
    ([[(0, 0), (1, 1), (1, 0), (0, 1)]], ["region 1", "intersects itself"]),
    ([[(2, 0), (3, 0), (3, 1), (2, 1)]], ["region 1"]),
    (["abc"], ["region 1"]),
])
def test_bad_regions_are_refused_by_name(regions, words):
    with pytest.raises(qmesh.QmeshError) as e:
        qmesh.Domain(SQUARE, [HOLE], regions=regions)
    for w in words:
        assert w in str(e.value)


def test_region_names_checked():
    with pytest.raises(qmesh.QmeshError, match="one entry per region"):
        qmesh.Domain(SQUARE, regions=[[(1, 0), (2, 0), (2, 1), (1, 1)]], region_names=["a", "b"])


def _variant(ring, reverse, start, extra):
    """`ring` reversed or not, starting at point `start`, with a collinear point added at the
    middle of side `extra` (None: none)."""
    P = np.asarray(ring, float)
    if extra is not None:
        k = extra % len(P)
        P = np.insert(P, k + 1, 0.5 * (P[k] + P[(k + 1) % len(P)]), axis=0)
    if reverse:
        P = P[::-1]
    return np.roll(P, -start, axis=0)


@settings(max_examples=40, deadline=None)
@given(st.sampled_from([[(0.5, 0.2), (1.0, 0.2), (1.0, 0.6)],
                        [(0.3, 0.3), (1.2, 0.3), (1.4, 0.8), (0.3, 0.7)],
                        [(1, 0), (2, 0), (2, 1), (1, 1)]]),
       st.booleans(), st.integers(0, 5), st.one_of(st.none(), st.integers(0, 5)),
       st.booleans(), st.integers(0, 5), st.integers(0, 2))
def test_a_region_given_twice_is_refused_naming_both(ring, rev, start, extra, rev1, start1, other):
    first = _variant(ring, rev1, start1, None)
    second = _variant(ring, rev, start, extra)
    regions = [[(0.05, 0.05), (0.2, 0.05), (0.1, 0.15)], first, [(1.6, 0.85), (1.9, 0.85), (1.8, 0.95)]]
    at = [0, 1, 3][other]
    regions.insert(at, second)
    i, j = sorted((3 if at <= 1 else 2, at + 1))
    with pytest.raises(qmesh.QmeshError, match=f"region {i} and region {j} are the same polygon"):
        qmesh.Domain(SQUARE, regions=regions)


def test_regions_overlapping_along_an_edge_on_the_same_side_are_refused():
    with pytest.raises(qmesh.QmeshError, match="region 1 overlaps region 2"):
        qmesh.Domain(SQUARE, regions=[[(0.5, 0.2), (1, 0.2), (1, 0.6)], [(0.5, 0.2), (1, 0.2), (1, 0.7)]])
