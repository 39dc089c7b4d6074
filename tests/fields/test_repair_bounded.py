"""The repair is bounded before it is spent: a raster cell of extreme anisotropy among isotropic
ones made it split without end (hundreds of thousands of vertices, gigabytes); it now stops at
certify.growth_limit and refuses, naming the cell and its anisotropy."""

import re
import resource

import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

import qmesh
from qmesh.fields import certify


def _one_cell(k1: float, row: int, col: int, angle: float = 30.0):
    x = np.linspace(0, 1, 9)
    K1, ang = np.ones((8, 8)), np.zeros((8, 8))
    K1[row, col], ang[row, col] = k1, angle
    return qmesh.TensorField.from_raster(x, x, K1, np.ones((8, 8)), ang)


SQUARE = qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])


@settings(max_examples=6, deadline=None)
@given(st.sampled_from([1e11, 1e12, 1e14]), st.integers(1, 6), st.integers(1, 6))
@example(1e14, 5, 5).via("discovered failure")      # stalled near the limit: a warning, not a refusal
@example(1e14, 6, 5).via("discovered failure")      # seeded 50 000 lattice points, 60 s
def test_an_extreme_cell_is_refused_by_name_within_the_growth_limit(k1, row, col):
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(qmesh.QmeshError) as refused:
        qmesh.mesh(SQUARE, _one_cell(k1, row, col), target_vertices=200)
    said = str(refused.value)
    assert f"raster cell (row {row}, column {col})" in said
    ratio = float(re.search(r"where Q is ([0-9.e+]+) : 1", said).group(1))
    assert abs(ratio / k1 - 1) < 0.01          # the cell's own anisotropy, to round-off
    found = re.search(r"past (\d+) vertices|the limit is (\d+)", said)
    limit = int(found.group(1) or found.group(2))
    assert limit <= certify.growth_limit(300)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 1024 * 1024   # < 1 GiB more (KiB)


def test_a_strong_but_followable_cell_still_meshes_certified():
    m = qmesh.mesh(SQUARE, _one_cell(1e6, 3, 3), target_vertices=200)
    assert m.n_vertices < certify.growth_limit(200)
    assert qmesh.measure.q_nonnegative_fraction(m, None) == 1.0


def test_the_growth_limit_follows_the_mesh_and_the_memory_budget(monkeypatch):
    assert certify.growth_limit(200) == 200 + certify.SPARE
    assert certify.growth_limit(10_000) == certify.GROWTH * 10_000
    monkeypatch.setattr(certify.budget, "default_budget", lambda: certify.budget.FIXED_BYTES + 1600 * 5000)
    assert certify.growth_limit(4000) == 5000
