"""The solver payoff: P1 FEM of −div(Q∇u) = f on a mesh, and what κ2 costs in CG iterations.

Why a better κ2 matters: conjugate gradients need O(√κ2) iterations. On every mesh we
solve −div(Q∇u) = f with Dirichlet data from a manufactured solution, report the discretisation
error against the exact u (nodal max and L2 by quadrature) and the CG iteration count and time
to a fixed relative residual, plain and with two symmetric preconditioners: Jacobi (diagonal) and
symmetric Gauss–Seidel (SSOR with ω = 1). scipy's spilu is not offered: its incomplete factors
are not symmetric, and CG with them stalled here (3000 iterations without converging at drop
tolerances 1e-3 and 1e-2; at 1e-4 it is nearly a direct solve, 3 iterations, which says nothing
about κ2).

The manufactured solution is u(x) = g(S x), g(ξ) = sin(ω ξ₁) cos(ω ξ₂) + ξ₁ξ₂/2, with
- kind "metric" (default): S = H^{1/2}, H = ∇²s, i.e. u varies on the unit scale of the
  chapter's metric; since S Q S = det(H) I (Q = adj H), f = −det(H) Δg. This is how solutions
  of an anisotropic problem behave: smooth along the conductive direction, steep across it.
- kind "isotropic": S = I, f = −tr(Q ∇²g): a solution that ignores the anisotropy.
f is derived analytically (no symbolic evaluation): −div(Q∇u) = −tr(S Q Sᵀ ∇²g(Sx)).
The stiffness matrix is `qmesh.measure.stiffness`; the load vector uses the degree-4 rule of
`qmesh.quadrature`. Constant Q only (a varying Q would need ∇Q in f).
`dirichlet` is the plain P1 solve for any conductivity, boundary values and load vector (what
MODFLOW 6's heads on a `qmesh.io.to_modflow6` grid are compared with).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from qmesh import measure
from qmesh.geometry import quadrature
from qmesh.errors import QmeshError
from qmesh.geometry.triangles import signed_areas
from qmesh.triangle_mesh import Mesh

RTOL = 1e-8
"""CG stops when ‖b − Ax‖ ≤ RTOL ‖b‖."""

PRECONDITIONERS = ("none", "jacobi", "ssor")


def _sqrtm_spd(H: np.ndarray) -> np.ndarray:
    w, V = np.linalg.eigh(H)
    return (V * np.sqrt(w)) @ V.T


@dataclass(frozen=True)
class Manufactured:
    """u(x) = g(S x), g(ξ) = sin(ω ξ₁) cos(ω ξ₂) + ξ₁ξ₂/2, for a constant conductivity Q."""

    Q: np.ndarray
    S: np.ndarray
    omega: float = 1.0

    @classmethod
    def for_anisotropy(cls, anisotropy, kind: str = "metric", omega: float = 1.0) -> "Manufactured":
        if not anisotropy.is_constant:
            raise QmeshError("the manufactured solution needs a constant Q (f would need ∇Q)")
        if kind not in ("metric", "isotropic"):
            raise QmeshError(f"kind must be 'metric' or 'isotropic', got {kind!r}")
        H = np.asarray(anisotropy.H, dtype=float)
        Q = np.asarray(anisotropy.Q(np.zeros((1, 2)))[0], dtype=float)
        S = _sqrtm_spd(H) if kind == "metric" else np.eye(2)
        return cls(Q, S, float(omega))

    def _xi(self, P: np.ndarray) -> np.ndarray:
        return np.asarray(P, dtype=float) @ self.S.T

    def u(self, P: np.ndarray) -> np.ndarray:
        """The exact solution at points P (n, 2)."""
        a, b = (self.omega * self._xi(P)).T
        x1, x2 = self._xi(P).T
        return np.sin(a) * np.cos(b) + 0.5 * x1 * x2

    def f(self, P: np.ndarray) -> np.ndarray:
        """−div(Q∇u) = −tr(S Q Sᵀ ∇²g(Sx)), with ∇²g written out."""
        a, b = (self.omega * self._xi(P)).T
        w2 = self.omega ** 2
        g11 = g22 = -w2 * np.sin(a) * np.cos(b)
        g12 = -w2 * np.cos(a) * np.sin(b) + 0.5
        A = self.S @ self.Q @ self.S.T
        return -(A[0, 0] * g11 + 2.0 * A[0, 1] * g12 + A[1, 1] * g22)


def _quadrature_points(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Physical points of the degree-4 rule on every triangle, shape (M, q, 2)."""
    return np.einsum("qa,mad->mqd", quadrature.DUNAVANT4_POINTS, P[T])


def load_vector(mesh: Mesh, f) -> np.ndarray:
    """b_i = ∫ f φ_i, by the degree-4 Dunavant rule on every triangle (scattered by bincount)."""
    P, T = mesh.points, mesh.triangles
    bary, w = quadrature.DUNAVANT4_POINTS, quadrature.DUNAVANT4_WEIGHTS
    X = _quadrature_points(P, T)                                      # (M, q, 2)
    fq = np.asarray(f(X.reshape(-1, 2)), dtype=float).reshape(X.shape[:2])
    local = np.abs(signed_areas(P, T))[:, None] * ((fq * w) @ bary)   # (M, 3): ∫_T f φ_a
    return np.bincount(T.ravel(), weights=local.ravel(), minlength=mesh.n_vertices)


@dataclass(frozen=True)
class System:
    """The Dirichlet-reduced system K_II u_I = b_I − K_IB u_B and what rebuilds the full u_h."""

    A: sp.csr_matrix
    b: np.ndarray
    free: np.ndarray
    u_boundary: np.ndarray


def assemble(mesh: Mesh, anisotropy, solution: Manufactured) -> System:
    """Stiffness (qmesh.measure), load vector, and the exact u imposed on the boundary."""
    K = measure.stiffness(mesh, anisotropy)
    b = load_vector(mesh, solution.f)
    free = measure.free_vertices(mesh)
    u_b = solution.u(mesh.points)
    u_b[free] = 0.0
    rhs = b[free] - (K @ u_b)[free]
    return System(K[free][:, free].tocsr(), rhs, free, u_b)


def errors(mesh: Mesh, solution: Manufactured, u_h: np.ndarray) -> tuple[float, float]:
    """(max nodal |u_h − u|, ‖u_h − u‖_L2 by the degree-4 rule)."""
    P, T = mesh.points, mesh.triangles
    nodal = float(np.max(np.abs(u_h - solution.u(P))))
    bary, w = quadrature.DUNAVANT4_POINTS, quadrature.DUNAVANT4_WEIGHTS
    X = _quadrature_points(P, T)
    e = u_h[T] @ bary.T - solution.u(X.reshape(-1, 2)).reshape(X.shape[:2])
    l2 = float(np.sqrt(np.sum(np.abs(signed_areas(P, T)) * ((e * e) @ w))))
    return nodal, l2


def _preconditioner(A: sp.csr_matrix, kind: str):
    if kind == "none":
        return None
    if kind == "jacobi":
        return sp.diags(1.0 / A.diagonal())
    if kind == "ssor":      # M = (D + L) D⁻¹ (D + U), applied by two triangular solves
        lower, upper, d = sp.tril(A, format="csr"), sp.triu(A, format="csr"), A.diagonal()

        def apply(r):
            y = spla.spsolve_triangular(lower, r, lower=True)
            return spla.spsolve_triangular(upper, d * y, lower=False)

        return spla.LinearOperator(A.shape, matvec=apply, dtype=float)
    raise QmeshError(f"preconditioner must be one of {PRECONDITIONERS}, got {kind!r}")


def cg(A: sp.csr_matrix, b: np.ndarray, preconditioner: str = "none",
       rtol: float = RTOL) -> tuple[np.ndarray, int, float]:
    """scipy's CG from zero to ‖b − Ax‖ ≤ rtol‖b‖: (x, iterations, seconds incl. the setup)."""
    count = [0]

    def tick(_):
        count[0] += 1

    t0 = time.perf_counter()
    M = _preconditioner(A, preconditioner)
    x, info = spla.cg(A, b, rtol=rtol, atol=0.0, maxiter=20 * len(b) + 100, M=M, callback=tick)
    seconds = time.perf_counter() - t0
    if info != 0:
        raise QmeshError(f"CG ({preconditioner}) did not reach rtol {rtol} in {count[0]} iterations")
    return x, count[0], seconds


def solve_report(mesh: Mesh, anisotropy, kind: str = "metric",
                 preconditioners=PRECONDITIONERS) -> dict:
    """Discretisation errors and CG iterations/time per preconditioner, as plain numbers.

    The reference solution is a sparse direct solve; each CG run's result is checked against it.
    """
    solution = Manufactured.for_anisotropy(anisotropy, kind)
    system = assemble(mesh, anisotropy, solution)
    u_h = system.u_boundary.copy()
    u_h[system.free] = spla.spsolve(system.A.tocsc(), system.b)
    nodal, l2 = errors(mesh, solution, u_h)
    out = {"solution": kind, "n_unknowns": int(len(system.free)),
           "u_max_error": nodal, "u_l2_error": l2}
    scale = max(np.abs(u_h).max(), 1.0)
    for kind_m in preconditioners:
        x, its, seconds = cg(system.A, system.b, kind_m)
        deviation = float(np.abs(x - u_h[system.free]).max() / scale) if len(x) else 0.0
        out[f"cg_{kind_m}_iterations"] = its
        out[f"cg_{kind_m}_seconds"] = seconds
        out[f"cg_{kind_m}_deviation"] = deviation
    return out


def dirichlet(mesh: Mesh, conductivity, fixed, values, load=None) -> np.ndarray:
    """The P1 solution u_h of −div(Q∇u) = f: u_h = `values` on the vertices `fixed` (indices
    or a mask), K u_h = b on the others (natural, no-flux, on the boundary edges left free).

    K is `qmesh.measure.stiffness(mesh, conductivity)` (None: the mesh's element means, or
    Q = I), b the `load` vector (N,) (`load_vector(mesh, f)` for ∫ f φ_i; None: f = 0); a
    sparse direct solve. `values` is one number for all or one per fixed vertex."""
    K = measure.stiffness(mesh, conductivity)
    n = mesh.n_vertices
    mask = np.zeros(n, bool)
    mask[np.asarray(fixed)] = True
    if not mask.any():
        raise QmeshError("fixed must hold at least one vertex (else u_h is defined up to a constant)")
    u = np.zeros(n)
    u[np.asarray(fixed)] = values
    b = np.zeros(n) if load is None else np.asarray(load, dtype=float)
    free = ~mask
    rhs = b[free] - K[free][:, mask] @ u[mask]
    if free.any():
        u[free] = spla.spsolve(K[free][:, free].tocsc(), rhs)
    return u
