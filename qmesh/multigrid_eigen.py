"""λ_min of a large stiffness matrix without factorising it: LOBPCG preconditioned by multigrid.

At 1e5 unknowns one sparse LDLᵀ factorisation of the Dirichlet matrix K (0.6–0.75 s on one
core) is most of κ2's time. A smoothed-aggregation hierarchy (pyamg; Vaněk, Mandel & Brezina
1996) costs about half of that, and LOBPCG (Knyazev 2001) with one V-cycle per step reaches the
smallest eigenpair in about 20 steps on the meshes qmesh makes: M-matrices of triangles nearly
equilateral in their metric, for which smoothed aggregation is made. Where pyamg is missing or
LOBPCG does not converge in MAX_STEPS, None tells the caller to factorise instead.

LOBPCG with one vector is a few lines (`_lobpcg`), written here rather than taken from SciPy:
κ2 runs it while other threads run (λ_max's Lanczos steps, `report`'s Laplacian κ2), and
SciPy's version warns (silencing it takes Python's warning filters, which are process-wide
and not thread-safe) and reduces its Gram matrices with threaded BLAS (the last digits then
vary from run to run). It stops when the
residual ‖Kx − θx‖ ≤ √tol · θ (‖x‖ = 1). The Ritz value θ is a Rayleigh quotient, never below
λ_min, and exceeds it by about residual² / gap (the gap to λ_2), so by about tol · θ where that
gap is comparable to λ_min (the Dirichlet Laplacian's λ_2 / λ_min is 2.5 on a disk).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from numpy.typing import NDArray

Vector = NDArray[np.float64]

MULTIGRID_LIMIT = 50_000
"""From this many unknowns on, "auto" takes multigrid: below it the factorisation is faster."""

MAX_STEPS = 40
"""LOBPCG steps after which multigrid gives up (None) and the caller factorises; it gives up as
soon as the residual's rate of decrease over the last RATE_STEPS steps says it would need more
(so a matrix multigrid is not made for, as Q = I on a mesh stretched for another Q, costs a
dozen steps before the factorisation, not forty)."""

RATE_STEPS = 6

POSITIVE_SHARE = 0.02
""""auto" takes multigrid only where at most this share of K's off-diagonals is positive: smoothed
aggregation is made for M-matrices. On the chapter's 1e5 disk, Q = I (7.9% positive) made
LOBPCG give up after about half a second before the factorisation; at 2.7% (Q turned 3° from
the mesh's own) it converged as at 0%."""


def suits(K: sp.csr_matrix) -> bool:
    """Whether K is near enough an M-matrix for multigrid (POSITIVE_SHARE); its diagonal,
    positive in any SPD matrix, is not counted."""
    n, off = K.shape[0], K.nnz - K.shape[0]
    return off <= 0 or int(np.count_nonzero(K.data > 0.0)) - n <= POSITIVE_SHARE * off


def smallest_eigenvalue(K: sp.csr_matrix, v0: Vector, tol: float) -> float | None:
    """λ_min of the symmetric positive definite K from the start vector v0, to a residual of
    √tol relative to it (so to about tol relative), or None where multigrid does not get there."""
    try:
        cycle = preconditioner(K)
    except ImportError:
        return None
    return _lobpcg(K.dot, cycle, v0, np.sqrt(tol))


def preconditioner(K: sp.csr_matrix) -> Callable[[Vector], Vector]:
    """One V-cycle of smoothed aggregation for K (ImportError without pyamg)."""
    import pyamg
    # "local" weighting: the prolongation smoother's ω from each row (a Gershgorin bound), not
    # from a spectral radius estimated from a random vector (then no two runs agree, and its
    # BLAS-threaded Krylov steps stall on a busy machine); one Gauss–Seidel sweep forward
    # before, one backward after: a symmetric V-cycle, as LOBPCG needs, at half the default's
    # sweeps (a few more steps, less time in all)
    hierarchy = pyamg.smoothed_aggregation_solver(
        K, symmetry="symmetric", improve_candidates=None,
        smooth=("jacobi", {"weighting": "local"}),
        presmoother=("gauss_seidel", {"sweep": "forward"}),
        postsmoother=("gauss_seidel", {"sweep": "backward"}))
    # the levels' operators as CSR (pyamg keeps the coarse ones as 1 × 1-block BSR, whose
    # Gauss–Seidel and products take twice as long), and the V-cycle run directly: pyamg's
    # `solve` would add two products by K and two norms per cycle (BLAS-threaded, so they stall on
    # a busy machine: a V-cycle at 3e4 took 34 instead of 8 ms) for a stopping test unused here
    levels = [tuple(_csr(getattr(lvl, name, None)) for name in ("A", "R", "P"))
              + (getattr(lvl, "presmoother", None), getattr(lvl, "postsmoother", None))
              for lvl in hierarchy.levels]
    coarsest = hierarchy.coarse_solver

    def v_cycle(b: Vector, level: int = 0) -> Vector:
        A, R, P, pre, post = levels[level]
        if level == len(levels) - 1:
            return np.asarray(coarsest(A, b), dtype=float).ravel()
        x = np.zeros_like(b)
        pre(A, x, b)
        x += P @ v_cycle(R @ (b - A @ x), level + 1)
        post(A, x, b)
        return x
    return v_cycle


def _csr(M: sp.spmatrix | None) -> sp.csr_matrix | None:
    return None if M is None else sp.csr_matrix(M)


def _dot(a: Vector, b: Vector) -> float:
    return float(np.einsum("i,i->", a, b))     # one thread, one summation order: same digits


def _lobpcg(apply: Callable[[Vector], Vector], precondition: Callable[[Vector], Vector],
            v0: Vector, rtol: float) -> float | None:
    """The smallest eigenvalue of the symmetric positive definite x ↦ apply(x) by LOBPCG with one
    vector: x_{k+1} minimises the Rayleigh quotient over span{x_k, T r_k, p_k} (Knyazev 2001,
    Algorithm 4.1; r_k = A x_k − θ_k x_k, T the preconditioner, p_k the last step), each of the
    three normalised, the 3 × 3 Rayleigh–Ritz solved by eigh; p is dropped for a step where
    the three are numerically dependent. None when ‖r_k‖ ≤ rtol·θ_k is not met in MAX_STEPS, or
    will not be at the rate the residual has been falling."""
    x = v0 / np.sqrt(_dot(v0, v0))
    ax = apply(x)
    p = ap = None
    residuals: list[float] = []
    for step in range(MAX_STEPS):
        theta = _dot(x, ax)
        r = ax - theta * x
        residuals.append(np.sqrt(_dot(r, r)))
        if not (np.isfinite(theta) and theta > 0.0):
            return None
        if residuals[-1] <= rtol * theta:
            return theta
        if step >= 2 * RATE_STEPS and _steps_left(residuals, rtol * theta) > MAX_STEPS - step:
            return None
        w = precondition(r)
        w /= np.sqrt(_dot(w, w))
        basis, images = [x, w], [ax, apply(w)]
        if p is not None and ap is not None:
            basis.append(p)
            images.append(ap)
        try:
            c = _ritz(basis, images)
        except (np.linalg.LinAlgError, ValueError):
            p = ap = None                          # dependent directions: restart without p
            continue
        p = sum(ci * b for ci, b in zip(c[1:], basis[1:]))
        ap = sum(ci * b for ci, b in zip(c[1:], images[1:]))
        x, ax = c[0] * x + p, c[0] * ax + ap
        size = np.sqrt(_dot(x, x))
        x, ax = x / size, ax / size
        size = np.sqrt(_dot(p, p))
        p, ap = p / size, ap / size
    return None


def _steps_left(residuals: list[float], goal: float) -> float:
    """Steps to bring the last residual to `goal` at the rate of the last RATE_STEPS steps."""
    rate = (residuals[-1] / residuals[-1 - RATE_STEPS]) ** (1.0 / RATE_STEPS)
    return np.inf if not rate < 1.0 else float(np.log(goal / residuals[-1]) / np.log(rate))


def _ritz(basis: list[Vector], images: list[Vector]) -> Vector:
    """The coefficients of the smallest Ritz vector of A on span(basis), images = A·basis."""
    k = len(basis)
    gram_a = np.array([[_dot(basis[i], images[j]) for j in range(k)] for i in range(k)])
    gram_b = np.array([[_dot(basis[i], basis[j]) for j in range(k)] for i in range(k)])
    gram_a = (gram_a + gram_a.T) / 2
    _, vectors = scipy.linalg.eigh(gram_a, gram_b, subset_by_index=(0, 0))
    return vectors[:, 0]
