"""A text's proof refines the pieces its tolerance needs (`means._spared`): where a triangle's
bound is a few times its tolerance, the pieces of the largest bounds are split and the others
kept, with the bound within the tolerance and the means within it of a reference; a triangle
whose pieces do not fall as counted on (a point where the text has no limit) ends within the
tolerance all the same."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.conductivity import means as _m
from tests.fields import reference as ref
from tests.fields.test_third_order_bound import SPIRAL, _triangle

FVCA5 = ("(1e-3*x**2 + y**2)/(x**2 + y**2)", "(1e-3 - 1)*x*y/(x**2 + y**2)",
         "(x**2 + 1e-3*y**2)/(x**2 + y**2)")


def _proven(F, P, rtol, spare):
    """Means, bounds and the pieces enclosed of the triangles P (k, 3, 2) proven to `rtol`."""
    bound = F._enclosure()
    pieces = []

    def counted(A, B, C):
        pieces.append(len(A))
        return bound(A, B, C)

    Q, err = _m.adaptive_means(F._evaluate, P[:, 0], P[:, 1], P[:, 2], rtol=1e-6,
                               bound=counted, bound_rtol=rtol, spare=spare)
    return Q, err, sum(pieces)


def _spiral_triangles(rng, k, fewer):
    """k spiral triangles a fiftieth of the square, away from its centre, and tolerances below
    what their children's enclosures prove by a factor drawn from `fewer` (past 16: a second
    level of pieces)."""
    F = qmesh.TensorField.principal(*SPIRAL)
    P = np.stack([_triangle(rng, 0.5 + rng.uniform(0.25, 0.45) * np.array([np.cos(a), np.sin(a)]),
                            0.02) for a in rng.uniform(0, 2 * np.pi, k)])
    T = np.arange(k * 3).reshape(-1, 3)
    children = F.enclosure_errors(P.reshape(-1, 2), T)
    size = np.linalg.norm(F.means(P.reshape(-1, 2), T).reshape(-1, 4), axis=1)
    return F, P, children / size / rng.uniform(*fewer, k)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_a_triangle_splits_only_the_pieces_its_tolerance_needs(seed):
    """No more pieces enclosed than splitting every piece above the tolerance, each bound within
    its tolerance, and each mean within its bound of a reference of 4096 pieces."""
    F, P, rtol = _spiral_triangles(np.random.default_rng(seed), 4, (16, 200))
    Q, err, spared = _proven(F, P, rtol, spare=True)
    _, _, every = _proven(F, P, rtol, spare=False)
    assert spared <= every
    assert np.all(err <= rtol * _m.frobenius(Q) * (1 + 1e-12))
    for k in range(len(P)):
        want = ref.fine_mean(lambda x, y: F(np.column_stack([x, y])), P[k], levels=6, n=8)
        got = _m.full_tensors(Q[k])
        assert np.linalg.norm(got - want) <= err[k] + 1e-12 * np.linalg.norm(want)


def test_spiral_triangles_enclose_fewer_pieces_than_every_one_above_the_tolerance():
    """40 such triangles 16 to 40 times above their tolerance (after their children's pieces,
    within a few times it): a fifth fewer pieces enclosed at least than splitting every piece
    above the tolerance."""
    F, P, rtol = _spiral_triangles(np.random.default_rng(11), 40, (16, 40))
    _, _, spared = _proven(F, P, rtol, spare=True)
    _, _, every = _proven(F, P, rtol, spare=False)
    assert spared <= every * 0.8, (spared, every)


def test_triangles_at_a_point_with_no_limit_end_within_their_tolerance():
    """FVCA5 test 5's field around its rotation centre (0, 0), where Q has no limit: triangles
    at it and beside it, asked for 1e-3 and 1e-5 of their means, end within it where every
    piece above it split does (those beside it: all), computed again where sparing left them
    above it."""
    F = qmesh.TensorField.from_expressions(*FVCA5)
    P = np.array([[[0.0, 0.0], [0.05, 0.0], [0.0, 0.05]], [[0.05, 0.0], [0.05, 0.05], [0.0, 0.05]],
                  [[0.01, 0.01], [0.06, 0.0], [0.03, 0.04]]])
    for rtol in (1e-3, 1e-5):
        Q, err, _ = _proven(F, P, rtol, spare=True)
        Q0, err0, _ = _proven(F, P, rtol, spare=False)
        within = err <= rtol * _m.frobenius(Q) * (1 + 1e-12)
        assert np.array_equal(within, err0 <= rtol * _m.frobenius(Q0) * (1 + 1e-12))
        assert np.all(within[1:])
