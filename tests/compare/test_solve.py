"""The manufactured-solution solver: the error decreases at the expected rate."""

from __future__ import annotations

import numpy as np
import pytest

import qmesh
from qmesh.compare import isotropic, solve


@pytest.mark.parametrize("kind", ["metric", "isotropic"])
@pytest.mark.parametrize("Q", [[[0.1, 0.0], [0.0, 10.0]], [[2.0, 0.7], [0.7, 0.5]]])
def test_f_is_minus_div_Q_grad_u(kind, Q):
    """f against a finite-difference −tr(Q ∇²u) at random points."""
    sol = solve.Manufactured.for_anisotropy(qmesh.Anisotropy.constant(Q), kind)
    P = np.random.default_rng(1).uniform(-0.7, 0.7, (20, 2))
    h = 1e-4
    ex, ey = np.array([h, 0.0]), np.array([0.0, h])
    u = sol.u
    uxx = (u(P + ex) - 2 * u(P) + u(P - ex)) / h**2
    uyy = (u(P + ey) - 2 * u(P) + u(P - ey)) / h**2
    uxy = (u(P + ex + ey) - u(P + ex - ey) - u(P - ex + ey) + u(P - ex - ey)) / (4 * h**2)
    Qa = np.asarray(Q)
    f_fd = -(Qa[0, 0] * uxx + 2 * Qa[0, 1] * uxy + Qa[1, 1] * uyy)
    np.testing.assert_allclose(sol.f(P), f_fd, rtol=1e-4, atol=1e-4 * np.abs(f_fd).max())


def test_load_vector_integrates_constants(delaunay_mesh):
    b = solve.load_vector(delaunay_mesh, lambda X: np.full(len(X), 3.0))
    assert b.sum() == pytest.approx(3.0 * qmesh.Disk(16).area, rel=1e-12)
    assert np.all(b > 0)


@pytest.mark.parametrize("kind", ["metric", "isotropic"])
def test_error_decreases_like_one_over_n(kind, chapter_anisotropy):
    """P1 on quasi-uniform meshes: ‖u_h − u‖_L2 ~ h² ~ N⁻¹ (fitted exponent near −1)."""
    N, err = [], []
    for vb in (32, 64, 128):
        mesh = isotropic.isotropic_mesh(vb)
        rep = solve.solve_report(mesh, chapter_anisotropy, kind, preconditioners=())
        N.append(mesh.n_vertices)
        err.append(rep["u_l2_error"])
    p = np.polyfit(np.log(N), np.log(err), 1)[0]
    assert -1.25 < p < -0.8
    assert err[0] > err[1] > err[2]


def test_cg_matches_the_direct_solve_and_preconditioning_helps(chapter_anisotropy):
    mesh = isotropic.isotropic_mesh(64)
    rep = solve.solve_report(mesh, chapter_anisotropy)
    for p in solve.PRECONDITIONERS:
        assert rep[f"cg_{p}_deviation"] < 1e-6
        assert rep[f"cg_{p}_iterations"] > 0
    assert rep["cg_ssor_iterations"] < rep["cg_none_iterations"]
    assert rep["cg_jacobi_iterations"] <= rep["cg_none_iterations"]


def test_better_conditioned_adapted_mesh_needs_fewer_cg_iterations(chapter_anisotropy):
    """The payoff: at VB 64 the adapted mesh has fewer vertices *and* far fewer CG iterations."""
    iso = isotropic.isotropic_mesh(64)
    ada = qmesh.mesh(qmesh.Disk(64), chapter_anisotropy, target_vertices=212, seed=0)
    r_iso = solve.solve_report(iso, chapter_anisotropy, preconditioners=("none",))
    r_ada = solve.solve_report(ada, chapter_anisotropy, preconditioners=("none",))
    assert r_ada["cg_none_iterations"] < 0.5 * r_iso["cg_none_iterations"]


def test_varying_q_is_refused():
    aniso = qmesh.Anisotropy.from_s(
        lambda P: np.exp(P[:, 0]) + P[:, 1] ** 2,
        lambda P: np.c_[np.exp(P[:, 0]), 2 * P[:, 1]],
        lambda P: np.stack([np.c_[np.exp(P[:, 0]), 0 * P[:, 0]], np.c_[0 * P[:, 0], 2 + 0 * P[:, 0]]], 1))
    with pytest.raises(qmesh.QmeshError, match="constant"):
        solve.Manufactured.for_anisotropy(aniso)
    with pytest.raises(qmesh.QmeshError):
        solve.Manufactured.for_anisotropy(qmesh.Anisotropy.constant(qmesh.CHAPTER_Q), "other")
