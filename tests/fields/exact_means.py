"""Element means computed without qmesh's quadrature, for fields whose features are known: each
triangle cut exactly along the lines where Q jumps or kinks, then a Gauss rule of another family
than the mesher's on each smooth piece; Gaussian bumps by a one-dimensional integral along each
edge (polar coordinates about the bump's centre); Gaussian ridges along a line in closed form
(erf along the ridge's normal). And the q_ij those means give, assembled here from the P1
gradients. Vectorised over triangles: a mesh of a few thousand triangles takes a second."""

from __future__ import annotations

import numpy as np
from scipy.special import erf, erfc


# --------------------------------------------------------------------------- rules

def collapsed_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n × n Gauss–Legendre points on the reference triangle by the Duffy collapse (barycentric
    u, v of corners B and C) and weights summing to 1: exact for degree 2n − 2."""
    t, w = np.polynomial.legendre.leggauss(n)
    t, w = 0.5 * (t + 1), 0.5 * w
    u, v = np.meshgrid(t, t, indexing="ij")
    W = np.outer(w, w) * (1 - u)
    return np.column_stack([u.ravel(), (v * (1 - u)).ravel()]), 2 * W.ravel()


def subdivided(A, B, C, levels: int):
    """Each triangle (A, B, C) (k, 2) cut into 4**levels congruent ones → (A, B, C) and the
    parent of each."""
    parent = np.arange(len(A))
    for _ in range(levels):
        ab, bc, ca = (A + B) / 2, (B + C) / 2, (C + A) / 2
        A, B, C = (np.concatenate(z) for z in ((A, ab, ca, ab), (ab, B, bc, bc), (ca, bc, C, ca)))
        parent = np.tile(parent, 4)
    return A, B, C, parent


def signed_area(A, B, C):
    return 0.5 * ((B[:, 0] - A[:, 0]) * (C[:, 1] - A[:, 1]) - (B[:, 1] - A[:, 1]) * (C[:, 0] - A[:, 0]))


def rule_integrals(Q, A, B, C, n: int, levels: int, at) -> np.ndarray:
    """∫ Q over each triangle (k, 2, 2) (unsigned area) by the collapsed rule on 4**levels pieces;
    Q(x, y, at) on 1-D arrays, the points of each triangle `at[i]` together → (m, 2, 2)."""
    a, b, c, parent = subdivided(A, B, C, levels)
    uv, w = collapsed_rule(n)
    X = a[:, None] + uv[None, :, 0, None] * (b - a)[:, None] + uv[None, :, 1, None] * (c - a)[:, None]
    q = Q(X[..., 0].ravel(), X[..., 1].ravel(), at[parent]).reshape(len(a), len(w), 4)
    piece = np.abs(signed_area(a, b, c))[:, None] * np.einsum("r,krc->kc", w, q)
    out = np.zeros((len(A), 4))
    np.add.at(out, parent, piece)
    return out.reshape(-1, 2, 2)


# --------------------------------------------------------------------------- jumps and kinks

def cut(A, B, C, parent, a, b, c):
    """Triangles cut by the line a x + b y = c (c one per triangle, or a number): a triangle the
    line crosses becomes the corner on one side and two triangles covering the rest, none
    crossing it; the others are kept. → (A, B, C, parent, c of each)."""
    c = np.broadcast_to(c, (len(A),))
    u = np.stack([X @ np.array([a, b]) - c for X in (A, B, C)], axis=1)      # (k, 3)
    pos = u > 0
    n = pos.sum(axis=1)
    crossed = (n == 1) | (n == 2)
    keep = ~crossed
    k = np.flatnonzero(crossed)
    V = np.stack([A[k], B[k], C[k]], axis=1)                                 # (m, 3, 2)
    uk, pk = u[k], pos[k]
    lone = np.where(n[k] == 1, np.argmax(pk, axis=1), np.argmax(~pk, axis=1))   # alone on its side
    r = np.arange(len(k))
    i, j, l = lone, (lone + 1) % 3, (lone + 2) % 3
    Pi, Pj, Pl = V[r, i], V[r, j], V[r, l]
    ui, uj, ul = uk[r, i], uk[r, j], uk[r, l]
    cij = Pi + (ui / (ui - uj))[:, None] * (Pj - Pi)                          # on the line
    cil = Pi + (ui / (ui - ul))[:, None] * (Pl - Pi)
    out_a = np.concatenate([A[keep], Pi, cij, cij])
    out_b = np.concatenate([B[keep], cij, Pj, Pl])
    out_c = np.concatenate([C[keep], cil, Pl, cil])
    out_p = np.concatenate([parent[keep], parent[k], parent[k], parent[k]])
    return out_a, out_b, out_c, out_p, np.concatenate([c[keep], c[k], c[k], c[k]])


def clipped_means(Q, P, T, lines, rules=((5, 1), (7, 2))):
    """The means of Q over the triangles T (M, 3) of P, Q smooth between the `lines` (a, b, c):
    every triangle cut exactly along each line (`cut`), a collapsed Gauss rule on each piece,
    the pieces' integrals summed per triangle and divided by the sum of their areas. Each
    triangle is cut in coordinates centred on it (a sliver's pieces far from the origin keep
    their areas to round-off of their own size). Computed with each of the two `rules` (n,
    levels); → (the finer's means (M, 2, 2), their difference (M,), the Frobenius norm: an
    estimate of the coarser's error, so far above the finer's)."""
    o = P[T].mean(axis=1)
    A, B, C = (P[T[:, k]] - o for k in range(3))
    a, b, c, parent = A, B, C, np.arange(len(T))
    for la, lb, lc in lines:
        a, b, c, parent, _ = cut(a, b, c, parent, la, lb, lc - o[parent] @ np.array([la, lb]))
    area = np.bincount(parent, np.abs(signed_area(a, b, c)), minlength=len(T))
    shifted = (lambda x, y, at: Q(x + np.repeat(o[at, 0], len(x) // len(at)),
                                  y + np.repeat(o[at, 1], len(x) // len(at))))
    got = []
    for n, levels in rules:
        piece = rule_integrals(shifted, a, b, c, n, levels, parent).reshape(-1, 4)
        out = np.zeros((len(T), 4))
        np.add.at(out, parent, piece)
        got.append(out.reshape(-1, 2, 2) / area[:, None, None])
    return got[-1], np.linalg.norm((got[-1] - got[0]).reshape(-1, 4), axis=1)


# --------------------------------------------------------------------------- bumps and ridges

_OCTAVES = np.concatenate([[0.0], 2.0 ** np.arange(-8, 40)])      # × w: the panels' ends in |s|


def _from_foot(S, d2, w, n):
    """∫_0^S h(d² + s²) ds for S ≥ 0 (k,), h(r²) = (1 − exp(−r²/w²)) / r², on panels ending at
    w·2^j (`_OCTAVES`: h varies on the scale max(w, r)), n Gauss–Legendre points each."""
    t, wt = np.polynomial.legendre.leggauss(n)
    ends = np.minimum(w * _OCTAVES[None, :], S[:, None])                    # (k, J)
    lo, hi = ends[:, :-1], ends[:, 1:]
    half, mid = 0.5 * (hi - lo), 0.5 * (hi + lo)
    s = mid[..., None] + half[..., None] * t                                # (k, J-1, n)
    r2 = d2[:, None, None] + s * s
    with np.errstate(invalid="ignore", divide="ignore"):
        h = np.where(r2 > 1e-12 * w * w, -np.expm1(-r2 / (w * w)) / r2, 1.0 / (w * w))
    return np.einsum("kjn,n,kj->k", h, wt, half)


def bump_means(P, T, centre, w, n=12):
    """The mean of g = exp(−|x − centre|² / w²) over each triangle (M,), exactly but for a
    one-dimensional Gauss rule: ∫_T g = Σ over its edges of the signed ∫ over the triangle
    (centre, edge), in polar coordinates about the centre ∫ dψ ∫_0^R g r dr, which along the
    edge (s its coordinate from the centre's foot, d the centre's distance to its line) is
    (w²/2) d ∫ h(d² + s²) ds with h smooth (`_from_foot`). → (means, the change from n − 4
    points a panel to n)."""
    A, B, C = (P[T[:, k]] - np.asarray(centre, float) for k in range(3))
    area = signed_area(A, B, C)
    got = []
    for m in (n - 4, n):
        total = np.zeros(len(T))
        for a, b in ((A, B), (B, C), (C, A)):
            e = b - a
            L = np.hypot(e[:, 0], e[:, 1])
            t = e / L[:, None]
            d = a[:, 0] * t[:, 1] - a[:, 1] * t[:, 0]          # area(0, a, b) = d · L / 2
            sa, sb = np.sum(a * t, axis=1), np.sum(b * t, axis=1)
            G = [np.sign(s) * _from_foot(np.abs(s), d * d, w, m) for s in (sa, sb)]
            total += 0.5 * w * w * d * (G[1] - G[0])
        got.append(total / area)
    return got[1], np.abs(got[1] - got[0])


def _erf_between(p, q):
    """erf(q) − erf(p) for p ≤ q, from the tails where both are on one side (no cancellation)."""
    return np.where(p >= 0, erfc(p) - erfc(q), np.where(q <= 0, erfc(-q) - erfc(-p), erf(q) - erf(p)))


def _ramp_integral(p, q, u0, w):
    """∫_p^q (u − p) exp(−(u − u0)²/w²) du / (q − p) (0 where q = p): closed form."""
    zp, zq = (p - u0) / w, (q - u0) / w
    gauss = 0.5 * np.sqrt(np.pi) * w * _erf_between(zp, zq)                  # ∫ g
    first = -0.5 * w * w * (np.exp(-zq * zq) - np.exp(-zp * zp))             # ∫ (u − u0) g
    with np.errstate(invalid="ignore", divide="ignore"):
        exact = (first + (u0 - p) * gauss) / (q - p)
    thin = (q - p) < 1e-6 * w                       # the weight's mean times the interval
    return np.where(thin, 0.5 * (q - p) * np.exp(-(0.5 * (p + q) - u0) ** 2 / (w * w)), exact)


def ridge_means(P, T, normal, u0, w):
    """The mean of g = exp(−(n·x − u0)² / w²) over each triangle (M,), n the `normal`: in
    closed form, ∫_T g = ∫ g(u) L(u) du with L the triangle's chord along u = const, 0 at its
    lowest and highest corner and linear between them and the middle one."""
    u = P[T] @ np.asarray(normal, float)                                     # (M, 3)
    u1, u2, u3 = np.sort(u, axis=1).T
    rising = _ramp_integral(u1, u2, u0, w)          # ∫ (u − u1) g / (u2 − u1)
    falling = _reflected(u2, u3, u0, w)             # ∫ (u3 − u) g / (u3 − u2)
    return 2 * (rising + falling) / (u3 - u1)       # L = 2|T| / (u3 − u1) at the middle corner


def _reflected(p, q, u0, w):
    """∫_p^q (q − u) exp(−(u − u0)²/w²) du / (q − p): `_ramp_integral` with u → −u."""
    return _ramp_integral(-q, -p, -u0, w)


# --------------------------------------------------------------------------- q_ij

def relative_q(P, T, Q, stated=None, round_off=1e-12):
    """q_ij / Σ_T |q_ij^T| of every edge with the element means Q (M, 2, 2), assembled here from
    the P1 gradients → (those of the interior edges, those of the boundary edges). With
    `stated` = (s, b) (3M,), a certificate's share q_ij^T of each half-edge 3t + j (corner j →
    j + 1) and its bound, also whether it passes each edge (Σ s − Σ b ≥ −round_off Σ|s|), split
    the same way."""
    X = P[T]
    area = signed_area(X[:, 0], X[:, 1], X[:, 2])
    E = X[:, [2, 0, 1]] - X[:, [1, 2, 0]]                         # the edge opposite corner i
    G = np.stack([E[..., 1], -E[..., 0]], axis=-1) / (2 * area[:, None, None])   # ∇φ_i
    pairs, share = [], []
    for i, j in ((0, 1), (1, 2), (2, 0)):
        share.append(-np.abs(area) * np.einsum("ki,kij,kj->k", G[:, i], Q, G[:, j]))
        pairs.append(np.sort(T[:, [i, j]], axis=1))
    pairs, share = np.concatenate(pairs), np.concatenate(share)
    key = pairs[:, 0].astype(np.int64) * len(P) + pairs[:, 1]
    _, edge, count = np.unique(key, return_inverse=True, return_counts=True)
    inner = count == 2

    def per_edge(v):
        return np.bincount(edge, v, minlength=len(count))
    q, scale = per_edge(share), per_edge(np.abs(share))
    r = q / np.where(scale > 0, scale, 1.0)
    if stated is None:
        return r[inner], r[~inner]
    s, b = (np.asarray(v).reshape(-1, 3).T.ravel() for v in stated)   # in the order of `share`
    ok = per_edge(s) - per_edge(b) >= -round_off * per_edge(np.abs(s))
    return (r[inner], r[~inner]), (ok[inner], ok[~inner])
