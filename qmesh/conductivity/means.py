"""Element means Q̄_T = (1/|T|) ∫_T Q of a conductivity field, and its means over squares.

Only the element means enter the P1 stiffness matrix (FIELDS.md §2:
K_ij = Σ_T |T| ∇φ_iᵀ Q̄_T ∇φ_j), so they are computed once, here, for the mesher, the
measurements, the files and the adapters alike. A symmetric tensor is carried as its three
components (q11, q12, q22), arrays (..., 3); its Frobenius norm is √(q11² + 2 q12² + q22²).

- `adaptive_means`: a formula or callable. Dunavant's (1985) degree-5 rule with 7 points on a
  triangle against the same rule on its 4 midpoint children; a triangle whose difference exceeds
  its share of the tolerance is split and the test repeated on its children, level by level,
  vectorised over all the pieces of a level. Exact (to round-off) for polynomials of degree ≤ 5,
  so for constant and linear fields.
- `raster_edge_integrals` / `raster_means`: a raster of cells, each with a constant Q. The exact
  area-weighted mean of the cells T overlaps by Green's theorem, ∫_T f = ∮_∂T G dy with
  G(x, y) = ∫_{x0}^{x} f(s, y) ds, which is linear in x inside each cell (cumulative sums of
  f · width along each row): each edge of T split at the grid lines it crosses is a chain of pieces
  inside one cell each, G is linear along each piece, and the midpoint rule integrates it exactly.
  O(perimeter): the work per triangle is the number of grid lines its edges cross, not the number
  of cells it covers.
- `gauss_box_means` / `raster_box_means`: the mean over an axis-aligned square, the mesher's
  smoothing of the field at the target scale: a tensor-product Gauss–Legendre rule for formulas;
  exact for rasters by a summed-area table (a bilinear primitive F(X, Y) = ∫∫_{x0,y0}^{X,Y} f).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from numpy.typing import NDArray

from qmesh.errors import QmeshError

Array = NDArray[np.float64]
Evaluate = Callable[[Array], Array]
"""A checked field: points (n, 2) → components (n, 3) = (q11, q12, q22); QmeshError naming the
first point where Q is not finite, not symmetric or not positive definite."""

RTOL = 1e-10
"""Adaptive quadrature: a triangle's mean is accepted when the estimated error (the Frobenius norm
of the last fine − coarse difference) is ≤ RTOL · ‖Q̄_T‖_F + ATOL."""
ATOL = 1e-300
"""The absolute floor of the tolerance (in units of Q): a mean whose norm underflows still ends."""
MAX_DEPTH = 8
"""At most this many levels of midpoint subdivision below each triangle (4⁸ pieces of it at most)."""
MIN_BUDGET = 1 << 19
"""Pieces refined per level: at most max(4 M, MIN_BUDGET) for M triangles, the worst first, so
a field that never converges (a discontinuity, a singular point) costs a bounded amount of work; its
error bound says so."""
CHUNK = 1 << 15
"""Pieces evaluated at once (7 points each): bounds the memory of one evaluation."""

# Dunavant (1985), Table I, degree 5 (the Radon–Stroud T2:5-1 rule): barycentric points, weights
# summing to 1; exact for polynomials of degree ≤ 5 on a triangle.
_S15 = np.sqrt(15.0)
_A, _B = (6.0 - _S15) / 21.0, (6.0 + _S15) / 21.0
_WA, _WB = (155.0 - _S15) / 1200.0, (155.0 + _S15) / 1200.0
RULE_BARY = np.array([[1 / 3, 1 / 3, 1 / 3],
                      [1 - 2 * _A, _A, _A], [_A, 1 - 2 * _A, _A], [_A, _A, 1 - 2 * _A],
                      [1 - 2 * _B, _B, _B], [_B, 1 - 2 * _B, _B], [_B, _B, 1 - 2 * _B]])
RULE_WEIGHTS = np.array([9 / 40, _WA, _WA, _WA, _WB, _WB, _WB])


def frobenius(q: Array) -> Array:
    """‖Q‖_F of symmetric tensors given as components (..., 3)."""
    return np.sqrt(q[..., 0] ** 2 + 2.0 * q[..., 1] ** 2 + q[..., 2] ** 2)


def full_tensors(q: Array) -> Array:
    """Components (..., 3) → matrices (..., 2, 2)."""
    out = np.empty(q.shape[:-1] + (2, 2))
    out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1] = q[..., 0], q[..., 1], q[..., 1], q[..., 2]
    return out


def _sum_by(index: NDArray[np.intp], values: Array, n: int) -> Array:
    """Σ of values (k,) or (k, c) over equal index → (n,) or (n, c)."""
    if values.ndim == 1:
        return np.bincount(index, values, minlength=n).astype(np.float64, copy=False)
    return np.stack([np.bincount(index, values[:, c], minlength=n) for c in range(values.shape[1])],
                    axis=1).astype(np.float64, copy=False)


# --------------------------------------------------------------------------- formulas

def rule_averages(evaluate: Evaluate, A: Array, B: Array, C: Array) -> Array:
    """The 7-point degree-5 rule's average of Q over each triangle (A, B, C) → components (k, 3)."""
    k = len(A)
    out = np.empty((k, 3))
    for s in range(0, k, CHUNK):
        a, b, c = A[s:s + CHUNK], B[s:s + CHUNK], C[s:s + CHUNK]
        P = (RULE_BARY[None, :, 0, None] * a[:, None] + RULE_BARY[None, :, 1, None] * b[:, None]
             + RULE_BARY[None, :, 2, None] * c[:, None])                       # (k, 7, 2)
        q = evaluate(P.reshape(-1, 2)).reshape(len(a), 7, 3)
        out[s:s + CHUNK] = np.einsum("r,krc->kc", RULE_WEIGHTS, q)
    return out


def _children(A: Array, B: Array, C: Array) -> list[tuple[Array, Array, Array]]:
    """The 4 midpoint children of each triangle, each a quarter of its area, same orientation."""
    ab, bc, ca = 0.5 * (A + B), 0.5 * (B + C), 0.5 * (C + A)
    return [(A, ab, ca), (ab, B, bc), (ca, bc, C), (ab, bc, ca)]


def adaptive_means(evaluate: Evaluate, A: Array, B: Array, C: Array, rtol: float = RTOL,
                   atol: float = ATOL, max_depth: int = MAX_DEPTH) -> tuple[Array, Array]:
    """Element means of a field over triangles (A, B, C) (each (M, 2)): components (M, 3) and an
    error bound (M,) in the Frobenius norm.

    Level by level, every live piece p (a 4^-L share of its triangle T) has its coarse average
    (the 7-point rule on p) and its fine one (the rule on its 4 midpoint children) with
    difference d_p = ‖fine − coarse‖_F. The pieces of T all end when Σ 4^-L d_p over T (with the
    pieces ended before) is ≤ tol_T = rtol ‖Q̄_T‖_F + atol; otherwise a piece ends when d_p ≤ tol_T
    (its share 4^-L of the tolerance) and the others are split. An ended piece contributes its fine
    average, and its 4^-L d_p to the bound: the bound is the last difference, which for a smooth
    field overestimates the fine rule's error (that shrinks ~64× per level). Work per level is
    capped (MIN_BUDGET); at `max_depth`, or past the cap, pieces end as they are and the bound
    carries what is left."""
    M = len(A)
    total, err = np.zeros((M, 3)), np.zeros(M)
    owner = np.arange(M)
    coarse = rule_averages(evaluate, A, B, C)
    budget = max(4 * M, MIN_BUDGET)
    for level in range(max_depth + 1):
        kids = _children(A, B, C)
        kid_avg = [rule_averages(evaluate, *kid) for kid in kids]
        fine = 0.25 * (kid_avg[0] + kid_avg[1] + kid_avg[2] + kid_avg[3])
        d = frobenius(fine - coarse)
        share = 0.25 ** level
        estimate = total + _sum_by(owner, share * fine, M)
        tol = rtol * frobenius(estimate) + atol
        settled = err + _sum_by(owner, share * d, M) <= tol
        end = settled[owner] | (d <= tol[owner])
        if level == max_depth:
            end[:] = True
        split = np.flatnonzero(~end)
        if 4 * len(split) > budget:                       # the worst pieces first
            keep = split[np.argpartition(-d[split], budget // 4)[:budget // 4]]
            end[:] = True
            end[keep] = False
            split = np.flatnonzero(~end)
        total += _sum_by(owner[end], share * fine[end], M)
        err += _sum_by(owner[end], share * d[end], M)
        if len(split) == 0:
            break
        A = np.concatenate([kid[0][split] for kid in kids])
        B = np.concatenate([kid[1][split] for kid in kids])
        C = np.concatenate([kid[2][split] for kid in kids])
        coarse = np.concatenate([avg[split] for avg in kid_avg])
        owner = np.tile(owner[split], 4)
    return total, err


GAUSS_BOX_POINTS = 4
"""Gauss–Legendre points per axis of `gauss_box_means` (degree 7 in each variable). An even count
has no node at the square's centre, where a field singular at a vertex (FVCA5 test 5's rotation
centre) would otherwise be evaluated."""


def gauss_box_means(evaluate: Evaluate, P: Array, half_width: Array,
                    n: int = GAUSS_BOX_POINTS) -> Array:
    """Mean of Q over the square [x ± h] × [y ± h] around each point P (k, 2), h = half_width (k,):
    the tensor-product n × n Gauss–Legendre rule → components (k, 3)."""
    t, w = np.polynomial.legendre.leggauss(n)
    k = len(P)
    out = np.empty((k, 3))
    step = max(1, CHUNK * 7 // (n * n))
    for s in range(0, k, step):
        p, h = P[s:s + step], half_width[s:s + step]
        X = p[:, None, None, 0] + h[:, None, None] * t[None, :, None]
        Y = p[:, None, None, 1] + h[:, None, None] * t[None, None, :]
        X, Y = np.broadcast_arrays(X, Y)
        q = evaluate(np.stack([X, Y], axis=-1).reshape(-1, 2)).reshape(len(p), n, n, 3)
        out[s:s + step] = np.einsum("i,j,kijc->kc", w, w, q) / 4.0
    return out


# --------------------------------------------------------------------------- rasters

@dataclass(frozen=True)
class Raster:
    """Cells with edges x (nx+1,), y (ny+1,) and a constant tensor per cell q (ny, nx, 3), with the
    cumulative tables of the exact integrals (row j between y[j] and y[j+1], column i between
    x[i] and x[i+1]; w, h the cell widths and heights):

    - row[j, i] = Σ_{i' < i} q[j, i'] w[i']          (ny, nx+1, 3): G at x[i] in row j;
    - row_abs   the same of |q|                      (ny, nx+1, 3): bounds |G| and its round-off;
    - col[j, i] = Σ_{j' < j} q[j', i] h[j']          (ny+1, nx, 3);
    - sat[j, i] = Σ_{j' < j, i' < i} q[j', i'] w h   (ny+1, nx+1, 3): the summed-area table.
    """

    x: Array
    y: Array
    q: Array
    row: Array
    row_abs: Array
    col: Array
    sat: Array

    @classmethod
    def build(cls, x: Array, y: Array, q: Array) -> "Raster":
        """The tables of cells q (ny, nx, 3) on edges x, y."""
        w, h = np.diff(x), np.diff(y)
        ny, nx = q.shape[:2]
        row = np.zeros((ny, nx + 1, 3))
        np.cumsum(q * w[None, :, None], axis=1, out=row[:, 1:])
        row_abs = np.zeros((ny, nx + 1, 3))
        np.cumsum(np.abs(q) * w[None, :, None], axis=1, out=row_abs[:, 1:])
        col = np.zeros((ny + 1, nx, 3))
        np.cumsum(q * h[:, None, None], axis=0, out=col[1:])
        sat = np.zeros((ny + 1, nx + 1, 3))
        np.cumsum(row[:, 1:] * h[:, None, None], axis=0, out=sat[1:, 1:])
        return cls(x, y, q, row, row_abs, col, sat)

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx): rows × columns of cells."""
        return self.q.shape[0], self.q.shape[1]

    def cell_of(self, X: Array, Y: Array) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """(row j, column i) of the cell holding each point (inside the raster; a point on a cell
        line takes the cell above or to the right of it, the last row or column at the far edge)."""
        ny, nx = self.shape
        i = np.clip(np.searchsorted(self.x, X, side="right") - 1, 0, nx - 1)
        j = np.clip(np.searchsorted(self.y, Y, side="right") - 1, 0, ny - 1)
        return j, i

    def primitive(self, X: Array, Y: Array) -> Array:
        """F(X, Y) = ∫_{x0}^{X} ∫_{y0}^{Y} Q, bilinear in each cell, for points inside → (k, 3):
        full cells below-left, the partial column and row, and the corner piece."""
        j, i = self.cell_of(X, Y)
        u, v = (X - self.x[i])[:, None], (Y - self.y[j])[:, None]
        return self.sat[j, i] + v * self.row[j, i] + u * self.col[j, i] + u * v * self.q[j, i]


def raster_edge_integrals(R: Raster, P0: Array, P1: Array) -> tuple[Array, Array]:
    """∫_e G dy along each segment e = P0 → P1 (E, 2) inside the raster → (E, 3), with
    Σ |G|·|dy| over its pieces (E,) (an upper bound of |G|, for the round-off bound).

    The segment is cut at its crossings with the grid lines x = x_i and y = y_j (parameters t in
    (0, 1)); each piece lies in one cell, where G(x, y) = row[j, i] + q[j, i](x − x_i) is linear,
    so G at the piece's midpoint times the piece's dy is its exact integral. Horizontal segments
    have dy = 0 and contribute nothing."""
    E = len(P0)
    out, bound = np.zeros((E, 3)), np.zeros(E)
    d = P1 - P0
    live = np.flatnonzero(d[:, 1] != 0)
    if len(live) == 0:
        return out, bound
    p0, dd = P0[live], d[live]
    x, y = R.x, R.y
    lo, hi = np.minimum(p0, p0 + dd), np.maximum(p0, p0 + dd)
    ax, bx = np.searchsorted(x, lo[:, 0], side="right"), np.searchsorted(x, hi[:, 0], side="left")
    ay, by = np.searchsorted(y, lo[:, 1], side="right"), np.searchsorted(y, hi[:, 1], side="left")
    nxc, nyc = np.maximum(bx - ax, 0), np.maximum(by - ay, 0)
    counts = nxc + nyc + 2                           # t = 0, the crossings, t = 1
    n = len(live)
    edge = np.repeat(np.arange(n), counts)
    start = np.cumsum(counts) - counts
    k = np.arange(len(edge)) - start[edge]           # slot within the segment
    t = np.empty(len(edge))
    first, last = k == 0, k == counts[edge] - 1
    isx = ~first & (k <= nxc[edge])
    isy = ~first & ~last & ~isx
    t[first], t[last] = 0.0, 1.0
    e = edge[isx]
    t[isx] = (x[ax[e] + k[isx] - 1] - p0[e, 0]) / dd[e, 0]
    e = edge[isy]
    t[isy] = (y[ay[e] + k[isy] - 1 - nxc[e]] - p0[e, 1]) / dd[e, 1]
    np.clip(t, 0.0, 1.0, out=t)
    order = np.lexsort((t, edge))
    t, edge = t[order], edge[order]
    piece = np.flatnonzero(edge[1:] == edge[:-1])    # consecutive slots of one segment
    e = edge[piece]
    ta, tb = t[piece], t[piece + 1]
    tm = 0.5 * (ta + tb)
    mx, my = p0[e, 0] + tm * dd[e, 0], p0[e, 1] + tm * dd[e, 1]
    dy = (tb - ta) * dd[e, 1]
    j, i = R.cell_of(mx, my)
    u = (mx - x[i])[:, None]
    G = R.row[j, i] + R.q[j, i] * u
    G_abs = R.row_abs[j, i] + np.abs(R.q[j, i]) * np.abs(u)
    out[live] = _sum_by(e, G * dy[:, None], n)
    bound[live] = _sum_by(e, frobenius(G_abs) * np.abs(dy), n)
    return out, bound


def raster_means(R: Raster, points: Array, triangles: NDArray[np.intp]) -> tuple[Array, Array]:
    """Exact area-weighted means of the raster's cells over each triangle (inside the raster) →
    components (M, 3), and a bound of their round-off (M,) (Frobenius norm).

    Q̄_T = (1/|T|) ∮_∂T G dy (Green's theorem with ∂G/∂x = Q), the boundary in the triangle's own
    vertex order and |T| its signed area, so either orientation gives the mean. Each edge shared
    by two triangles is integrated once. The round-off bound is (nx + 8) ε Σ |G| |dy| / |T|:
    G is a cumulative sum of up to nx terms, and ∮ G dy cancels a constant part of G, so the
    error grows with the raster's width over the triangle's size."""
    M = len(triangles)
    a, b = triangles[:, [0, 1, 2]].ravel(), triangles[:, [1, 2, 0]].ravel()
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo.astype(np.int64) * len(points) + hi
    uniq, inv = np.unique(key, return_inverse=True)
    u0, u1 = uniq // len(points), uniq % len(points)
    I, bnd = raster_edge_integrals(R, points[u0], points[u1])
    sign = np.where(a < b, 1.0, -1.0)
    inv = inv.reshape(-1)
    integral = (I[inv] * sign[:, None]).reshape(M, 3, 3).sum(axis=1)
    bound = bnd[inv].reshape(M, 3).sum(axis=1)
    A, B, C = points[triangles[:, 0]], points[triangles[:, 1]], points[triangles[:, 2]]
    area = 0.5 * ((B[:, 0] - A[:, 0]) * (C[:, 1] - A[:, 1]) - (B[:, 1] - A[:, 1]) * (C[:, 0] - A[:, 0]))
    flat = np.flatnonzero(area == 0)
    if len(flat):
        t = flat[0]
        raise QmeshError(f"triangle {t} (vertices {points[triangles[t]].tolist()}) has zero area: "
                         "its mean over raster cells is not defined")
    eps = np.finfo(float).eps
    return integral / area[:, None], (R.shape[1] + 8) * eps * bound / np.abs(area)


def raster_box_means(R: Raster, P: Array, half_width: Array) -> Array:
    """Exact mean of the cells over each square [x ± h] × [y ± h] clipped to the raster →
    components (k, 3): F(b, d) − F(a, d) − F(b, c) + F(a, c) over the clipped area, F the
    summed-area primitive (`Raster.primitive`). The caller checks the squares meet the raster."""
    x0, x1 = np.clip(P[:, 0] - half_width, R.x[0], R.x[-1]), np.clip(P[:, 0] + half_width, R.x[0], R.x[-1])
    y0, y1 = np.clip(P[:, 1] - half_width, R.y[0], R.y[-1]), np.clip(P[:, 1] + half_width, R.y[0], R.y[-1])
    F = R.primitive
    integral = F(x1, y1) - F(x0, y1) - F(x1, y0) + F(x0, y0)
    return integral / ((x1 - x0) * (y1 - y0))[:, None]
