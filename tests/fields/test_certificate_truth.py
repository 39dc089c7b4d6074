"""No certificate a jump or a narrow feature can fool: text fields with jumps along lines at
random positions and angles, narrow ramps, bumps and ridges, meshed and checked against element
means computed without qmesh's quadrature (`exact_means`: exact clipping along the jump lines,
bumps and ridges by integrals of their own); the references checked against a fine subdivision
first. benchmarks/cert_truth.py runs the same check over many more fields and sizes."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import qmesh
from tests.fields import exact_means as em
from tests.fields import hostile_fields as hf
from tests.fields import reference as ref
from tests.fields import truth


def _triangle(rng, centre, size):
    while True:
        P = centre + size * rng.uniform(-1, 1, (3, 2))
        if abs(em.signed_area(P[None, 0], P[None, 1], P[None, 2])[0]) > 0.1 * size ** 2:
            return P


def _scalar(g):
    """A scalar g(x, y) as the (k, 2, 2) tensor g·I a fine_mean takes."""
    return lambda x, y: g(x, y)[:, None, None] * np.eye(2)


@pytest.mark.parametrize("seed", range(4))
def test_the_bump_and_ridge_references_agree_with_a_fine_subdivision(seed):
    """The bump's polar integral and the ridge's closed form against 4^6 pieces of an 8 × 8
    Gauss rule, on a triangle about 4 widths across centred within a width of the feature."""
    rng = np.random.default_rng(seed)
    w = 10 ** rng.uniform(np.log10(0.003), np.log10(0.03))
    c = rng.uniform(0.3, 0.7, 2)
    P = _triangle(rng, c + rng.uniform(-1, 1, 2) * w, 4 * w)
    T = np.array([[0, 1, 2]])
    g, err = em.bump_means(P, T, c, w)
    fine = ref.fine_mean(_scalar(lambda x, y: np.exp(-((x - c[0]) ** 2 + (y - c[1]) ** 2) / w ** 2)),
                         P, levels=6, n=8)[0, 0]
    assert g[0] > 1e-2 and abs(g[0] - fine) <= 1e-12 and err[0] <= 1e-12
    n = np.array([np.cos(seed), np.sin(seed)])
    r = em.ridge_means(P, T, n, c @ n, w)
    fine = ref.fine_mean(_scalar(lambda x, y: np.exp(-(n[0] * x + n[1] * y - c @ n) ** 2 / w ** 2)),
                         P, levels=6, n=8)[0, 0]
    assert r[0] > 1e-2 and abs(r[0] - fine) <= 1e-12


def test_the_clipped_means_of_a_step_are_its_areas():
    """A step across x + 2y = 1 over the triangle (0, 0), (1, 0), (0, 1): the part beyond the
    line is the triangle (1, 0), (0, 1), (0, 0.5) of area 1/4, half the triangle."""
    P = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])

    def step(x, y):
        return _scalar(lambda x, y: np.where(x + 2 * y > 1, 10.0, 1.0))(x, y)
    Q, err = em.clipped_means(step, P, np.array([[0, 1, 2]]), [(1.0, 2.0, 1.0)])
    assert Q[0] == pytest.approx(5.5 * np.eye(2), rel=1e-14) and err[0] < 1e-13


@pytest.mark.parametrize("kind", hf.KINDS)
def test_the_text_and_the_numpy_form_of_each_kind_agree(kind):
    """What the mesher evaluates and what the references integrate are one field: at random
    points, and at points by each bump's centre and on each ridge."""
    rng = np.random.default_rng(3)
    case = hf.draw(kind, rng)
    X = rng.uniform(0, 1, (400, 2))
    for c, w, _ in case.bumps:
        X = np.vstack([X, c + w * rng.uniform(-2, 2, (50, 2))])
    for n, u0, w, _ in case.ridges:
        X = np.vstack([X, u0 * n / (n @ n) + np.outer(rng.uniform(-0.3, 0.3, 50), [-n[1], n[0]])])
    F, Q = case.field()(X), case.Q(X[:, 0], X[:, 1])
    assert np.allclose(F, Q, rtol=1e-12, atol=1e-12 * np.abs(Q).max())


def test_the_jump_a_sampled_rule_certified_falsely_passes_with_the_exact_means():
    """0° | 90° at 100 : 1 across x + 0.3y = 0.537: with means blind to the jump an interior
    edge had exact q_ij / Σ|q_ij^T| = −0.886 at 1 500 vertices."""
    _, v = truth.mesh_and_check(hf.fooled_jump(), 300)
    assert v.remaining == 0 and v.false_interior == v.false_boundary == 0 and v.outside == 0


@settings(max_examples=6, deadline=None)
@given(kind=st.sampled_from(hf.KINDS), seed=st.integers(0, 2**32 - 1),
       n=st.sampled_from([120, 200]))
def test_no_certificate_is_false_against_the_exact_means(kind, seed, n):
    """A field drawn of any kind, meshed: every edge the certificate passes has q_ij ≥ 0 with
    the exact means, and every stored mean is within its stated bound of the exact one. (A
    field that turns faster than n vertices can follow is refused: no certificate.)"""
    try:
        _, v = truth.mesh_and_check(hf.draw(kind, np.random.default_rng(seed)), n)
    except qmesh.QmeshError as e:
        assert "can follow" in str(e)
        assume(False)
    assert v.false_interior == 0 and v.false_boundary == 0, v
    assert v.outside == 0, v


def test_a_callable_with_a_jump_is_labelled_sampled_in_the_mesh_and_its_report():
    """A callable's means rest on samples: the mesh says at what spacing, and so does its
    report; the exact means are what shows they may miss."""
    line = (1.0, 0.3, 0.537)

    def Q(x, y):
        x, y = np.asarray(x, float), np.asarray(y, float)
        return ref.principal(1000.0, 1.0, np.where(x + 0.3 * y - 0.537 > 0, 0.0, 90.0))
    case = hf.Case("callable", "callable", lambda: qmesh.TensorField(Q), Q, [line])
    m, v = truth.mesh_and_check(case, 200)
    assert v.sampled_at is not None and v.sampled_at > 0
    assert qmesh.measure.report(m, laplacian=False)["means_sampled_at"] == v.sampled_at


def _grid(k):
    """The unit square in k × k squares, each cut along a diagonal: a mesh made without qmesh."""
    t = np.linspace(0, 1, k + 1)
    P = np.column_stack([np.tile(t, k + 1), np.repeat(t, k + 1)])
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    a = (j * (k + 1) + i).ravel()
    T = np.vstack([np.column_stack([a, a + 1, a + k + 2]), np.column_stack([a, a + k + 2, a + k + 1])])
    return P, T


def test_the_check_finds_the_means_a_sample_missed_and_passes_the_proven_ones():
    """On one grid, the jump of `hf.fooled_jump` as a callable (its means sampled: the rule
    against its 4 children, which agree where no sample crosses the line) and as its text (the
    means proven): the exact means fall outside the callable's stated bounds on some triangle,
    and within the text's on every one."""
    case = hf.fooled_jump()
    P, T = _grid(24)

    def sampled(x, y):
        return case.base(np.ravel(x), np.ravel(y)).reshape(np.shape(x) + (2, 2))
    for field, outside in ((qmesh.TensorField(sampled), True), (case.field(), False)):
        Q, err = field.means_with_error(P, T)
        v = truth.judge(P, T, Q, err, case, remaining=0)
        assert (v.outside > 0) == outside, v
