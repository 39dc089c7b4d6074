"""Certify and repair: every q_ij ≥ 0 with the stiffness matrix assembled from the element means.

FIELDS.md §2–4. For P1 elements only the element means Q̄_T = (1/|T|)∫_T Q enter the stiffness
matrix, and the share of triangle T in the off-diagonal of its edge ij (k the opposite corner) is

    q_ij^T = −K_ij^T = −e_iᵀ adj(Q̄_T) e_j / (4|T|) = ½ √det Q̄_T · cot θ_k(adj Q̄_T),

e_i the edge vector opposite corner i (∇φ_i = J e_i / 2|T|, Jᵀ Q J = adj Q). An edge passes when
q_ij = Σ_T q_ij^T (two triangles inside, one on the boundary) is ≥ 0 by more than the error the
means carry (their quadrature's bound, ‖δQ̄‖·|e_i||e_j|/4|T| per share) and round-off. Each
round assembles the shares of the triangles that changed; an edge that fails is flipped when
its quadrilateral is convex and the other diagonal does better, else split at its midpoint
(smaller triangles see a more nearly constant Q); until none fails or the rounds run out, which
is then said, never passed over.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from qmesh.conductivity.anisotropy import adj2
from qmesh.geometry import topology
from qmesh.geometry.triangles import signed_areas
from qmesh.triangle_mesh import Mesh

ROUND = 1e-12       # q_ij may fall below 0 by this share of Σ|q_ij^T| (round-off of the assembly)
MAX_ROUNDS = 400    # rounds of flips and splits before the remaining edges are reported
STALL = 30          # ... or rounds without fewer failing edges than the best so far
SHORTEST = 1e-9     # edges shorter than this share of the domain's extent are not split


@dataclass(frozen=True)
class Certificate:
    """What the repair did and what is left: `remaining` edges still fail (0: certified)."""

    rounds: int
    flips: int
    added: int
    remaining: int
    worst: float        # the smallest q_ij / Σ|q_ij^T| over the edges (≥ −ROUND when certified)


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
    bound = (err[:, None] * np.linalg.norm(Ej, axis=2) * np.linalg.norm(Ek, axis=2)
             / (4.0 * area[:, None]))
    return s.ravel(), bound.ravel()


def certify(mesh: Mesh, field, max_rounds: int = MAX_ROUNDS) -> tuple[Mesh, Certificate]:
    """`mesh` made to pass on every interior and boundary edge with `field`'s element means,
    and what that took; the Mesh carries the means (`Mesh.conductivity`)."""
    P, T = np.array(mesh.points), np.array(mesh.triangles)
    twin = topology.twins(T)
    fixed = np.array(mesh.fixed)
    out = np.full(len(P), -1, np.int64)        # the tag of the boundary edge leaving each vertex
    out[mesh.boundary_edges[:, 0]] = mesh.boundary_tags
    Qbar, err = field.means_with_error(P, T)
    Qbar, err = np.array(Qbar, dtype=float), np.array(err, dtype=float)
    flips = added = 0
    shortest = SHORTEST * float(np.ptp(P, axis=0).max())
    fewest, since = np.inf, 0
    for rounds in range(max_rounds + 1):
        s, b = shares(P, T, Qbar, err)
        h, q, slack = _failing(s, b, twin)
        if len(h) < fewest:
            fewest, since = len(h), 0
        since += 1
        if not len(h) or rounds == max_rounds or since > STALL:
            break
        done = _flips(P, T, twin, h, q, field)
        if len(done):
            t = np.concatenate([done // 3, twin[done] // 3])
            T, twin = topology.flip(T, twin, done)
            flips += len(done)
        else:
            keep = _longer(P, T, h, shortest)
            if not keep.any():
                break
            P, T, twin, fixed, out, t = _splits(P, T, twin, fixed, out, h[keep], q[keep])
            added = len(P) - mesh.n_vertices
        Qbar, err = _refresh(field, P, T, Qbar, err, t)
    worst = float(slack.min()) if len(slack) else 0.0
    hb = np.flatnonzero(twin < 0)
    tb, kb = np.divmod(hb, 3)
    E = np.column_stack([T[tb, kb], T[tb, topology.NXT[kb]]])
    done_mesh = Mesh(P, T, fixed, E, out[E[:, 0]], mesh.tag_names, conductivity=Qbar)
    return done_mesh, Certificate(rounds, flips, added, len(h), worst)


def _failing(s, b, twin):
    """The failing edges (one half-edge each), their q_ij, and every edge's relative slack."""
    g = np.where(twin >= 0, twin, np.arange(len(twin)))
    inner = twin >= 0
    q = s + np.where(inner, s[g], 0.0)
    bound = b + np.where(inner, b[g], 0.0)
    scale = np.abs(s) + np.where(inner, np.abs(s[g]), 0.0)
    one = ~inner | (np.arange(len(twin)) < twin)            # each edge once
    slack = (q - bound)[one] / np.where(scale[one] > 0, scale[one], 1.0)
    bad = one & ~(q - bound >= -ROUND * scale)          # NaN fails too
    h = np.flatnonzero(bad)
    return h, q[h], slack


def _longer(P, T, h, shortest: float) -> np.ndarray:
    """Which half-edges h are longer than `shortest` (split no further: no flat triangles)."""
    a, b = T[h // 3, h % 3], T[h // 3, topology.NXT[h % 3]]
    return np.hypot(*(P[b] - P[a]).T) > shortest


def _independent(h, q, tris):
    """The failing edges that are the worst in each triangle they touch (no two share one)."""
    rank = np.empty(len(h))
    rank[np.argsort(-q, kind="stable")] = np.arange(1, len(h) + 1)     # most negative: highest
    cols = np.column_stack(tris)
    u, at = np.unique(cols.ravel(), return_inverse=True)
    best = np.zeros(len(u))
    np.maximum.at(best, at, np.repeat(rank, cols.shape[1]))
    return (best[at].reshape(cols.shape) == rank[:, None]).all(axis=1)


def _flips(P, T, twin, h, q, field):
    """The failing interior edges whose flip is valid and makes the new diagonal pass better."""
    inner = h[twin[h] >= 0]
    if not len(inner):
        return inner
    g = twin[inner]
    t1, e1 = np.divmod(inner, 3)
    t2, e2 = np.divmod(g, 3)
    u, v, a = T[t1, e1], T[t1, topology.NXT[e1]], T[t1, topology.PRV[e1]]
    bb = T[t2, topology.PRV[e2]]
    new = np.concatenate([np.column_stack([u, bb, a]), np.column_stack([bb, v, a])])
    ok = (signed_areas(P, new) > 0).reshape(2, -1).all(axis=0)     # a convex quadrilateral
    if not ok.any():
        return inner[:0]
    inner, q_old = inner[ok], q[twin[h] >= 0][ok]
    new = new.reshape(2, -1, 3)[:, ok].reshape(-1, 3)
    Qn, en = field.means_with_error(P, new)
    s, b = shares(P, new, np.asarray(Qn, dtype=float), np.asarray(en, dtype=float))
    k = len(inner)
    s, b = s.reshape(2 * k, 3), b.reshape(2 * k, 3)
    q_new = s[:k, 1] + s[k:, 2]                   # b→a in (u, b, a), a→b in (b, v, a)
    b_new = b[:k, 1] + b[k:, 2]
    better = q_new - b_new > q_old
    cand, qc = inner[better], q_old[better]
    pick = _independent(cand, qc, (cand // 3, twin[cand] // 3))
    return cand[pick]


def _splits(P, T, twin, fixed, out, h, q):
    """Split failing edges at their midpoints, boundary ones first (one per triangle)."""
    boundary = twin[h] < 0
    if boundary.any():
        hb, qb = h[boundary], q[boundary]
        hb = hb[_independent(hb, qb, (hb // 3,))]
        n = len(P)
        u, v = T[hb // 3, hb % 3], T[hb // 3, topology.NXT[hb % 3]]
        T, twin = topology.split_boundary_edges(T, twin, hb, n + np.arange(len(hb)))
        t = np.concatenate([hb // 3, len(T) - len(hb) + np.arange(len(hb))])
        new_out = out[u]
    else:
        hi = h[_independent(h, q, (h // 3, twin[h] // 3))]
        n = len(P)
        u, v = T[hi // 3, hi % 3], T[hi // 3, topology.NXT[hi % 3]]
        t = np.concatenate([hi // 3, twin[hi] // 3, len(T) + np.arange(2 * len(hi))])
        T, twin = topology.split_edges(T, twin, hi, n + np.arange(len(hi)))
        new_out = np.full(len(hi), -1, np.int64)
    P = np.concatenate([P, 0.5 * (P[u] + P[v])])
    fixed = np.concatenate([fixed, np.zeros(len(u), bool)])
    out = np.concatenate([out, new_out])
    return P, T, twin, fixed, out, t


def _refresh(field, P, T, Qbar, err, t):
    """The means of the triangles `t` (changed rows, and rows past the old end) recomputed."""
    M = len(T)
    if len(Qbar) < M:
        Qbar = np.concatenate([Qbar, np.zeros((M - len(Qbar), 2, 2))])
        err = np.concatenate([err, np.zeros(M - len(err))])
    t = np.unique(t)
    Qn, en = field.means_with_error(P, T[t])
    Qbar[t], err[t] = Qn, en
    return Qbar, err
