"""qmesh.Domain: rings, holes, tags and names, and bad geometry named precisely."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
import qmesh.geometry.rings
from qmesh import QmeshError, domains

SQUARE = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
HOLE = 0.3 * SQUARE


def test_rings_are_oriented_and_seeds_keep_every_input_point():
    D = qmesh.Domain(SQUARE[::-1], [HOLE])                       # outline clockwise, hole CCW
    outer, hole = D.rings
    assert qmesh.geometry.rings.signed_area(outer) > 0 > qmesh.geometry.rings.signed_area(hole)
    assert sorted(map(tuple, D.seeds.tolist())) == sorted(map(tuple, np.vstack([SQUARE, HOLE]).tolist()))
    assert D.area == pytest.approx(4.0 - 0.36)
    # Ω is on the left of every segment: the left side of each midpoint is inside
    A, B = D.segment_ends
    E = B - A
    left = 0.5 * (A + B) + 1e-6 * np.column_stack([-E[:, 1], E[:, 0]])
    assert D.contains(left, tol=0).all()


def test_default_tags_and_names():
    D = qmesh.Domain(SQUARE, [HOLE - 0.5, HOLE + 0.5], names=["wall", "a", "b"])
    assert sorted(set(D.segment_tags.tolist())) == [1, 2, 3]
    np.testing.assert_array_equal(D.segment_tags[:4], 1)
    assert D.tag_names == {1: "wall", 2: "a", 3: "b"}


def test_per_segment_tags_follow_their_segment_when_a_ring_is_reversed():
    """Segment i of the input (point i → i+1) keeps its tag, whatever the orientation fix did."""
    tags = [11, 12, 13, 14]
    D = qmesh.Polygon(SQUARE[::-1], tags=tags)
    A, B = D.segment_ends
    given = SQUARE[::-1]
    for i, t in enumerate(tags):
        mid = 0.5 * (given[i] + given[(i + 1) % 4])
        k = D.edge_of(mid[None])[0]
        assert D.segment_tags[k] == t


def test_polygons_and_disks_are_accepted_as_rings():
    D = qmesh.Domain(qmesh.Disk(32), [qmesh.Disk(8, radius=0.2), qmesh.Polygon(HOLE + [0.55, -0.1])])
    assert len(D.holes) == 2
    assert D.area == pytest.approx(qmesh.Disk(32).area - qmesh.Disk(8, radius=0.2).area - 0.36)


@pytest.mark.parametrize("outer, holes, message", [
    ([[0, 0], [1, 1], [1, 0], [0, 1]], [], r"the outline intersects itself: segment 0 \(point 0 → 1\) meets segment 2"),
    (SQUARE, [[[0.9, 0], [1.5, 0.2], [0.9, 0.4]]], r"hole 1 crosses the outline"),
    (SQUARE, [HOLE, HOLE + 0.1], r"hole 2 crosses hole 1"),
    (SQUARE, [HOLE + 3], r"hole 1 is not inside the outline"),
    (SQUARE, [SQUARE * 0.5, SQUARE * 0.2], r"hole 2 lies inside hole 1"),
    (SQUARE, [[[0, 0], [0.2, 0], [0.2, 0], [0, 0.2]]], r"hole 1 has repeated points: point 1 and point 2"),
    (SQUARE, [[[-1, 0], [0, 0.5], [0, -0.5]]], r"hole 1 crosses the outline"),
    (SQUARE, [[[-1 + 1e-12, 0], [0, 0.5], [0, -0.5]]], r"point 0 of hole 1 touches segment 3 of the outline"),
    ([[0, 0], [2, 0], [1, 0], [1, 1]], [], r"intersects itself"),                      # a spike
    (SQUARE, [[[0, 0], [0.1, 0]]], r"hole 1 needs at least 3 points"),
    ("square", [], r"the outline must be an \(n, 2\) array"),
    (SQUARE, np.zeros((3, 2)), r"holes must be a list of polygons"),
])
def test_bad_geometry_names_the_ring_and_segment(outer, holes, message):
    with pytest.raises(QmeshError, match=message):
        qmesh.Domain(outer, holes)


@pytest.mark.parametrize("kwargs, message", [
    ({"tags": [1]}, "one entry per ring"),
    ({"tags": [1.5, 2]}, "must be integers"),
    ({"tags": [[1, 2], 2]}, "one integer or 4 integers"),
    ({"tags": [0, 2]}, "from 1 to"),
    ({"names": {1: 2}}, "map integer tags to strings"),
    ({"names": "outline"}, "got a string"),
])
def test_bad_tags_and_names(kwargs, message):
    with pytest.raises(QmeshError, match=message):
        qmesh.Domain(SQUARE, [HOLE], **kwargs)


def test_named_domains_are_valid_and_named():
    for name, make in domains.NAMED.items():
        D = make()
        assert D.area > 0, name
        assert set(D.tag_names) <= set(D.segment_tags.tolist()) or not D.tag_names, name


@settings(max_examples=40, deadline=None)
@given(scale=st.floats(-8, 8), shift=st.tuples(st.floats(-1e8, 1e8), st.floats(-1e8, 1e8)),
       n=st.integers(3, 200))
def test_far_and_tiny_disks_are_valid_domains(scale, shift, n):
    """A regular polygon is accepted at any scale and position, with its true area."""
    r = 10.0 ** scale
    c = np.array(shift) * r
    D = qmesh.Disk(n, radius=r, center=c)
    assert D.area == pytest.approx(0.5 * n * np.sin(2 * np.pi / n) * r * r, rel=1e-6)
