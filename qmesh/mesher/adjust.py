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

from qmesh.geometry.portable import inv2, solve2, times2
from qmesh.geometry.topology import NXT, PRV, touching
from qmesh.geometry.triangles import (Frame, area_gradients, chunks, columns, quadratic_form_xy,
                                      signed_areas)

STAR_SHRINK = 0.5      # largest fraction of a triangle's area one vertex's move may remove
FAN_WEIGHT = 0.15     # shape_step's weight of triangles with two boundary corners (see there)
MIN_AREA_KEPT = 0.1    # after all moves every triangle keeps at least this fraction of its area


def _corner_brackets(T, anisotropy, F: Frame, s_at, grad_at):
    """Σ_{k∈T, k≠i} [s(x_k) − s(x_i) − ∇s(x_i)·(x_k − x_i)] for every corner i of every T: (M, 3);
    `s_at`, `grad_at`: s and ∇s at every vertex (None for a constant Q)."""
    if anisotropy.is_constant:
        w = 0.5 * quadratic_form_xy(F.ex, F.ey, anisotropy.H)              # s(x_k − x_i) of (2.91)
        return (w[:, 0] + w[:, 1] + w[:, 2])[:, None] - w       # the two edges at the corner
    X = np.stack([F.x, F.y], axis=-1)
    s, g = s_at[T], grad_at[T]
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


def newton_rhs(P, T, anisotropy):
    """b_i of (2.91)/(2.93) and the star areas |Ω_i|.

    The per-corner terms are computed CHUNK triangles at a time and added onto the vertices
    as they come (np.add.at, block after block: the additions of a bincount over the whole
    mesh, in its order, so the sums are bit for bit those of one pass): neither a whole-mesh
    Frame nor the (M, 3) arrays of the terms are made (writing those, and the areas repeated for
    a bincount, took about 40% of this pass at 1e6 vertices)."""
    n = len(P)
    star, bx, by = np.zeros(n), np.zeros(n), np.zeros(n)
    s_at = grad_at = None
    if not anisotropy.is_constant:
        s_at = np.asarray(anisotropy.s(P), dtype=float)
        grad_at = np.asarray(anisotropy.grad(P), dtype=float)
    xy = columns(P)
    for c in chunks(len(T)):
        F = Frame(xy, T[c])
        S = _corner_brackets(T[c], anisotropy, F, s_at, grad_at)
        corner = T[c].ravel()
        np.add.at(star, corner, np.repeat(F.A, 3))
        np.add.at(bx, corner, (F.gx * S).ravel())
        np.add.at(by, corner, (F.gy * S).ravel())
    B = np.column_stack([bx, by])
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
        d = times2(b, inv2(anisotropy.H).T)                    # interior: H d = b
        Hv = np.broadcast_to(anisotropy.H, (n, 2, 2))
    else:
        Hv = np.asarray(anisotropy.hessian(P), dtype=float)
        d = solve2(Hv, b)
    sliding = (tangent[:, 0] != 0) | (tangent[:, 1] != 0)
    tb = np.einsum("ni,ni->n", tangent[sliding], b[sliding])
    tHt = np.einsum("ni,nij,nj->n", tangent[sliding], Hv[sliding], tangent[sliding])
    d[sliding] = tangent[sliding] * (tb / tHt)[:, None]
    d[fixed] = 0.0
    return alpha * d                                            # (2.92)


def shape_step(P, T, anisotropy, movable, on_boundary=None):
    """A Newton step per vertex on the shape of its star, for the `movable` vertices (zero rows
    for the others): minimises Σ_{T∋i} w_T Σ l̃²/Ã, a weighted sum of the inverse metric qualities
    (2.94) of its triangles (up to 4√3), convex in x_i (quadratic over linear functions).

    For a constant Q the trace of the stiffness matrix is ½√det Q Σ_T Σ_{interior corners}
    l̃²_opp/Ã, so the step keeps the diagonal, and with it λ_max, low where the vertex step
    (2.91) has no good place for a vertex: next to boundary points much finer than h. A triangle
    with two corners in `on_boundary` adds only its short boundary edge to that trace, so it
    weighs FAN_WEIGHT (its shape still counts, for the minimum quality).
    """
    T = T[touching(T, movable)]                               # the stars of the movable vertices
    if not len(T):
        return np.zeros((len(P), 2))
    parts = np.empty((5, len(T), 3))       # ∂/∂x, ∂/∂y and the Hessian's 00, 01, 11 per corner
    xy = columns(P)
    for c in chunks(len(T)):               # by blocks: see newton_rhs (each row on its own)
        _star_terms(xy, T[c], anisotropy, None if on_boundary is None else on_boundary[T[c]],
                    parts[:, c])
    idx = np.flatnonzero(movable)
    local = np.full(len(P), len(idx), np.int64)              # corners not movable: one spare bin
    local[idx] = np.arange(len(idx))
    li = local[T.ravel()]
    gx, gy, k00, k01, k11 = (np.bincount(li, x.ravel(), minlength=len(idx) + 1)[:-1] for x in parts)
    det = k00 * k11 - k01 * k01
    ok = det > 0                                              # the star's Hessian (convex sum)
    det = np.where(ok, det, 1.0)
    d = np.zeros((len(P), 2))
    d[idx] = np.where(ok[:, None], -np.column_stack([k11 * gx - k01 * gy, k00 * gy - k01 * gx])
                      / det[:, None], 0.0)
    return d


def _star_terms(xy, T, anisotropy, ob, out):
    """shape_step's per-corner terms of the triangles T into out (5, M, 3): the gradient of
    w_T S/Ã in the corner's position and its Hessian's entries 00, 01, 11; `ob` the triangles'
    corners on the boundary (None: every w_T = 1)."""
    F = Frame(xy, T)
    ex, ey = F.ex, F.ey                                       # the edge opposite each corner
    if anisotropy.is_constant:
        (h00_, h01_), (h10_, h11_) = anisotropy.H
        l2 = quadratic_form_xy(ex, ey, anisotropy.H)
    else:                       # at the centroids, from this Frame's corners (metric_hessians)
        Hm = np.asarray(anisotropy.hessian(np.column_stack([F.x.mean(axis=1), F.y.mean(axis=1)])),
                        dtype=float)
        h00_, h01_, h10_, h11_ = (Hm[:, i, j, None] for i, j in ((0, 0), (0, 1), (1, 0), (1, 1)))
        l2 = ((ex * h00_ * ex + ex * h01_ * ey) + ey * h10_ * ex) + ey * h11_ * ey   # quadratic_form
    sq = np.sqrt(h00_ * h11_ - h01_ * h10_)
    A = sq * F.A[:, None]                                     # metric areas (M, 1)
    S = l2.sum(axis=1)[:, None]                               # Σ l̃² (2.94)
    wt = None
    if ob is not None and FAN_WEIGHT != 1:
        # a triangle with two boundary corners adds l̃²_b/Ã of its boundary edge b to the trace:
        # weight it by that share of S/3 (equilateral: 1), but at least FAN_WEIGHT
        fan = ob.sum(axis=1) == 2
        lb2 = l2[np.arange(len(T)), np.argmin(ob, axis=1)]
        wt = np.where(fan, np.clip(3.0 * lb2 / S[:, 0], FAN_WEIGHT, 1.0), 1.0)[:, None]
    ux, uy = ex[:, NXT] - ex[:, PRV], ey[:, NXT] - ey[:, PRV]  # (x_c − x_a) + (x_c − x_b) per corner
    sx = 2.0 * (h00_ * ux + h01_ * uy)                        # ∂S/∂x_c = 2 H u
    sy = 2.0 * (h10_ * ux + h11_ * uy)
    ax, ay = sq * F.gx, sq * F.gy                             # ∂Ã/∂x_c
    ia = 1.0 / A
    sa = S * ia * ia
    c1, c2 = 2.0 * S * (ia * ia * ia), ia * ia
    # ∂(S/Ã)/∂x_c, and its Hessian 4H/Ã − (∇S ∇Ãᵀ + ∇Ã ∇Sᵀ)/Ã² + 2S ∇Ã ∇Ãᵀ/Ã³, entries 00, 01, 11
    out[0], out[1] = sx * ia - sa * ax, sy * ia - sa * ay
    out[2] = 4.0 * h00_ * ia - 2.0 * c2 * sx * ax + c1 * ax * ax
    out[3] = 4.0 * h01_ * ia - c2 * (sx * ay + sy * ax) + c1 * ax * ay
    out[4] = 4.0 * h11_ * ia - 2.0 * c2 * sy * ay + c1 * ay * ay
    if wt is not None:
        out *= wt


def boundary_layer(T, on_boundary, rings):
    """Interior vertices at most `rings` edges away from a boundary vertex."""
    near = on_boundary.copy()
    for _ in range(int(rings)):
        near = near.copy()
        near[T[touching(T, near)].ravel()] = True
    return near & ~on_boundary


def limit_moves(P, T, d, keep=None):
    """Cap moves so no vertex leaves its star and no triangle inverts; returns (P + d, d).

    Vertices in `keep` move exactly by d (their moves were checked already).
    """
    cap = np.ones(len(d))
    area = np.empty(len(T))
    xy, dxy = columns(P), columns(d)
    for c in chunks(len(T)):              # by chunks: see newton_rhs (a minimum is exact anyway)
        F = Frame(xy, T[c])
        area[c] = F.A
        _star_cap(T[c], F, dxy, cap)
    if keep is not None:
        cap[keep] = 1.0
    return _no_inversion(P, T, area, d * cap[:, None], keep)


def vertex_step(P, T, anisotropy, *, fixed, tangent, alpha=0.5):
    """New positions after one relaxed, capped adjustment of every vertex, and the displacements."""
    return limit_moves(P, T, newton_step(P, T, anisotropy, fixed=fixed, tangent=tangent,
                                         alpha=alpha))


def _star_cap(T, F: Frame, dxy, cap):
    """Lower `cap` (per vertex, ≤ 1) so each vertex's move alone keeps every triangle of T;
    `dxy` the moves' `columns`."""
    rate = F.gx * np.take(dxy[0], T) + F.gy * np.take(dxy[1], T)   # dA/dt for each corner's move
    shrink = rate < -STAR_SHRINK * F.A[:, None]                # would lose over half the area
    np.minimum.at(cap, T[shrink], -STAR_SHRINK * F.A[:, None].repeat(3, 1)[shrink] / rate[shrink])


def _no_inversion(P, T, A0, d, keep=None, max_halvings=30):
    """Halve the moves of vertices whose triangles would lose too much area."""
    d = d.copy()
    for i in range(max_halvings + 1):
        Pd = columns(P + d)
        bad = np.concatenate([signed_areas(Pd, T[c]) < MIN_AREA_KEPT * A0[c] for c in chunks(len(T))])
        if not bad.any():
            return P + d, d
        v = np.zeros(len(P), bool)
        v[T[bad].ravel()] = True
        if keep is not None:
            v &= ~keep
        d[v] *= 0.5 if i < max_halvings else 0.0
    return P + d, d
