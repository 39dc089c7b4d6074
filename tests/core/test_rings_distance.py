"""rings.distance: the grid that rules out far points first and pairs the others with the
segments registered in their cell (`_grid`) changes nothing: every point gets the distance a
brute force over all (point, segment) pairs gives, or inf beyond `reach`, and exactly (bit for
bit) what pairing by y-bands alone gives, for rings of any size and position and any reach."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from qmesh.geometry import rings


def _brute(P, A, B, reach):
    """min over all segments of |p − closest point|, written out pair by pair (all pairs)."""
    ab = (B - A)[None]
    ap = P[:, None] - A[None]
    t = np.clip((ap * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-300), 0, 1)
    d = np.hypot(*(ap - t[..., None] * ab).transpose(2, 0, 1)).min(axis=1)
    return np.where(d <= reach, d, np.inf)


@given(seed=st.integers(0, 2**32 - 1), n_seg=st.integers(3, 40), log_size=st.floats(-6, 6),
       log_shift=st.floats(-3, 6), reach_share=st.floats(1e-4, 0.5), many=st.booleans())
@settings(max_examples=40, deadline=None)
def test_grid_prefilter_gives_the_brute_force_distances(seed, n_seg, log_size, log_shift, reach_share,
                                                        many):
    rng = np.random.default_rng(seed)
    size, shift = 10.0 ** log_size, 10.0 ** log_shift * rng.standard_normal(2)
    ang = np.sort(rng.uniform(0, 2 * np.pi, n_seg))
    R = size * rng.uniform(0.3, 1.0, n_seg)
    ring = shift + np.column_stack([R * np.cos(ang), R * np.sin(ang)])
    A, B = ring, np.roll(ring, -1, axis=0)
    n = rings.GRID_MIN + 10 if many else 500          # past GRID_MIN the grid is used
    P = shift + size * rng.uniform(-1.2, 1.2, (n, 2))
    reach = reach_share * size
    got = rings.distance(P, A, B, reach)
    want = _brute(P, A, B, reach)
    np.testing.assert_array_equal(got, rings._distance(P, A, B, reach))   # the y-band route
    assert np.array_equal(np.isfinite(got), np.isfinite(want))
    np.testing.assert_allclose(got[np.isfinite(got)], want[np.isfinite(want)], rtol=1e-9,
                               atol=1e-12 * (size + np.abs(shift).max()))


def test_the_grid_is_used_and_rules_out_most_points_of_a_large_cloud():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 2 * np.pi, 65)[:-1]
    ring = np.column_stack([np.cos(t), np.sin(t)])
    P = rng.uniform(-1, 1, (rings.GRID_MIN * 5, 2))
    grid = rings._grid(P, ring, np.roll(ring, -1, axis=0), 0.01)
    assert grid is not None and grid[0].mean() > 0.5 and grid[2] is not None


@pytest.mark.parametrize("register_max", [0, 10**9], ids=["y-bands", "cells"])
def test_both_pairings_of_the_band_give_the_y_band_distances(monkeypatch, register_max):
    """Past REGISTER_MAX registrations per point the band's points are paired by y-bands, else
    by cells; a flat ring of 1024 segments, a cloud around it, reaches of a fifth and of two and a half
    spacings."""
    monkeypatch.setattr(rings, "REGISTER_MAX", register_max)
    monkeypatch.setattr(rings, "REGISTER_FLOOR", register_max)
    rng = np.random.default_rng(3)
    t = np.sort(rng.uniform(0, 2 * np.pi, 1024))
    ring = np.column_stack([3 * np.cos(t), 0.2 * np.sin(t)])        # flat: long y-bands
    A, B = ring, np.roll(ring, -1, axis=0)
    P = rng.uniform([-3.3, -0.5], [3.3, 0.5], (rings.GRID_MIN + 100, 2))
    for reach in (4e-3, 5e-2):
        assert (rings._grid(P, A, B, reach)[2] is None) == (register_max == 0)
        np.testing.assert_array_equal(rings.distance(P, A, B, reach), rings._distance(P, A, B, reach))


def test_few_points_among_many_rings_side_by_side_take_the_grid(monkeypatch):
    """Below GRID_MIN, 400 hexagons on a grid put about 80 segments in every y-band: `distance`
    takes the grid (the bands would pair each point with them all) and still gives what the
    y-bands give, bit for bit."""
    k = 20
    t = np.pi / 3 * np.arange(6)
    unit = np.column_stack([np.cos(t), np.sin(t)]) / (3 * k)
    centres = (np.stack(np.meshgrid(np.arange(k), np.arange(k)), -1).reshape(-1, 2) + 0.5) / k
    A = np.concatenate([c + unit for c in centres])
    B = np.concatenate([c + np.roll(unit, -1, axis=0) for c in centres])
    P = np.random.default_rng(5).uniform(0, 1, (3000, 2))
    reach = 0.2 / k
    size = len(P) + len(A)
    assert size < rings.GRID_MIN
    order = np.argsort(P[:, 1], kind="stable")
    assert rings._band_pairs(P[order, 1], A, B, reach) > rings.GRID_PAIRS * size
    used = []
    monkeypatch.setattr(rings, "_grid", lambda *a, _g=rings._grid: used.append(1) or _g(*a))
    got = rings.distance(P, A, B, reach)
    assert used, "the grid was not used"
    np.testing.assert_array_equal(got, rings._distance(P, A, B, reach))
    assert np.isfinite(got).any() and not np.isfinite(got).all()
