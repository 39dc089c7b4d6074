"""Metric areas and quality (2.94) of triangles in a metric H, at any scale of H: a region's
adj Q may hold 1e300 or 1e-300, where det H over- or underflows."""

import warnings

import numpy as np
from hypothesis import given, settings, strategies as st

from qmesh.geometry.triangles import metric_areas, metric_measures, metric_quality

P = np.array([[0.0, 0.0], [1.0, 0.0], [0.3, 0.8], [1.2, 1.1]])
T = np.array([[0, 1, 2], [1, 3, 2]])


def spd(a, b, c):
    """[[a, b], [b, c]] made positive definite (c raised where it must be)."""
    return np.array([[a, b], [b, max(c, 2.0 * b * b / a)]])


@settings(max_examples=60, deadline=None)
@given(st.floats(0.1, 10.0), st.floats(-3.0, 3.0), st.floats(0.1, 10.0),
       st.integers(-1000, 1000))
def test_area_scales_and_quality_does_not_at_any_scale(a, b, c, k):
    H = np.repeat(spd(a, b, c)[None], len(T), axis=0)
    scaled = np.ldexp(H, k)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                 # no overflow, no underflow said
        area, quality = metric_areas(P, T, H), metric_quality(P, T, H)
        big_area, big_quality = metric_areas(P, T, scaled), metric_quality(P, T, scaled)
        chunked = metric_measures(P, T, scaled)
    assert np.array_equal(big_quality, quality)        # scale-free, to the bit
    assert np.array_equal(chunked[1], quality)
    finite = np.isfinite(np.ldexp(area, k))            # an area past 1.8e308 is inf, rightly
    assert np.array_equal(big_area[finite], np.ldexp(area, k)[finite])
    assert np.all(np.isinf(big_area[~finite]))
