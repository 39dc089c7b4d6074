"""The vertex moves' tries (qmesh/fields/moves.py `_judged`): a try refused on geometry alone —
it flattens or turns over a triangle of its star, or does not move — has no rough means asked
for its star, and the other tries are judged exactly as they are on their own."""

import numpy as np
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh.fields import moves
from qmesh.fields.cache import ElementMeans
from qmesh.fields.repair_state import RepairState
from qmesh.geometry import topology
from qmesh.geometry.triangles import proper
from tests.fields.test_certify import FORMULA, square_mesh


class Counted(ElementMeans):
    """The field's means, the triangles asked for rough means counted."""

    rough_asked = 0

    def rough(self, P, T):
        self.rough_asked += len(np.reshape(T, (-1, 3)))
        return super().rough(P, T)


def _state(P, T, means=Counted):
    fixed = np.zeros(len(P), bool)
    fixed[:4] = True
    return RepairState.of(P, T, means(qmesh.TensorField.from_expressions(*FORMULA)), fixed=fixed)


def _movers(seed, n):
    """A square's mesh (its corners fixed) and movers of it, two triangles apart."""
    P, T = square_mesh(seed, n)
    twin = topology.twins(T)
    fixed = np.zeros(len(P), bool)
    fixed[:4] = True
    free = moves.free(T, twin, fixed, np.arange(len(P)))
    return P, T, moves.movers(T, twin, free, np.random.default_rng(seed))


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(20, 150), reach=st.floats(0.005, 0.2))
def test_tries_refused_on_geometry_ask_for_no_means(seed, n, reach):
    P, T, v = _movers(seed, n)
    k = len(v)
    small = np.random.default_rng(seed + 1).normal(0.0, reach, (k, 2))   # some flatten their star
    D = np.stack([small, np.zeros((k, 2)), 10.0 * np.ones((k, 2))])   # no move; out of Ω
    st_ = _state(P, T)
    take, q1 = moves._judged(st_, v, D, True, how="rough")
    # the star triangles of the first try's movers that move and flatten nothing, found here
    mask = np.zeros(len(P), bool)
    mask[v] = True
    star = np.flatnonzero(topology.touching(T, mask))
    corner = np.argmax(mask[T[star]], axis=1)
    mover = np.searchsorted(v, T[star][np.arange(len(star)), corner])
    X = P[T[star]].copy()
    X[np.arange(len(star)), corner] += small[mover]
    bad = np.zeros(k, bool)
    bad[mover[~proper(X.reshape(-1, 2), np.arange(3 * len(star)).reshape(-1, 3))]] = True
    bad |= np.hypot(*small.T) == 0
    assert st_.field.rough_asked == np.count_nonzero(~bad[mover])
    assert not take[1:].any() and not take[0][bad].any()
    alone = _state(P, T)
    take1, q11 = moves._judged(alone, v, D[:1], True, how="rough")
    assert np.array_equal(take1[0], take[0])
    assert np.array_equal(q11[0][~bad], q1[0][~bad])


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(5, 80),
       c=st.lists(st.floats(-0.5, 0.5), min_size=6, max_size=6))
def test_rough_means_are_the_rule_alone(seed, n, c):
    """Candidates are ranked on the degree-5 rule alone: Q at 7 points a triangle, no more; exact
    for a quadratic Q, whose mean over a triangle is the average of Q at its edges' midpoints."""
    P, T = square_mesh(seed, n)
    a, b, d, e, f, g = c
    q11 = f"3 + {a}*x + {b}*y*y"
    q12 = f"{d}*x*y/4"
    q22 = f"4 + {e}*x*x + {f}*y + {g}*x*y"
    field = qmesh.TensorField.from_expressions(q11, q12, q22)
    cache = ElementMeans(field)
    before = field.evaluations.asked
    Q, err = cache.rough(P, T)
    assert field.evaluations.asked - before == 7 * len(T)
    assert not err.any()
    mid = 0.5 * (P[T] + P[T[:, [1, 2, 0]]])                          # (M, 3, 2)
    exact = field(mid.reshape(-1, 2)).reshape(len(T), 3, 2, 2).mean(axis=1)
    assert np.allclose(Q, exact, rtol=1e-12, atol=1e-12)


class Both(Counted):
    """`Counted`, the triangles asked for adaptive means counted too."""

    full_asked = 0

    def means_with_error(self, P, T):
        self.full_asked += len(np.reshape(T, (-1, 3)))
        return super().means_with_error(P, T)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(30, 150), shape=st.booleans())
def test_relax_asks_adaptive_means_only_for_moves_that_pass_on_rough_ones(seed, n, shape):
    """A relax move is judged on rough means first; only the moves that pass them are judged
    on adaptive means, and a move taken passes on both."""
    P, T, v = _movers(seed, n)
    st_ = _state(P, T, Both)
    field = st_.field
    field.full_asked = field.rough_asked = 0
    moves.relax(st_, None, v, shape=shape)
    assert field.rough_asked > 0
    assert field.full_asked <= field.rough_asked
    moved = np.flatnonzero(np.any(st_.P != P, axis=1))
    if len(moved):
        d = st_.P[moved] - P[moved]
        for how in ("rough", "means_with_error"):
            assert moves._judged(_state(P, T), moved, d[None], shape, how=how)[0][0].all()
