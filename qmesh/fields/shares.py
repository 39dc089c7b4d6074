"""Each triangle's share of its edges' stiffness off-diagonals, and which edges fail q_ij ≥ 0.

FIELDS.md §3. For P1 elements only the element means Q̄_T = (1/|T|)∫_T Q enter the stiffness
matrix, and the share of triangle T in the off-diagonal of its edge ij (k the opposite corner) is

    q_ij^T = −K_ij^T = −e_iᵀ adj(Q̄_T) e_j / (4|T|) = ½ √det Q̄_T · cot θ_k(adj Q̄_T),

e_i the edge vector opposite corner i (∇φ_i = J e_i / 2|T|, Jᵀ Q J = adj Q). An edge passes when
q_ij = Σ_T q_ij^T (two triangles inside, one on the boundary) is ≥ 0 by more than the error the
means carry (their quadrature's bound, ‖δQ̄‖·|e_i||e_j|/4|T| per share) and round-off. The repair
(certify.py, flips.py, splits.py, moves.py) judges every change by these and keeps the shapes
by FLOOR and KEEP.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from qmesh.conductivity.anisotropy import adj2
from qmesh.geometry.triangles import signed_areas

ROUND = 1e-12       # q_ij may fall below 0 by this share of Σ|q_ij^T| (round-off of the assembly)
GAIN = 1e-9         # a flip or a move must lower its deficit by this share at least
FLOOR = 0.3         # a split or a repairing move keeps the worst metric quality (2.94) of what it
KEEP = 0.75         # changes above KEEP · min(FLOOR, the worst before) where it can (a repairing
                    # move: above min(the worst before, KEEP · FLOOR))


def shares(P: NDArray[np.float64], T: NDArray[np.int64], Qbar: NDArray[np.float64],
           err: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """q_ij^T of the edge of every half-edge 3t + j (corner j → j + 1) and a bound on its error
    from the means' error `err` (M,): FIELDS.md §3."""
    X = P[T]
    E = X[:, [2, 0, 1]] - X[:, [1, 2, 0]]                    # edge opposite each corner
    area = 0.5 * signed_areas(P, T)
    A = adj2(Qbar)
    Ej, Ek = E, E[:, [1, 2, 0]]                              # opposite corners j and j + 1
    s = -np.einsum("mki,mij,mkj->mk", Ej, A, Ek) / (4.0 * area[:, None])
    bound = (err[:, None] * np.hypot(Ej[..., 0], Ej[..., 1]) * np.hypot(Ek[..., 0], Ek[..., 1])
             / (4.0 * area[:, None]))
    return s.ravel(), bound.ravel()


def failing(s, b, twin, slack=False):
    """The failing edges (one half-edge each), their q_ij, and (`slack`) every edge's relative
    slack (else None). An edge both of whose shares pass their own bounds passes (rounding is
    monotone): only the others are summed."""
    maybe = np.flatnonzero(~(s >= b))                   # NaN too
    g = twin[maybe]
    mark = np.zeros(len(s), bool)
    mark[np.where((g >= 0) & (g < maybe), g, maybe)] = True          # each edge once
    h = np.flatnonzero(mark)
    g = twin[h]
    inner = g >= 0
    gg = np.where(inner, g, 0)
    q = s[h] + np.where(inner, s[gg], 0.0)
    bound = b[h] + np.where(inner, b[gg], 0.0)
    scale = np.abs(s[h]) + np.where(inner, np.abs(s[gg]), 0.0)
    bad = ~(q - bound >= -ROUND * scale)                # NaN fails too
    return h[bad], q[bad], (_slack(s, b, twin) if slack else None)


def _slack(s, b, twin):
    """Every edge's q_ij − bound over Σ|q_ij^T| + bound (each edge once): between −1 and 1, as
    q_ij / Σ|q_ij^T| is, also where the means' error bound outweighs the shares."""
    g = np.where(twin >= 0, twin, np.arange(len(twin)))
    inner = twin >= 0
    q = s + np.where(inner, s[g], 0.0)
    bound = b + np.where(inner, b[g], 0.0)
    scale = np.abs(s) + np.where(inner, np.abs(s[g]), 0.0)
    one = ~inner | (np.arange(len(twin)) < twin)            # each edge once
    total = (scale + np.abs(bound))[one]
    return (q - bound)[one] / np.where(total > 0, total, 1.0)


def by_bound(s, b, twin, h, tight):
    """The triangles beside the failing half-edges h whose q_ij ≥ 0 fails only by the means'
    error bound, and whose means are not yet at the field's own tolerance."""
    g = twin[h]
    inner = g >= 0
    gg = np.maximum(g, 0)
    q = s[h] + np.where(inner, s[gg], 0.0)
    scale = np.abs(s[h]) + np.where(inner, np.abs(s[gg]), 0.0)
    only = q >= -ROUND * scale
    t = np.concatenate([h[only] // 3, g[only & inner] // 3])
    return np.unique(t[~tight[t]])


def deficit(q, bound):
    """How far q_ij falls short of its error bound (0 for an edge that passes)."""
    return np.maximum(bound - q, 0.0)


def independent(h, q, tris):
    """The failing edges that are the worst in each triangle they touch (no two share one)."""
    rank = np.empty(len(h))
    rank[np.argsort(-q, kind="stable")] = np.arange(1, len(h) + 1)     # most negative: highest
    cols = np.column_stack(tris)
    u, at = np.unique(cols.ravel(), return_inverse=True)
    best = np.zeros(len(u))
    np.maximum.at(best, at, np.repeat(rank, cols.shape[1]))
    return (best[at].reshape(cols.shape) == rank[:, None]).all(axis=1)


def means_of(field, how, P, T, tags):
    """`field`'s means and error bounds of the triangles T (`how`: means_with_error, tighten, or
    rough where the field has it); a medium's (`tags` given) from each triangle's region."""
    f = getattr(field, how, field.means_with_error)
    return f(P, T) if tags is None else f(P, T, tags)


def cut_interfaces(twin, reg):
    """The twins with the interfaces cut (−1 on both sides of an edge between two regions, as on
    the boundary): each side's share is then judged on its own, and never flipped. `twin`
    itself without regions."""
    if reg is None:
        return twin
    across = twin >= 0
    other = np.where(across, twin // 3, 0)
    return np.where(across & (reg[other] == np.repeat(reg, 3)), twin, -1)
