"""Vertex adjustment: the generalised optimal-Delaunay step (chapter (2.85)–(2.93), MATH.md).

With the connectivity fixed, each vertex moves towards the minimiser of the interpolation energy
E = ‖s_h − s‖_L1 = ⅓ Σ_i |Ω_i| s(x_i) − ∫ s over its own star:

    H(x_i) d_i = b_i = −(1/|Ω_i|) Σ_{T∋i} ∇_{x_i}|T| Σ_{k∈T, k≠i} [s(x_k) − s(x_i) − ∇s(x_i)·(x_k − x_i)]

(2.91) for constant Q, where the bracket is s(x_k − x_i); (2.93) linearised for a varying s.
b_i = −3 ∇_{x_i}E / |Ω_i| and ⅓|Ω_i| H is E's Hessian in x_i, so d_i is a Newton step on E.
For s = ½|x|² this is the ODT update of Alliez et al. (2005) and L. Chen (2004).

Seed boundary vertices never move; other boundary vertices slide along their polygon edge (the
same Newton step restricted to the edge's direction). The move is relaxed by α (2.92) and capped
so that no vertex leaves its star: no triangle loses more than half its area to one vertex, and
moves that would still invert a triangle (neighbours moving together) are halved until none does.
"""

from __future__ import annotations

import numpy as np

from .geometry import (Frame, area_gradients, metric_hessians, quadratic_form,
                       quadratic_form_xy, signed_areas)

STAR_SHRINK = 0.5      # largest fraction of a triangle's area one vertex's move may remove
MIN_AREA_KEPT = 0.1    # after all moves every triangle keeps at least this fraction of its area


def _corner_brackets(P, T, anisotropy, F: Frame):
    """Σ_{k∈T, k≠i} [s(x_k) − s(x_i) − ∇s(x_i)·(x_k − x_i)] for every corner i of every T: (M, 3)."""
    if anisotropy.is_constant:
        w = 0.5 * quadratic_form_xy(F.ex, F.ey, anisotropy.H)              # s(x_k − x_i) of (2.91)
        return w.sum(axis=1, keepdims=True) - w                # the two edges at the corner
    X = np.stack([F.x, F.y], axis=-1)
    s = np.asarray(anisotropy.s(P), dtype=float)[T]
    g = np.asarray(anisotropy.grad(P), dtype=float)[T]
    out = np.zeros(T.shape)
    for shift in (1, 2):
        k = np.roll(np.arange(3), -shift)
        out += s[:, k] - s - np.einsum("mci,mci->mc", g, X[:, k] - X)   # (2.93) linearised
    return out


def _scatter(T, values, n):
    """Sum per-corner values (M, 3[, 2]) onto the n vertices."""
    idx = T.ravel()
    if values.ndim == 2:
        return np.bincount(idx, values.ravel(), minlength=n)
    v = values.reshape(-1, values.shape[-1])
    return np.column_stack([np.bincount(idx, v[:, j], minlength=n) for j in range(v.shape[1])])


def newton_rhs(P, T, anisotropy, F: Frame | None = None):
    """b_i of (2.91)/(2.93) and the star areas |Ω_i|."""
    n = len(P)
    F = Frame(P, T) if F is None else F
    star = np.bincount(T.ravel(), np.repeat(F.A, 3), minlength=n)
    S = _corner_brackets(P, T, anisotropy, F)
    B = np.column_stack([_scatter(T, F.gx * S, n), _scatter(T, F.gy * S, n)])
    return -B / np.where(star > 0, star, 1.0)[:, None], star


def energy_gradient(P, T, anisotropy):
    """∇_{x_i}E straight from E = ⅓ Σ_T |T| Σ_{k∈T} s(x_k) − ∫s (fixed domain), for testing."""
    n = len(P)
    G = area_gradients(P, T)
    A = signed_areas(P, T)
    s = np.asarray(anisotropy.s(P), dtype=float)
    star = np.bincount(T.ravel(), np.repeat(A, 3), minlength=n)
    ssum = s[T].sum(axis=1)
    grad = _scatter(T, G * ssum[:, None, None], n) + star[:, None] * anisotropy.grad(P)
    return grad / 3.0


def newton_step(P, T, anisotropy, *, fixed, tangent, alpha=0.5):
    """The relaxed displacement α·d_i of every vertex (2.91)–(2.92), before any cap.

    `fixed` marks vertices that never move; `tangent` (N, 2) is the unit direction a sliding
    boundary vertex may move along (zero rows for interior vertices).
    """
    n = len(P)
    b, _ = newton_rhs(P, T, anisotropy)
    if anisotropy.is_constant:
        d = b @ np.linalg.inv(anisotropy.H).T                  # interior: H d = b
        Hv = np.broadcast_to(anisotropy.H, (n, 2, 2))
    else:
        Hv = np.asarray(anisotropy.hessian(P), dtype=float)
        d = np.linalg.solve(Hv, b[..., None])[..., 0]
    sliding = np.any(tangent != 0, axis=1)
    tb = np.einsum("ni,ni->n", tangent[sliding], b[sliding])
    tHt = np.einsum("ni,nij,nj->n", tangent[sliding], Hv[sliding], tangent[sliding])
    d[sliding] = tangent[sliding] * (tb / tHt)[:, None]
    d[fixed] = 0.0
    return alpha * d                                            # (2.92)


def shape_step(P, T, anisotropy, movable):
    """A Newton step per vertex on the shape of its star, for the `movable` vertices (zero rows
    for the others): minimises Σ_{T∋i} Σ l̃²/Ã, the sum of the inverse metric qualities (2.94)
    of its triangles (up to 4√3), which is convex in x_i (a quadratic over a linear function).

    For a constant Q the trace of the stiffness matrix is ½√det Q Σ_T Σ_{interior corners}
    l̃²_opp/Ã, so this step also keeps the diagonal, and with it λ_max, low where the vertex step
    (2.91) has no good place for a vertex: between boundary points much finer than h.
    """
    n = len(P)
    F = Frame(P, T)
    Hm = metric_hessians(anisotropy, P, T)
    Hb = Hm[0] if Hm.strides[0] == 0 else None
    sq = np.sqrt(Hm[:, 0, 0] * Hm[:, 1, 1] - Hm[:, 0, 1] * Hm[:, 1, 0])
    E = F.E                                                   # edge opposite each corner
    S = (quadratic_form(E, Hb) if Hb is not None else quadratic_form(E, Hm)).sum(axis=1)
    A = sq * F.A                                              # metric areas
    G = np.zeros((n, 2))
    K = np.zeros((n, 2, 2))
    for c in range(3):                                        # the three corners
        a, b = (c + 1) % 3, (c + 2) % 3
        # corner c's two edges: E[:, a] = x_c − x_b and E[:, b] = x_a − x_c (Frame)
        u = E[:, a] - E[:, b]                                 # (x_c − x_a) + (x_c − x_b)
        Mu = u @ Hb.T if Hb is not None else np.einsum("mij,mj->mi", Hm, u)
        dS = 2.0 * Mu
        dA = sq[:, None] * np.column_stack([F.gx[:, c], F.gy[:, c]])
        grad = dS / A[:, None] - (S / A ** 2)[:, None] * dA
        cross = dS[:, :, None] * dA[:, None, :]
        hess = (4.0 * (Hm if Hb is None else np.broadcast_to(Hb, (len(T), 2, 2))) / A[:, None, None]
                - (cross + cross.transpose(0, 2, 1)) / (A ** 2)[:, None, None]
                + (2.0 * S / A ** 3)[:, None, None] * dA[:, :, None] * dA[:, None, :])
        for j in range(2):
            G[:, j] += np.bincount(T[:, c], grad[:, j], minlength=n)
            for k in range(2):
                K[:, j, k] += np.bincount(T[:, c], hess[:, j, k], minlength=n)
    d = np.zeros((n, 2))
    m = movable & (np.linalg.det(K) > 0)
    d[m] = -np.linalg.solve(K[m], G[m][..., None])[..., 0]
    return d


def boundary_layer(T, on_boundary, rings):
    """Interior vertices at most `rings` edges away from a boundary vertex."""
    near = on_boundary.copy()
    for _ in range(rings):
        near = near.copy()
        near[T[near[T].any(axis=1)].ravel()] = True
    return near & ~on_boundary


def limit_moves(P, T, d, keep=None):
    """Cap moves so no vertex leaves its star and no triangle inverts; returns (P + d, d).

    Vertices in `keep` move exactly by d (their moves were checked already).
    """
    F = Frame(P, T)
    cap = _star_cap(T, F, d)
    if keep is not None:
        cap[keep] = 1.0
    return _no_inversion(P, T, F.A, d * cap[:, None], keep)


def vertex_step(P, T, anisotropy, *, fixed, tangent, alpha=0.5):
    """New positions after one relaxed, capped adjustment of every vertex, and the displacements."""
    return limit_moves(P, T, newton_step(P, T, anisotropy, fixed=fixed, tangent=tangent,
                                         alpha=alpha))


def _star_cap(T, F: Frame, d):
    """Largest factor ≤ 1 per vertex so its move alone keeps every triangle of its star."""
    rate = (F.gx * np.take(np.ascontiguousarray(d[:, 0]), T)
            + F.gy * np.take(np.ascontiguousarray(d[:, 1]), T))   # dA/dt for each corner's move
    shrink = rate < -STAR_SHRINK * F.A[:, None]                # would lose over half the area
    cap = np.ones(len(d))
    np.minimum.at(cap, T[shrink], -STAR_SHRINK * F.A[:, None].repeat(3, 1)[shrink] / rate[shrink])
    return cap


def _no_inversion(P, T, A0, d, keep=None, max_halvings=30):
    """Halve the moves of vertices whose triangles would lose too much area."""
    d = d.copy()
    for i in range(max_halvings + 1):
        bad = signed_areas(P + d, T) < MIN_AREA_KEPT * A0
        if not bad.any():
            return P + d, d
        v = np.zeros(len(P), bool)
        v[T[bad].ravel()] = True
        if keep is not None:
            v &= ~keep
        d[v] *= 0.5 if i < max_halvings else 0.0
    return P + d, d
