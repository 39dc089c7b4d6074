"""Triangle's maximum-area switch in plain decimals: below 1e-4, `%g` gave
`a6.3e-05`, which Triangle reads as a6.3 and further switches, so the peer missed its target."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.compare import metric_peers


@settings(max_examples=60, deadline=None, derandomize=True)
@given(area=st.floats(1e-30, 1e6))
def test_area_switch_is_plain_decimals_of_the_same_number(area):
    text = metric_peers.area_switch(area)
    assert text[0] == "a" and set(text[1:]) <= set("0123456789.")
    assert float(text[1:]) == area


@pytest.mark.parametrize("target", [500, 2000])
def test_stretched_triangle_lands_on_target_for_areas_below_1e4(target):
    pytest.importorskip("triangle")
    small = qmesh.Polygon(0.02 * np.array([[0, 0], [1, 0], [1, 1], [0, 1]]))  # metric areas ~1e-7
    pm = metric_peers.stretched_triangle(small, qmesh.Anisotropy.constant(np.eye(2)), target)
    assert pm.h < 1e-4
    assert abs(pm.mesh.n_vertices - target) <= 0.03 * target
