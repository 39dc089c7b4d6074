"""The benchmark's corner bound on the min metric quality (benchmarks/corners.py, as bench_fields.py uses it): never
below what a mesh reaches, 1 where every corner is 60° or wider in the metric, and reached by
the isosceles triangle that fills a sharp corner."""

import sys
from pathlib import Path

import numpy as np
from scipy.spatial import Delaunay
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh import measure
from tests.fields.test_certify import square_mesh

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import bench_fields as bench  # noqa: E402


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(5, 80), log_ratio=st.floats(0, 4),
       angle=st.floats(0, 180))
def test_no_mesh_beats_the_corner_bound(seed, n, log_ratio, angle):
    P, T = square_mesh(seed, n)
    Q = qmesh.conductivity.anisotropy.principal_matrix(1.0, 10.0 ** -log_ratio, angle)
    Qbar = np.broadcast_to(Q, (len(T), 2, 2)).copy()
    quality = measure.quality(qmesh.Mesh(P, T, np.zeros(len(P), bool)), Qbar)
    bound = bench.corner_bound(P, T, Qbar)
    assert np.nanmin(quality) <= bound + 1e-12
    if log_ratio == 0:
        assert bound == 1.0


def test_an_isosceles_triangle_in_a_sharp_corner_reaches_it():
    a = np.radians(20.0)
    P = np.array([[0.0, 0.0], [1.0, 0.0], [np.cos(a), np.sin(a)]])
    T = np.array([[0, 1, 2]])
    Qbar = np.eye(2)[None]
    q = measure.quality(qmesh.Mesh(P, T, np.ones(3, bool)), Qbar)
    assert np.isclose(bench.corner_bound(P, T, Qbar), q[0], rtol=1e-12)
    assert np.isclose(q[0], 2 * np.sqrt(3) * np.sin(a) / (2 + 4 * np.sin(a / 2) ** 2), rtol=1e-12)


def test_a_region_s_sharp_corner_bounds_a_medium():
    """A 20° wedge region inside a square: its tip bounds the medium's quality, though every
    corner of Ω is 90°; without the tags the bound sees only Ω's corners."""
    a = np.radians(20.0)
    wedge = np.array([[0.0, 0.0], [1.0, 0.0], [np.cos(a), np.sin(a)]])
    P = np.vstack([wedge, [[-1.0, -1.0], [2.0, -1.0], [2.0, 2.0], [-1.0, 2.0]]])
    T = Delaunay(P).simplices
    tags = (np.sort(T, axis=1) == [0, 1, 2]).all(axis=1).astype(int)
    assert tags.sum() == 1                                   # the wedge is one triangle
    Qbar = np.broadcast_to(np.eye(2), (len(T), 2, 2)).copy()
    q = measure.quality(qmesh.Mesh(P, T, np.zeros(len(P), bool)), Qbar)
    assert bench.corner_bound(P, T, Qbar) == 1.0
    assert np.isclose(bench.corner_bound(P, T, Qbar, tags), q[tags == 1][0], rtol=1e-12)
    assert np.nanmin(q) <= bench.corner_bound(P, T, Qbar, tags) + 1e-12
