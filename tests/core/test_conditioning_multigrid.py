"""κ2 with λ_min by multigrid-preconditioned LOBPCG (`qmesh.multigrid_eigen`): the same κ2 as
eigvalsh, the same digits on every run, no warning, and the factorisation wherever multigrid
does not converge."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh import measure, multigrid_eigen
from qmesh.domain import media_cases
from tests.core.test_measure_conditioning import CHAPTER, disk_mesh


def dense(mesh, conductivity):
    return np.linalg.eigvalsh(measure.stiffness_interior(mesh, conductivity).toarray())


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(150, 700))
def test_lambda_min_of_a_delaunay_laplacian_by_multigrid_is_eigvalsh_s(seed, n):
    """Q = I on a Delaunay mesh (an M-matrix, what smoothed aggregation is made for): multigrid
    converges, never below λ_min (a Rayleigh quotient), within tol of it (residual² / gap)."""
    mesh = disk_mesh(n, seed)
    K = measure.stiffness_interior(mesh, None)
    w = dense(mesh, None)
    v0 = np.random.default_rng(0).random(K.shape[0])
    lam = multigrid_eigen.smallest_eigenvalue(K, v0, 1e-6)
    assert lam is not None
    assert w[0] * (1 - 1e-12) <= lam <= w[0] * (1 + 1e-6)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), log_ratio=st.floats(0, 3), angle=st.floats(0, 180))
def test_kappa2_by_multigrid_is_eigvalsh_s_or_the_factorisations(seed, log_ratio, angle):
    """Any constant Q on a random mesh: multigrid's κ2, or where it gave up the factorisation's,
    agrees with eigvalsh."""
    mesh = disk_mesh(400, seed)
    Q = qmesh.Anisotropy.principal(10.0 ** log_ratio, 1.0, angle)
    w = dense(mesh, Q)
    c = measure.conditioning(mesh, Q, method="multigrid")
    assert c.kappa2 == pytest.approx(w[-1] / w[0], rel=1e-5)


def test_a_medium_s_kappa2_by_multigrid_is_the_factorisation_s(monkeypatch):
    domain, conductivity, _ = media_cases.inclusion()
    mesh = qmesh.mesh(domain, conductivity, target_vertices=1500)
    sparse = measure.conditioning(mesh, conductivity, method="sparse")
    spy = []
    real = multigrid_eigen.smallest_eigenvalue
    monkeypatch.setattr(multigrid_eigen, "smallest_eigenvalue",
                        lambda *a: spy.append(real(*a)) or spy[-1])
    by_multigrid = measure.conditioning(mesh, conductivity, method="multigrid")
    assert spy and spy[0] is not None                  # multigrid did converge here
    assert by_multigrid.kappa2 == pytest.approx(sparse.kappa2, rel=1e-6)


def test_the_same_digits_on_every_run_and_no_warning():
    mesh = disk_mesh(900, 11)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        runs = {measure.conditioning(mesh, CHAPTER, method="multigrid").kappa2 for _ in range(3)}
    assert len(runs) == 1


def test_auto_takes_multigrid_from_its_limit_on(monkeypatch):
    mesh = disk_mesh(600, 12)
    calls = []
    real = multigrid_eigen.smallest_eigenvalue
    monkeypatch.setattr(multigrid_eigen, "smallest_eigenvalue", lambda *a: calls.append(1) or real(*a))
    measure.conditioning(mesh, None)
    assert not calls                                   # below the limit: the factorisation
    monkeypatch.setattr(multigrid_eigen, "MULTIGRID_LIMIT", 100)
    measure.conditioning(mesh, None)
    assert calls


def test_where_multigrid_gives_up_the_factorisation_answers(monkeypatch):
    mesh = disk_mesh(500, 13)
    exact = measure.condition_number(mesh, CHAPTER, method="sparse")
    monkeypatch.setattr(multigrid_eigen, "smallest_eigenvalue", lambda *a: None)
    assert measure.condition_number(mesh, CHAPTER, method="multigrid") == exact


def test_a_numerically_singular_matrix_gets_no_figure_by_multigrid():
    mesh = disk_mesh(300, 4)
    v = measure.free_vertices(mesh)[0]
    Q = np.broadcast_to(np.eye(2), (mesh.n_triangles, 2, 2)).copy()
    Q[(mesh.triangles == v).any(axis=1)] *= 1e-20
    c = measure.conditioning(mesh, Q, method="multigrid")
    assert c.kappa2 is None and "numerically singular" in c.reason


def test_lobpcg_on_a_known_spectrum():
    """A diagonal operator (any symmetric one is, in its eigenvector basis) with a good
    preconditioner: the smallest eigenvalue to about rtol²."""
    w = np.r_[0.5, np.linspace(1.0, 1e4, 5000)]
    v0 = np.random.default_rng(0).random(len(w))
    lam = multigrid_eigen._lobpcg(lambda x: w * x, lambda r: r / w, v0, 1e-6)
    assert lam == pytest.approx(0.5, rel=1e-10)


def test_lobpcg_gives_up_early_where_its_rate_is_too_slow():
    """No preconditioner and a spectrum spread over four decades: the residual falls far too
    slowly; LOBPCG says so after a dozen steps rather than running all MAX_STEPS."""
    w = np.r_[1.0, 1.001, np.geomspace(1.002, 1e4, 20000)]
    v0 = np.random.default_rng(1).random(len(w))
    applied = []
    lam = multigrid_eigen._lobpcg(lambda x: applied.append(1) or w * x, lambda r: r, v0, 1e-6)
    assert lam is None
    assert len(applied) < multigrid_eigen.MAX_STEPS


def test_auto_factorises_a_matrix_far_from_an_m_matrix_without_trying_multigrid(monkeypatch):
    """Q = I on a mesh stretched for diag(0.1, 10): many positive off-diagonals, which multigrid
    is not made for; "auto" goes straight to the factorisation (same κ2), and takes multigrid
    for the Q the mesh was made for (an M-matrix)."""
    mesh = qmesh.mesh(qmesh.Disk(48), CHAPTER, target_vertices=600)
    calls = []
    real = multigrid_eigen.smallest_eigenvalue
    monkeypatch.setattr(multigrid_eigen, "smallest_eigenvalue",
                        lambda *a: calls.append(1) or real(*a))
    monkeypatch.setattr(multigrid_eigen, "MULTIGRID_LIMIT", 100)
    K = measure.stiffness_interior(mesh, None)
    assert not multigrid_eigen.suits(K)
    c = measure.conditioning(mesh, None)
    assert not calls
    assert c.kappa2 == pytest.approx(measure.conditioning(mesh, None, method="sparse").kappa2)
    assert multigrid_eigen.suits(measure.stiffness_interior(mesh, CHAPTER))
    measure.conditioning(mesh, CHAPTER)
    assert calls


def test_the_positive_share_is_counted_off_the_diagonal():
    """A 2 × 2 [[2, −1], [−1, 2]] is an M-matrix; [[2, 1], [1, 2]] has every off-diagonal
    positive; with POSITIVE_SHARE the border between them."""
    import scipy.sparse as sp
    assert multigrid_eigen.suits(sp.csr_matrix([[2.0, -1.0], [-1.0, 2.0]]))
    assert not multigrid_eigen.suits(sp.csr_matrix([[2.0, 1.0], [1.0, 2.0]]))
    assert multigrid_eigen.suits(sp.csr_matrix(np.eye(3)))
