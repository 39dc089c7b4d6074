"""Independent references for the element means: exact clipping of a triangle by each raster cell
(Sutherland–Hodgman, plain loops) and a fine uniform quadrature for formulas."""

import numpy as np

from qmesh.conductivity.anisotropy import principal_matrix


def clip(poly, axis, value, keep_above):
    """Sutherland–Hodgman: the part of polygon `poly` (list of (x, y)) with coordinate `axis`
    ≥ value (keep_above) or ≤ value."""
    out = []
    n = len(poly)
    inside = (lambda p: p[axis] >= value) if keep_above else (lambda p: p[axis] <= value)
    for k in range(n):
        cur, nxt = poly[k], poly[(k + 1) % n]
        if inside(cur):
            out.append(cur)
        if inside(cur) != inside(nxt):
            t = (value - cur[axis]) / (nxt[axis] - cur[axis])
            out.append((cur[0] + t * (nxt[0] - cur[0]), cur[1] + t * (nxt[1] - cur[1])))
    return out


def area(poly):
    if len(poly) < 3:
        return 0.0
    return 0.5 * sum(poly[k][0] * poly[(k + 1) % len(poly)][1] - poly[(k + 1) % len(poly)][0] * poly[k][1]
                     for k in range(len(poly)))


def cell_tensors(k1, k2, angle):
    """Q per cell (ny, nx, 2, 2) from MODFLOW's K, K22, ANGLEX, one cell at a time."""
    ny, nx = k1.shape
    return np.array([[principal_matrix(k1[j, i], k2[j, i], angle[j, i]) for i in range(nx)]
                     for j in range(ny)])


def principal(k1, k2, angle):
    """Q = R diag(k1, k2) Rᵀ on arrays, R the rotation by `angle` degrees (the reference's own)."""
    a = np.radians(angle)
    c, s = np.cos(a), np.sin(a)
    return np.stack([np.stack([k1 * c * c + k2 * s * s, (k1 - k2) * c * s], -1),
                     np.stack([(k1 - k2) * c * s, k1 * s * s + k2 * c * c], -1)], -2)


def raster_mean_by_clipping(x, y, Q, tri):
    """Area-weighted mean of the cells' Q (ny, nx, 2, 2) over triangle `tri` (3, 2), computed in
    coordinates centred on the triangle (areas of small pieces far from the origin stay exact)."""
    o = np.asarray(tri, float).mean(axis=0)
    x, y = np.asarray(x, float) - o[0], np.asarray(y, float) - o[1]
    poly = [tuple(map(float, p - o)) for p in np.asarray(tri, float)]
    total, covered = np.zeros((2, 2)), 0.0
    for j in range(len(y) - 1):
        for i in range(len(x) - 1):
            piece = poly
            for axis, value, above in ((0, x[i], True), (0, x[i + 1], False),
                                       (1, y[j], True), (1, y[j + 1], False)):
                piece = clip(piece, axis, value, above)
                if not piece:
                    break
            a = abs(area(piece)) if piece else 0.0
            total += a * Q[j, i]
            covered += a
    return total / abs(area(poly)), covered


def raster_box_mean(x, y, Q, p, h):
    """Mean of the cells over the square [p ± h] clipped to the raster, one cell at a time."""
    total, covered = np.zeros((2, 2)), 0.0
    for j in range(len(y) - 1):
        for i in range(len(x) - 1):
            w = max(0.0, min(x[i + 1], p[0] + h) - max(x[i], p[0] - h))
            v = max(0.0, min(y[j + 1], p[1] + h) - max(y[j], p[1] - h))
            total += w * v * Q[j, i]
            covered += w * v
    return total / covered


# Gauss–Legendre on the reference triangle by the Duffy collapse, n × n points: a rule of another
# family than the mesher's (Dunavant), exact for polynomials of degree 2n − 2 and more.
def _collapsed_rule(n):
    t, w = np.polynomial.legendre.leggauss(n)
    t, w = 0.5 * (t + 1), 0.5 * w
    u, v = np.meshgrid(t, t, indexing="ij")
    W = np.outer(w, w) * (1 - u)
    return np.column_stack([u.ravel(), (v * (1 - u)).ravel()]), 2 * W.ravel()   # weights sum to 1


def fine_mean(f, tri, levels=4, n=8):
    """Mean of f(x, y) → (k, 2, 2) over `tri` (3, 2): the triangle cut into 4**levels congruent
    pieces, an n × n collapsed Gauss rule on each."""
    A, B, C = (np.asarray(p, float)[None] for p in tri)
    for _ in range(levels):
        ab, bc, ca = (A + B) / 2, (B + C) / 2, (C + A) / 2
        A, B, C = (np.concatenate(z) for z in ((A, ab, ca, ab), (ab, B, bc, bc), (ca, bc, C, ca)))
    uv, w = _collapsed_rule(n)
    P = A[:, None] + uv[None, :, 0, None] * (B - A)[:, None] + uv[None, :, 1, None] * (C - A)[:, None]
    Q = f(P[..., 0].ravel(), P[..., 1].ravel()).reshape(len(A), len(w), 2, 2)
    return np.einsum("r,krij->ij", w, Q) / len(A)


def adaptive_mean_one_piece_at_a_time(evaluate, tri, rtol, atol=1e-300, max_depth=8):
    """`means.adaptive_means` of ONE triangle `tri` (3, 2), written out piece by piece: every
    piece's 7 rule points evaluated in a call of their own, the weighted values summed one at a
    time, the pieces of a level visited in the order the vectorised code stacks them (child 0 of
    every split piece, then child 1, …) and their sums taken in that order (as `np.bincount`
    does), no work cap. `evaluate`: points (n, 2) → components (n, 3). The same arithmetic as the
    batched code, so the same numbers to the bit. → (mean components (3,), error bound)."""
    from qmesh.conductivity.means import RULE_BARY, RULE_WEIGHTS

    def norm(q):
        return np.sqrt(q[0] ** 2 + 2.0 * q[1] ** 2 + q[2] ** 2)

    def rule(a, b, c):
        q = evaluate(np.array([w0 * a + w1 * b + w2 * c for w0, w1, w2 in RULE_BARY]))
        s = np.zeros(3)
        for w, v in zip(RULE_WEIGHTS, q):
            s = s + w * v
        return s

    def children(a, b, c):
        ab, bc, ca = 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a)
        return [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]

    def ordered_sum(values, zero):
        s = zero
        for v in values:
            s = s + v
        return s

    a, b, c = (np.asarray(p, float) for p in tri)
    pieces = [((a, b, c), rule(a, b, c))]
    total, err = np.zeros(3), 0.0
    for level in range(max_depth + 1):
        share = 0.25 ** level
        kids, avgs, fine, d = [], [], [], []
        for corners, coarse in pieces:
            k = children(*corners)
            v = [rule(*kid) for kid in k]
            f = 0.25 * (v[0] + v[1] + v[2] + v[3])
            kids.append(k), avgs.append(v), fine.append(f), d.append(norm(f - coarse))
        estimate = total + ordered_sum([share * f for f in fine], np.zeros(3))
        tol = rtol * norm(estimate) + atol
        settled = err + ordered_sum([share * x for x in d], 0.0) <= tol
        end = [settled or x <= tol or level == max_depth for x in d]
        total = total + ordered_sum([share * f for f, e in zip(fine, end) if e], np.zeros(3))
        err = err + ordered_sum([share * x for x, e in zip(d, end) if e], 0.0)
        split = [p for p, e in enumerate(end) if not e]
        if not split:
            break
        pieces = [(kids[p][c], avgs[p][c]) for c in range(4) for p in split]
    return total, err
