"""The polish's side merges (qmesh/fields/merges.py) on fans: thin triangles over vertices in line
on a side, all from one apex, under a constant field of any anisotropy and angle."""

import numpy as np
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh.conductivity.anisotropy import shape_metric
from qmesh.fields import merges, moves, shares
from qmesh.fields.repair_state import RepairState
from qmesh.geometry import topology
from qmesh.geometry.triangles import metric_quality, signed_areas


def fan(xs, apex):
    """Triangles (x_i, x_i+1, apex) over the points (x_i, 0): the side's ends and the apex fixed."""
    P = np.concatenate([np.column_stack([xs, np.zeros(len(xs))]), [apex]])
    k = len(xs)
    T = np.column_stack([np.arange(k - 1), np.arange(1, k), np.full(k - 1, k)]).astype(np.int64)
    fixed = np.zeros(len(P), bool)
    fixed[[0, k - 1, k]] = True
    return P, T, fixed


def state_of(P, T, fixed, field):
    st_ = RepairState.of(P, T, field, fixed=fixed)
    return st_, moves.tangents(st_.P, st_.T, st_.twin, st_.fixed)


def worst(st_):
    return np.nanmin(metric_quality(st_.P, st_.T, shape_metric(st_.Qbar)))


def total_deficit(st_):
    g = np.where(st_.twin >= 0, st_.twin, np.arange(len(st_.twin)))
    inner = st_.twin >= 0
    q = st_.s + np.where(inner, st_.s[g], 0.0)
    bound = st_.b + np.where(inner, st_.b[g], 0.0)
    return shares.deficit(q, bound).sum()


def test_a_fan_over_close_side_vertices_merges_while_its_quality_rises():
    """Twenty side vertices 0.05 apart under an apex 0.5 above, Q = I: each merge widens an
    angle at the apex, and merges go on round after round (none beside another in one round)
    while they raise the quality: down to the one triangle (0, 0), (1, 0), (½, ½), right-angled
    at the apex. What is left is certified and uses every vertex it keeps."""
    P, T, fixed = fan(np.linspace(0, 1, 21), (0.5, 0.5))
    st_, tan = state_of(P, T, fixed, qmesh.TensorField.principal(1.0, 1.0, "0"))
    assert worst(st_) < 0.1
    merged, rounds = 0, [1]
    while rounds[-1]:
        rounds.append(merges.side_merges(st_, np.arange(len(P)), tan))
        tan = moves.tangents(st_.P, st_.T, st_.twin, st_.fixed)
        merged += rounds[-1]
    assert merged == 19 and max(rounds[1:]) == 1
    assert np.array_equal(np.sort(st_.T[0]), [0, 20, 21])
    st_.fail()
    assert not len(st_.h)
    merges.compact(st_)
    assert len(st_.P) == len(P) - merged
    assert np.array_equal(np.unique(st_.T), np.arange(len(st_.P)))


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), k=st.integers(3, 30), ratio=st.floats(1.0, 1e3),
       angle=st.floats(0.0, 180.0), apex=st.tuples(st.floats(-0.5, 1.5), st.floats(0.05, 2.0)))
def test_merges_keep_the_state_and_raise_the_worst_quality(seed, k, ratio, angle, apex):
    """Whatever merges: the twins, the means and the shares are those of the mesh as it is; the
    area is kept; no edge's deficit total rises; the worst quality does not fall; and the
    merged vertices are dropped by `compact` with the triangles pointing at the same points."""
    rng = np.random.default_rng(seed)
    xs = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0.02, 0.98, k)]))
    xs = xs[np.r_[True, np.diff(xs) > 1e-3]]
    P, T, fixed = fan(xs, apex)
    field = qmesh.TensorField.principal(1.0, 1.0 / ratio, f"{angle}")
    st_, tan = state_of(P, T, fixed, field)
    area, before, low = signed_areas(P, T).sum(), total_deficit(st_), worst(st_)
    merged = merges.side_merges(st_, np.arange(len(P)), tan)
    assert np.array_equal(st_.twin, topology.twins(st_.T))
    fresh = RepairState.of(st_.P, st_.T, field)
    assert np.allclose(st_.Qbar, fresh.Qbar) and np.allclose(st_.s, fresh.s)
    assert np.isclose(signed_areas(st_.P, st_.T).sum(), area)
    assert np.all(signed_areas(st_.P, st_.T) > 0)
    assert total_deficit(st_) <= before * (1 + 1e-9) + 1e-15
    assert worst(st_) >= low
    X = st_.P[st_.T]
    merges.compact(st_)
    assert len(st_.P) == len(P) - merged
    assert np.array_equal(st_.P[st_.T], X)
