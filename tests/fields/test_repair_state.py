"""The repair's one state (qmesh/fields/repair_state.py): after its steps change the mesh — flips,
splits of a field's and of a medium's edges, moves — `refresh` of the triangles they report
leaves the twins, means, shares, failing edges and qualities exactly as a state made afresh from
the new mesh has them (each round assembles only what changed)."""

import numpy as np
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh.fields import flips, moves, splits
from qmesh.fields.cache import ElementMeans
from qmesh.fields.piecewise import RegionMeans
from qmesh.fields.repair_state import RepairState
from tests.fields.test_certify import random_raster, square_mesh


def assert_as_made_afresh(state):
    """The state as one made from its mesh (with its means: each triangle's kept, whatever the
    order of its corners, so a row left stale would show)."""
    fresh = RepairState.of(state.P, state.T, state.field, reg=state.reg)
    for name in ("twin", "cut", "Qbar", "err", "s", "b"):
        assert np.array_equal(getattr(state, name), getattr(fresh, name)), name
    state.fail()
    assert np.array_equal(state.h, fresh.h) and np.array_equal(state.q, fresh.q)
    fresh.track_quality()
    assert np.array_equal(state.quality, fresh.quality, equal_nan=True)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(20, 150), cells=st.integers(2, 8),
       medium=st.booleans())
def test_each_step_then_refresh_leaves_the_state_a_fresh_one_would_have(seed, n, cells, medium):
    P, T = square_mesh(seed, n)
    edges, k1, k2, angle = random_raster(seed, cells, 3.0)
    field = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    reg = None
    if medium:                                   # the right half a constant Q of its own
        reg = (P[T].mean(axis=1)[:, 0] > 0.5).astype(np.int64)
        conductivity = {0: field, 1: qmesh.Anisotropy.principal(1.0, 30.0, 20.0)}
        means = RegionMeans(conductivity)
    else:
        means = ElementMeans(field)
    fixed = np.zeros(len(P), bool)
    fixed[:4] = True
    state = RepairState.of(P, T, means, fixed=fixed, reg=reg)
    state.track_quality()                        # kept up to date by each refresh
    state.refresh(state.flip(flips.mending_flips(state, state.h)))
    assert_as_made_afresh(state)
    if len(state.h):
        split = splits.split_failing if reg is None else splits.split_failing_medium
        n0, m0 = len(state.P), len(state.T)
        state.refresh(split(state, state.h, state.q))
        assert len(state.P) > n0 and len(state.T) > m0
        assert len(state.fixed) == len(state.out) == len(state.P)
        assert reg is None or len(state.reg) == len(state.T)
        assert_as_made_afresh(state)
    who = moves.movers(state.T, state.twin,
                       moves.free(state.T, state.cut, state.fixed, np.arange(len(state.P))),
                       np.random.default_rng(seed))
    state.refresh(moves.relax(state, None, who, shape=True))
    assert_as_made_afresh(state)
