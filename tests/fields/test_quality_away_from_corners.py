"""Quality away from the corners on the field benchmark's magnetic islands (a callable, 1e4 : 1):
the polish goes on while it still lifts triangles below 0.3 and merges the fans where a field
line touches a side, so that none below 0.3 is left there or by the O- and X-points, and none
far below it anywhere away from the domain's sharp corners; and the classes
`benchmarks/quality_fields.py` sorts them into, checked on small meshes whose answer is known."""

import sys
import warnings
from pathlib import Path

import numpy as np

import qmesh
from qmesh import measure

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
import bench_fields as bench  # noqa: E402
import quality_fields  # noqa: E402

AWAY = 0.2      # the worst quality allowed away from the sharp corners


def _islands(n):
    case = bench.CASES["islands"]
    field = case.field()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        return case, field, qmesh.mesh(case.domain(), field, target_vertices=n)


def test_islands_keep_no_triangle_far_below_the_floor_away_from_sharp_corners():
    case, field, mesh = _islands(2000)
    q = measure.quality(mesh, mesh.conductivity)
    low, cls, _ = quality_fields.classify(case, mesh, field, q)
    corner = cls == quality_fields.CLASSES.index("corner")
    assert corner.any() and q[low[corner]].min() < AWAY      # the corners' own bound is lower
    assert q[low[~corner]].min() >= AWAY
    near = np.isin(cls, [quality_fields.CLASSES.index(c) for c in ("touch", "singular")])
    assert not near.any(), q[low[near]]
    # the polish moved no certificate: every q_ij >= 0 with the means the mesh carries
    shares = measure.q_nonnegative_fractions(mesh, mesh.conductivity)
    assert shares["q_nonnegative_fraction"] == shares["q_nonnegative_fraction_boundary"] == 1.0


def _square(P):
    """A triangulation of points P in the unit square (its four corners first)."""
    from scipy.spatial import Delaunay
    return qmesh.Mesh(P, Delaunay(P).simplices)


def test_a_touch_point_is_found_where_the_field_runs_along_a_side_and_turns():
    """The islands' field is along the side x = 0 at y = ½ only (b = (y − ½, 0.1π)): one touch
    there, and at (¼, 0), (¾, 0), (¼, 1), (¾, 1) where b = (∓½, 0) runs along y = 0 and y = 1."""
    t = np.linspace(0.0, 1.0, 41)[1:-1]
    side = np.concatenate([np.column_stack([t, 0 * t]), np.column_stack([0 * t + 1, t]),
                           np.column_stack([t, 0 * t + 1]), np.column_stack([0 * t, t])])
    P = np.concatenate([[(0, 0), (1, 0), (1, 1), (0, 1)], side, [(0.5, 0.5), (0.3, 0.6)]])
    mesh = _square(P)
    found = quality_fields.touch_points(mesh, bench.CASES["islands"].field())
    want = np.array([(0, 0.5), (1, 0.5), (0.25, 0), (0.75, 0), (0.25, 1), (0.75, 1)])
    assert len(found) == len(want)
    assert np.hypot(*(found[:, None] - want[None]).transpose(2, 0, 1)).min(axis=0).max() <= 0.025


def test_a_corner_is_sharp_where_its_wedge_is_narrow_in_the_metric():
    """A square corner is 90° in the identity metric, and acos(99/101) = 11.4° in the metric
    [[101, 99], [99, 101]] / 20 (det 1), whose sides u = (1, 0) and w = (0, 1) have |u|² = |w|²
    = 101/20 and u·w = 99/20; a reflex corner is measured the long way round."""
    H = np.stack([np.eye(2), np.array([[101.0, 99.0], [99.0, 101.0]]) / 20])
    u, w = np.array([[1.0, 0.0], [0.0, 1.0]]), np.array([[0.0, 1.0], [1.0, 0.0]])
    a = quality_fields.wedge_angles(H, u, w)
    assert np.allclose(a[:, 0], [np.pi / 2, np.arccos(99 / 101)])
    assert np.allclose(a[:, 1], [3 * np.pi / 2, 2 * np.pi - np.arccos(99 / 101)])
