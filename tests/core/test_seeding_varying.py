"""Initial points for a varying s (qmesh.seeding_varying): inside Ω, evenly spaced in the metric, at its density."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

import qmesh
from qmesh.mesher import seeding_varying

SQUARE = qmesh.Polygon([[-1, -1], [1, -1], [1, 1], [-1, 1]])
EXPRESSIONS = ["exp(x) + y**2", "cosh(3*x) + 0.02*y**2", "log(exp(2*x) + exp(-2*x) + exp(2*y))"]
DOMAINS = {"disk": lambda: qmesh.Disk(64), "annulus": qmesh.domains.annulus, "L-shape": qmesh.domains.lshape}


def _nearest_metric_distances(P, A):
    """Each point's metric distance (in ½(H_i + H_j)) to its nearest of 6 Euclidean-near neighbours."""
    H = A.hessian(P)
    L = np.linalg.cholesky(H.mean(axis=0))
    _, jj = cKDTree(P @ L).query(P @ L, k=7)
    E = P[jj[:, 1:]] - P[:, None]
    Hm = 0.5 * (H[:, None] + H[jj[:, 1:]])
    return np.sqrt(np.einsum("nki,nkij,nkj->nk", E, Hm, E)).min(axis=1)


@pytest.mark.parametrize("text", EXPRESSIONS)
@pytest.mark.parametrize("name", list(DOMAINS))
def test_points_inside_about_n_and_evenly_spaced_in_the_metric(text, name):
    domain, A = DOMAINS[name](), qmesh.Anisotropy.from_expression(text)
    P = seeding_varying.initial_points(domain, A, 1000, np.random.default_rng(1))
    assert 900 <= len(P) <= 1000
    assert np.all(domain.contains(P, tol=0.0))
    d = _nearest_metric_distances(P, A)
    # lattice-like: no two points much closer than the typical spacing (random points give ~0.05)
    assert d.min() >= 0.8 * np.median(d)


def test_density_follows_sqrt_det_hessian():
    A = qmesh.Anisotropy.from_expression("exp(x) + y**2")      # √det ∇²s = √2 e^{x/2}
    P = seeding_varying.initial_points(SQUARE, A, 3000, np.random.default_rng(0))
    expected = (np.exp(0.5) - 1) / (np.exp(0.5) - np.exp(-0.5))  # share of ∫√det H over x > 0
    assert np.mean(P[:, 0] > 0) == pytest.approx(expected, abs=0.02)


def test_same_rng_seed_same_points():
    A = qmesh.Anisotropy.from_expression("cosh(3*x) + 0.02*y**2")
    P1 = seeding_varying.initial_points(qmesh.Disk(32), A, 400, np.random.default_rng(5))
    P2 = seeding_varying.initial_points(qmesh.Disk(32), A, 400, np.random.default_rng(5))
    np.testing.assert_array_equal(P1, P2)
    assert len(seeding_varying.initial_points(qmesh.Disk(32), A, 0, np.random.default_rng(5))) == 0


@settings(max_examples=40, deadline=None, derandomize=True)
@given(n=st.integers(1, 60), p=st.floats(0.0, 0.5), seed=st.integers(0, 1000), prioritised=st.booleans())
def test_luby_gives_a_maximal_independent_set(n, p, seed, prioritised):
    rng = np.random.default_rng(seed)
    i, j = np.triu_indices(n, 1)
    keep = rng.random(len(i)) < p
    i, j = i[keep], j[keep]
    priority = rng.random(n) if prioritised else None
    S = seeding_varying._luby(n, i, j, rng, priority)
    assert not np.any(S[i] & S[j])                                   # independent
    covered = S.copy()
    covered[i[S[j]]] = True
    covered[j[S[i]]] = True
    assert covered.all()                                             # maximal
    if prioritised and n:
        assert S[np.argmin(priority)]                                # the best priority always wins


def test_no_seed_points_have_no_conflicts_and_no_warning():
    """A face whose lattice puts no point inside (a thin layer of a medium holding a field)
    seeds nothing, without a division by zero on the way."""
    import warnings

    from qmesh.mesher.seeding_varying import _conflicts_oriented
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        i, j = _conflicts_oriented(np.empty((0, 2)), np.empty((0, 2, 2)), 1.0)
    assert len(i) == len(j) == 0
