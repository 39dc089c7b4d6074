"""κ2's sparse path: the Dirichlet matrix is exactly symmetric, K⁻¹ comes from qdldl's LDLᵀ or,
without qdldl, from SuperLU with the same κ2, a pivot ≤ 0 gives a reason instead of a figure,
and the Lanczos recurrence survives an operator that hands back its own buffers."""

from __future__ import annotations

import sys

import numpy as np
import pytest
import scipy.sparse as sp

import qmesh
from qmesh import measure
from tests.core.test_measure_conditioning import disk_mesh as conditioning_disk

CHAPTER = qmesh.Anisotropy.constant([[0.1, 0.0], [0.0, 10.0]])


def disk_mesh(n: int, seed: int) -> qmesh.Mesh:
    return conditioning_disk(n, seed, outline=48, inner=0.97)


@pytest.mark.parametrize("anisotropy", [CHAPTER, None])
def test_dirichlet_and_neumann_matrices_are_exactly_symmetric(anisotropy):
    mesh = disk_mesh(500, 1)
    for K in (measure.stiffness_interior(mesh, anisotropy), measure.stiffness(mesh, anisotropy)):
        assert K.has_canonical_format
        assert (K != K.T).nnz == 0


@pytest.mark.parametrize("anisotropy", [CHAPTER, None])
def test_kappa2_is_the_same_without_qdldl(anisotropy, monkeypatch):
    pytest.importorskip("qdldl")
    mesh = disk_mesh(3000, 2)
    with_ldl = measure.conditioning(mesh, anisotropy, method="sparse")
    monkeypatch.setitem(sys.modules, "qdldl", None)            # `import qdldl` raises ImportError
    with_lu = measure.conditioning(mesh, anisotropy, method="sparse")
    assert with_ldl.kappa2 is not None and with_ldl.kappa2 > 1.0
    assert with_lu.kappa2 == pytest.approx(with_ldl.kappa2, rel=1e-10)
    assert with_lu.lambda_min == pytest.approx(with_ldl.lambda_min, rel=1e-10)


def test_inverse_solves_with_either_factorisation(monkeypatch):
    mesh = disk_mesh(800, 3)
    K = measure.stiffness_interior(mesh, CHAPTER)
    b = np.random.default_rng(0).random(K.shape[0])
    x = measure._inverse(K)(b)
    assert np.linalg.norm(K @ x - b) <= 1e-10 * np.linalg.norm(b)
    monkeypatch.setitem(sys.modules, "qdldl", None)
    y = measure._inverse(K)(b)
    assert np.linalg.norm(K @ y - b) <= 1e-10 * np.linalg.norm(b)


def test_an_indefinite_matrix_gets_a_reason_from_its_pivots():
    pytest.importorskip("qdldl")
    reason = measure._inverse(sp.csr_matrix(np.array([[1.0, 2.0], [2.0, 1.0]])))
    assert isinstance(reason, str) and "numerically singular" in reason


def test_a_singular_matrix_gets_a_reason_with_either_factorisation(monkeypatch):
    K = sp.csr_matrix(np.array([[1.0, 1.0], [1.0, 1.0]]))
    assert "singular" in measure._inverse(K)
    monkeypatch.setitem(sys.modules, "qdldl", None)
    assert "singular" in measure._inverse(K)


def test_lanczos_with_an_operator_that_returns_its_argument_or_one_buffer():
    v0 = np.random.default_rng(1).random(50)
    assert measure._largest_eigenvalue(lambda x: x, v0, 1e-10) == pytest.approx(1.0, rel=1e-12)
    w = np.linspace(1.0, 3.0, 50)
    out = np.empty(50)

    def scale(x):                                 # writes into, and returns, the same array
        np.multiply(w, x, out=out)
        return out

    assert measure._largest_eigenvalue(scale, v0, 1e-10) == pytest.approx(3.0, rel=1e-12)


def test_report_without_the_laplacian_computes_one_kappa2(monkeypatch):
    mesh = disk_mesh(600, 4)
    full = measure.report(mesh, CHAPTER)
    seen = []
    real = measure._conditioning
    monkeypatch.setattr(measure, "_conditioning", lambda m, a, *args: seen.append(a) or real(m, a, *args))
    short = measure.report(mesh, CHAPTER, laplacian=False)
    assert len(seen) == 1 and seen[0] is not None                 # the conductivity's κ2 only
    assert "kappa2_laplacian" not in short
    assert short == {k: v for k, v in full.items() if k != "kappa2_laplacian"}
    degenerate = qmesh.Mesh([[0, 0], [1, 0], [2, 0], [1, 1]], [[0, 1, 3], [0, 1, 2]])
    assert "kappa2_laplacian" not in measure.report(degenerate, CHAPTER, laplacian=False)


def test_checking_every_fourth_step_costs_at_most_three_more_products():
    w = np.r_[np.linspace(1.0, 50.0, 5000), 50.5]
    v0 = np.random.default_rng(2).random(len(w))
    counts, values = {}, {}
    for every in (1, 4):
        calls = []
        values[every] = measure._largest_eigenvalue(lambda x: calls.append(1) or w * x, v0, 1e-8, every)
        counts[every] = len(calls)
    assert values[4] == pytest.approx(50.5, rel=1e-12) and values[1] == pytest.approx(50.5, rel=1e-12)
    assert counts[1] > 8 and 0 <= counts[4] - counts[1] <= 3
