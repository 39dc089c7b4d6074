"""The vertex moves look for their stars among the stars they already have (moves.py `_star`):
a try judged among a superset's star is judged exactly as over the whole mesh, and a polish or
relax round passes over the whole mesh once, however many chunks it judges its tries in."""

import numpy as np
from hypothesis import given, settings, strategies as st

from qmesh.fields import moves
from qmesh.geometry import topology
from tests.fields.test_try_means import _movers, _state


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(20, 150), reach=st.floats(0.001, 0.1),
       shape=st.booleans())
def test_a_try_judged_within_a_superset_s_star_is_judged_as_over_the_mesh(seed, n, reach, shape):
    P, T, v = _movers(seed, n)
    rng = np.random.default_rng(seed + 2)
    some = np.sort(rng.choice(v, max(1, len(v) // 2), replace=False))
    mask = np.zeros(len(P), bool)
    mask[v] = True
    within = np.flatnonzero(topology.touching(T, mask))
    D = rng.normal(0.0, reach, (3, len(some), 2))
    for how in ("rough", "means_with_error"):
        got = moves._judged(_state(P, T), some, D, shape, how=how, within=(within, T[within]))
        want = moves._judged(_state(P, T), some, D, shape, how=how)
        for g, w in zip(got, want):
            assert np.array_equal(g, w)


def _whole_mesh_passes(monkeypatch, M):
    """Count the `touching` calls over all M triangles of the mesh (moves.py's name for it)."""
    passes = []
    touching = topology.touching
    monkeypatch.setattr(moves, "touching",
                        lambda T, mask: (passes.append(len(T) == M), touching(T, mask))[1])
    return passes


def test_a_polish_round_passes_over_the_mesh_once(monkeypatch):
    """Judged in chunks of 16 movers, its kept tries' stars found too: one pass over the whole
    mesh (not one more for each chunk, one for the kept tries and one for the moved stars),
    the same moves."""
    P, T, v = _movers(3, 400)
    want = _state(P, T)
    moves.polish(want, v)
    monkeypatch.setattr(moves, "POLISH_MOVERS", 16)
    passes = _whole_mesh_passes(monkeypatch, len(T))
    got = _state(P, T)
    changed = moves.polish(got, v)
    assert len(changed) and sum(passes) == 1
    assert np.array_equal(got.P, want.P)


def test_a_relax_round_passes_over_the_mesh_once(monkeypatch):
    """Its rough and adaptive judgements and the stars it moved: one pass over the whole mesh
    (not three or more), the same moves."""
    P, T, v = _movers(5, 400)
    metric = None
    want = _state(P, T)
    moves.relax(want, metric, v, shape=True)
    passes = _whole_mesh_passes(monkeypatch, len(T))
    got = _state(P, T)
    changed = moves.relax(got, metric, v, shape=True)
    assert len(changed) and sum(passes) == 1
    assert np.array_equal(got.P, want.P)
