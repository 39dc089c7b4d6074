"""Which certificate shows that a Dirichlet stiffness matrix keeps the discrete maximum principle.

The P1 system of -div(Q∇u) = f with Dirichlet data is A u_I + B u_Γ = f (A the interior block of
the stiffness matrix K, B its couplings to the boundary vertices, K1 = 0). It keeps the
discrete maximum principle, with the boundary couplings, exactly when A⁻¹ ≥ 0 and −A⁻¹B ≥ 0
(Ciarlet 1970): the block matrix [[A, B], [0, I]] is monotone. Two sufficient conditions, the
second weaker (docs/guide/monotonicity.md states them and proves the second):

- "M-matrix": every off-diagonal of A and every entry of B is ≤ 0 (every q_ij ≥ 0);
- "monotone": block elimination leaves an M-matrix. The set F of interior vertices with no
  positive coupling is eliminated; A_FF is then a Stieltjes matrix, A_FF⁻¹ ≥ D⁻¹ + D⁻¹ N D⁻¹,
  and every positive entry left must be dominated by its two- and three-edge paths through F:
  the bound A_CC − A_CF (D⁻¹ + D⁻¹ N D⁻¹) A_FC of the Schur complement, and the same bound of
  its boundary couplings, have no positive off-diagonal. The rows that bound leaves without a
  positive entry are eliminated in turn, up to LEVELS times. At one level A = M₁M₂ with
  M₁, M₂ M-matrices, the product form of Lorenz (1977).

Everything is sparse-matrix algebra over all rows at once; the only loop is over the levels. The
certificate is sufficient, never exact: "none" means that neither condition was found.
"""

from __future__ import annotations

from typing import Literal, NamedTuple

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

Certificate = Literal["M-matrix", "monotone", "none"]

_NO_PAIRS = np.zeros((0, 2), dtype=np.int64)

LEVELS = 8
"""Elimination steps tried before "none": each eliminates every row left without a positive
entry."""


class Monotonicity(NamedTuple):
    """The certificate of a Dirichlet stiffness matrix and its evidence; `str()` is the certificate.

    `certificate`: "M-matrix", "monotone" or "none". Counts: `n_interior` unknowns,
    `n_positive` off-diagonals a_ij > tol of A (each pair i < j once), `n_positive_boundary`
    couplings b_iγ > tol to boundary vertices, `n_eliminated` vertices eliminated over all
    levels. `breaking`: the vertex pairs (i, j) (mesh indices, i interior) whose positive
    entry the paths through the eliminated vertices do not dominate, `excess` the bound of
    what is left of each (relative to the largest |off-diagonal| of A and B), both empty
    unless "none". `eliminated`: the eliminated vertices (mesh indices).
    `perturbation`: the largest weight, relative to that scale, that the certificate moved
    from a positive entry onto the diagonal (K + that edge Laplacian is what is certified;
    ≤ rtol). `reason`: why there is no matrix to certify, or None.
    """

    certificate: Certificate
    n_interior: int
    n_positive: int
    n_positive_boundary: int
    n_eliminated: int
    breaking: NDArray[np.int64]
    excess: NDArray[np.float64]
    eliminated: NDArray[np.int64]
    perturbation: float
    reason: str | None = None

    def __str__(self) -> str:
        return self.certificate


def without_matrix(certificate: Certificate, n_interior: int, reason: str) -> Monotonicity:
    """The value for a mesh whose Dirichlet matrix is empty or not positive definite."""
    empty = np.zeros(0)
    return Monotonicity(certificate, n_interior, 0, 0, 0, _NO_PAIRS, empty,
                        np.zeros(0, dtype=np.int64), 0.0, reason)


def certify(K: sp.csr_matrix, interior: NDArray[np.int64], boundary: NDArray[np.int64],
            rtol: float) -> Monotonicity:
    """The certificate of A = K[interior, interior] with B = K[interior, boundary].

    K: the symmetric Neumann stiffness matrix (zero row sums) of a conductivity whose Dirichlet
    block A is positive definite (the caller checks that). Entries are compared with
    tol = rtol · max |off-diagonal of A and B|: a positive entry ≤ tol is moved onto the
    diagonal (q_ij := 0), at every level.
    """
    A = _rows_cols(K, interior, interior)
    B = _rows_cols(K, interior, boundary)
    d = A.diagonal()
    M = _off_diagonal(A)
    B.eliminate_zeros()
    biggest = max(np.abs(M.data).max(initial=0.0), np.abs(B.data).max(initial=0.0))
    scale = biggest if biggest > 0 else 1.0
    tol = rtol * scale
    n = len(interior)
    n_pos = int(np.count_nonzero(M.data > tol)) // 2            # symmetric: each pair twice
    n_pos_b = int(np.count_nonzero(B.data > tol))
    if n_pos == 0 and n_pos_b == 0:                              # every q_ij ≥ −tol
        moved = max(M.data.max(initial=0.0), B.data.max(initial=0.0), 0.0)
        return Monotonicity("M-matrix", n, 0, 0, 0, _NO_PAIRS, np.zeros(0),
                            np.zeros(0, dtype=np.int64), moved / scale)
    C = np.arange(n)                                 # the rows left, as indices into `interior`
    eliminated: list[NDArray[np.int64]] = []
    moved = 0.0
    for level in range(LEVELS + 1):
        # 1. entries in (0, tol] onto the diagonal: K + an edge Laplacian, zero row sums kept
        M, B, d, small = _move_small(M, B, d, tol)
        moved = max(moved, small)
        positive = _has_positive(M, B)
        if not positive.any():                                   # an M-matrix is left
            return Monotonicity("monotone", n, n_pos, n_pos_b, sum(map(len, eliminated)),
                                _NO_PAIRS, np.zeros(0), interior[np.concatenate(eliminated)],
                                moved / scale)
        if positive.all() or level == LEVELS:                    # nothing (more) to eliminate
            break
        # 2. eliminate F = every row without a positive entry; bound the Schur complement
        F = np.flatnonzero(~positive)
        eliminated.append(C[F])
        M, B, d, keep = _eliminate(M, B, d, F)
        C = C[keep]
    pairs, excess = _positive_pairs(M, B, interior[C], boundary)
    found = np.concatenate(eliminated) if eliminated else np.zeros(0, dtype=np.int64)
    return Monotonicity("none", n, n_pos, n_pos_b, len(found), pairs, excess / scale,
                        interior[found], moved / scale)


def _rows_cols(K: sp.csr_matrix, rows: NDArray[np.int64], cols: NDArray[np.int64]) -> sp.csr_matrix:
    return sp.csr_matrix(K[rows][:, cols])


def _off_diagonal(A: sp.csr_matrix) -> sp.csr_matrix:
    M = (A - sp.diags(A.diagonal())).tocsr()
    M.eliminate_zeros()
    return M


def _rows(M: sp.csr_matrix) -> NDArray[np.intp]:
    return np.repeat(np.arange(M.shape[0]), np.diff(M.indptr))


def _move_small(M: sp.csr_matrix, B: sp.csr_matrix, d: NDArray[np.float64], tol: float
                ) -> tuple[sp.csr_matrix, sp.csr_matrix, NDArray[np.float64], float]:
    """Positive entries ≤ tol set to 0 and added to the diagonal of their row (both rows for
    an interior pair: the matrix stays symmetric), and the largest one moved."""
    small_a = (M.data > 0) & (M.data <= tol)
    small_b = (B.data > 0) & (B.data <= tol)
    if not (small_a.any() or small_b.any()):
        return M, B, d, 0.0
    largest = max(M.data[small_a].max(initial=0.0), B.data[small_b].max(initial=0.0))
    d = d + np.bincount(_rows(M), M.data * small_a, minlength=len(d))
    d += np.bincount(_rows(B), B.data * small_b, minlength=len(d))
    M, B = M.copy(), B.copy()
    M.data[small_a] = 0.0
    B.data[small_b] = 0.0
    M.eliminate_zeros()
    B.eliminate_zeros()
    return M, B, d, float(largest)


def _has_positive(M: sp.csr_matrix, B: sp.csr_matrix) -> NDArray[np.bool_]:
    """The rows with a positive coupling (to a row left or to a boundary vertex)."""
    out = np.zeros(M.shape[0], bool)
    out[_rows(M)[M.data > 0]] = True
    out[M.indices[M.data > 0]] = True
    out[_rows(B)[B.data > 0]] = True
    return out


def _eliminate(M: sp.csr_matrix, B: sp.csr_matrix, d: NDArray[np.float64], F: NDArray[np.int64]
               ) -> tuple[sp.csr_matrix, sp.csr_matrix, NDArray[np.float64], NDArray[np.int64]]:
    """Upper bounds of the Schur complement onto C (the rows not in F): its off-diagonal part,
    its boundary couplings and its diagonal, and C.

    A_FF = D − N is a Stieltjes matrix (no positive entry, positive definite), so
    A_FF⁻¹ = Σ_m (D⁻¹N)^m D⁻¹ ≥ D⁻¹ + D⁻¹ N D⁻¹ =: W, and with A_CF ≤ 0,
    S = A_CC − A_CF A_FF⁻¹ A_FC ≤ A_CC − A_CF W A_FC entrywise: the two- and three-edge
    paths through F. The bounds of one level are the next level's matrix: an entry of the
    true Schur complement is at most the bound, a negative one at least as large in size,
    and its diagonal at most the bound's, so W stays a lower bound of the inverse."""
    free = np.zeros(M.shape[0], bool)
    free[F] = True
    C = np.flatnonzero(~free)
    Dinv = sp.diags(1.0 / d[F])
    W = Dinv - Dinv @ _rows_cols(M, F, F) @ Dinv                 # D⁻¹ + D⁻¹ N D⁻¹, N = −M_FF
    M_CF = _rows_cols(M, C, F)
    T = (M_CF @ W @ M_CF.T).tocsr()                              # A_FC = A_CFᵀ
    S = (_rows_cols(M, C, C) - T).tocsr()
    d_new = d[C] - T.diagonal()
    BS = (sp.csr_matrix(B[C]) - M_CF @ W @ sp.csr_matrix(B[F])).tocsr()
    BS.eliminate_zeros()
    return _off_diagonal(S), BS, d_new, C


def _positive_pairs(M: sp.csr_matrix, B: sp.csr_matrix, rows: NDArray[np.int64],
                    boundary: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """The vertex pairs (i, j) of every positive entry left (interior pairs once, then the
    boundary couplings) and the entries; `rows`: the vertex of each row left."""
    upper = sp.triu(M, k=1).tocoo()
    bs = B.tocoo()
    a, b = upper.data > 0, bs.data > 0
    pairs = np.concatenate([np.column_stack([rows[upper.row[a]], rows[upper.col[a]]]),
                            np.column_stack([rows[bs.row[b]], boundary[bs.col[b]]])])
    return pairs.astype(np.int64), np.concatenate([upper.data[a], bs.data[b]])
