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
from qmesh.geometry.portable import gauss_legendre

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
CHUNK = 1 << 13
"""Pieces evaluated at once (7 points each): bounds the memory of one evaluation (a few MB: larger
batches gain nothing per point)."""

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
    """‖Q‖_F of symmetric tensors given as components (..., 3); ∞ past the floats (a field that
    large is refused where it is checked, not warned about here)."""
    with np.errstate(over="ignore"):
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

def _rule_points(a: Array, b: Array, c: Array) -> Array:
    """The rule's 7 points on each triangle (a, b, c) (k, 2) → (7 k, 2), triangle by triangle:
    w0 a + w1 b + w2 c, one rule point at a time over all the triangles."""
    P = np.empty((len(a), 7, 2))
    for r, (w0, w1, w2) in enumerate(RULE_BARY):
        P[:, r] = w0 * a + w1 * b + w2 * c
    return P.reshape(-1, 2)


def rule_averages(evaluate: Evaluate, A: Array, B: Array, C: Array) -> Array:
    """The 7-point degree-5 rule's average of Q over each triangle (A, B, C) → components (k, 3),
    the field evaluated CHUNK triangles at a time (each triangle's average does not depend on the
    chunks: the same 7 values summed in the same order)."""
    k = len(A)
    out = np.empty((k, 3))
    for s in range(0, k, CHUNK):
        a, b, c = A[s:s + CHUNK], B[s:s + CHUNK], C[s:s + CHUNK]
        q = evaluate(_rule_points(a, b, c)).reshape(len(a), 7, 3)
        out[s:s + CHUNK] = np.einsum("r,krc->kc", RULE_WEIGHTS, q)
    return out


def _children(A: Array, B: Array, C: Array) -> tuple[Array, Array, Array]:
    """The 4 midpoint children of each of k triangles, each a quarter of its area, same
    orientation, stacked child by child: (4k, 2) corners, child c of triangle t in row c k + t
    (children 0, 1, 2 at corners A, B, C, child 3 the middle one)."""
    ab, bc, ca = 0.5 * (A + B), 0.5 * (B + C), 0.5 * (C + A)
    return (np.concatenate([A, ab, ca, ab]), np.concatenate([ab, B, bc, bc]),
            np.concatenate([ca, bc, C, ca]))


def _fine(kid_avg: Array) -> Array:
    """The fine average of each of k triangles: the mean of its 4 children's rows (4k, 3)
    stacked as `_children`'s, summed in the children's order."""
    k = len(kid_avg) // 4
    return 0.25 * (kid_avg[:k] + kid_avg[k:2 * k] + kid_avg[2 * k:3 * k] + kid_avg[3 * k:])


Bound = Callable[[Array, Array, Array], Array]
"""A rigorous bound of a piece's quadrature error: corners (k, 2) each → (k,) in the Frobenius
norm, ∞ where nothing bounds it (`enclosure_bound`)."""

BOUND_RTOL = 1e-2
"""With a rigorous bound (text formulas): pieces are also split until their proven bound is
within this share of ‖Q̄_T‖ (the default of `bound_rtol` for a caller of
`TensorField.means_with_error`), or `BOUND_DEPTH` is reached. What the enclosures prove shrinks
as the fourth power of a piece's size (the third-order remainder), far slower than the rule's
own error for a smooth field (the sixth power), so the repair does not prove every mean to one
tolerance: it proves each to what its edges need (`fields.certify`), most with the enclosures of
its 4 children alone."""
BOUND_DEPTH = 8
"""At most this many levels of subdivision for the bound (those of the rule, `MAX_DEPTH`): a jump
line crossing a triangle (a curved one: a straight one is cut along, `sides`) keeps about 2^L of
its 4^L pieces at level L, so what the line's pieces leave unresolved falls 2× a level (1/256 of the triangle at 8; each level more doubles the work
along the line, which the repair pays on every triangle it tries there). A piece still unbounded
there touches a point where the text divides by zero (FVCA5 test 5's rotation centre, where Q has
no limit but stays bounded): it adds the rule's estimate instead, the only part of a text's bound
that rests on samples, a 4^-8 share of its triangle."""
NEGLIGIBLE = 1e-3
"""An unresolved piece whose proven share 4^-L e_p is below this share of its triangle's bound
tolerance ends there, adding it (the pieces around a point where Q has no limit look the same at
every level: they would otherwise all go to BOUND_DEPTH)."""


FIRST = 0.75       # ½ (½ + 1): the first-order bound's factor (`enclosure_bound`)
SECOND = 0.3125    # ¼ (¼ + 1): the second-order one's (sup g − inf g gives 1 and ½)
THIRD = 5.0 / 48.0  # (1/12) (¼ + 1): the third-order one's
REACH_ULPS = 2.0 ** -49   # ≥ 3δ, δ ≤ 3·2^-53 |x| the rounded centroid's distance from the
                          # exact one: added to each reach r_i, δ for r_i about the exact one,
                          # 2δ more for the moment about c (r0²/4 + δ² ≤ (r0 + 2δ)²/4)
SUM_ROUND = 1e-10
"""Relative widening of a sum of proven bounds (at most 4^BOUND_DEPTH · 4 terms a triangle, each
sum's round-off below n·2^-53 of it): the sum stays an upper bound whatever the order."""


def enclosure_bound(forms: list[tuple]) -> Bound:
    """The rigorous error bound of the 7-point rule and its 4 children on a piece, from interval
    enclosures (`intervals.evaluate`) of the components' checked forms and of their first,
    second and third derivatives over the piece's box.

    The rule and its children have positive weights and integrate polynomials of degree ≤ 5
    exactly, so for any polynomial p of degree ≤ 3 the error of the mean of f is that of
    g = f − p: |error| ≤ sup g − inf g (both the exact mean and the rule's lie in g's range),
    and |error| ≤ mean_T |g| + max_T |g| (the rule's points lie in T). Per component, the least
    of four such bounds, r_i = max_T |x_i − c_i| about the centroid c, whose mean over T is at
    most r_i / 2 (the second moment of a triangle about its centroid is (1/12) Σ_k d_k d_kᵀ over
    its corners' offsets d_k, so mean (x_i − c_i)² ≤ r_i² / 4; Cauchy–Schwarz for the rest:
    mean |d_i d_j| ≤ r_i r_j / 4, mean |d_i d_j d_k| ≤ r_i r_j r_k / 4):
    - p = 0: the width of f's enclosure (all a jump leaves);
    - p the tangent plane at c with the midpoint slope of the gradient's enclosure G (the
      mean-value theorem on the segment c → x, inside the box): |g(x)| ≤ ½ Σ_i w(G_i) |x_i − c_i|,
      so |error| ≤ ½ Σ_i w(G_i) (r_i / 2 + r_i) = FIRST Σ_i w(G_i) r_i;
    - p the second-order Taylor polynomial at c with the midpoint Hessian of its enclosure H
      (Taylor's theorem with Lagrange's remainder at a point of that segment): |g(x)| ≤
      ¼ Σ_ij w(H_ij) |x_i − c_i| |x_j − c_j|, so |error| ≤ ¼ Σ_ij w(H_ij) (r_i r_j / 4 + r_i r_j)
      = SECOND Σ_ij w(H_ij) r_i r_j;
    - p the third-order Taylor polynomial at c with the midpoint third derivatives of their
      enclosure D (the same theorem one order up, its remainder (1/6) D³f(ξ)[d, d, d]):
      |g(x)| ≤ (1/12) Σ_ijk w(D_ijk) |d_i d_j d_k| over the 8 ordered triples (∂xxy thrice), so
      |error| ≤ (1/12) Σ_ijk w(D_ijk) (r_i r_j r_k / 4 + r_i r_j r_k)
      = THIRD Σ_ijk w(D_ijk) r_i r_j r_k. Its remainder falls as h⁴ with a piece's size h where the second order's falls as h³:
      on the spiral and plasma fields of benchmarks/bench_fields.py the proof needs about a
      fifth of the pieces;
    plus a relative 1e-13 for the rule's own round-off, combined in the Frobenius norm and
    widened by SUM_ROUND; ∞ where every enclosure is unbounded or not finite. The expansion
    point c is the rounded centroid clipped into the box (so every segment c → x lies in it),
    each r_i widened by REACH_ULPS of the corners' magnitude for its distance from the exact
    centroid."""
    from qmesh.conductivity import intervals   # imported here: only text fields need it

    def bound(A: Array, B: Array, C: Array) -> Array:
        lo, hi = np.minimum(np.minimum(A, B), C), np.maximum(np.maximum(A, B), C)
        c = np.clip((A + B + C) / 3.0, lo, hi)     # in the box: so is every segment c → x
        reach = np.maximum(np.maximum(np.abs(A - c), np.abs(B - c)), np.abs(C - c))   # (k, 2)
        far = np.maximum(np.maximum(np.abs(A), np.abs(B)), np.abs(C))
        rx, ry = (reach * (1.0 + 1e-15) + REACH_ULPS * far).T
        X, Y = (lo[:, 0], hi[:, 0]), (lo[:, 1], hi[:, 1])
        e = np.zeros((len(A), 3))
        with np.errstate(all="ignore"):
            for i, node in enumerate(intervals.evaluate_all(forms, X, Y)):
                (vl, vh), gx, gy, hxx, hxy, hyy, txxx, txxy, txyy, tyyy = node
                zeroth = vh - vl
                first = FIRST * ((gx[1] - gx[0]) * rx + (gy[1] - gy[0]) * ry)
                second = SECOND * ((hxx[1] - hxx[0]) * rx * rx + 2.0 * (hxy[1] - hxy[0]) * rx * ry
                                   + (hyy[1] - hyy[0]) * ry * ry)
                third = THIRD * ((txxx[1] - txxx[0]) * rx * rx * rx
                                 + 3.0 * (txxy[1] - txxy[0]) * rx * rx * ry
                                 + 3.0 * (txyy[1] - txyy[0]) * rx * ry * ry
                                 + (tyyy[1] - tyyy[0]) * ry * ry * ry)
                least = zeroth
                for b in (first, second, third):
                    least = np.minimum(least, np.where(np.isfinite(b), b, np.inf))
                size = np.maximum(np.abs(vl), np.abs(vh))
                e[:, i] = least + 1e-13 * size
            out = frobenius(e) * (1.0 + SUM_ROUND)
        return np.where(np.isfinite(out), out, np.inf)

    return bound


def _bound_chunked(bound: Bound, A: Array, B: Array, C: Array) -> Array:
    """`bound` of pieces (k, 2) each, CHUNK pieces at a time: an enclosure takes a few hundred
    array operations, and on arrays of a few MB each they run from memory instead of the cache
    (2.4× slower at 4e5 pieces than in chunks of CHUNK; each piece's bound is its own)."""
    if len(A) <= CHUNK:
        return bound(A, B, C)
    return np.concatenate([bound(A[s:s + CHUNK], B[s:s + CHUNK], C[s:s + CHUNK])
                           for s in range(0, len(A), CHUNK)])


def children_bound(bound: Bound, KA: Array, KB: Array, KC: Array) -> Array:
    """The proven error of the fine average of k pieces, from their 4 midpoint children stacked
    as `_children` stacks them (4k, 2): the fine average is the mean of the rule on each child,
    a rule with positive weights, exact for degree 3, whose points lie in the child, so its error
    is at most the mean of the children's `bound`s (∞ where one is). A piece's own box is about
    twice a child's, so this is about 8 times tighter than `bound` of the piece for the cost of 4
    enclosures, and it asks for no more samples than the fine average already took."""
    k = len(KA) // 4
    kids = _bound_chunked(bound, KA, KB, KC)
    with np.errstate(all="ignore"):
        out = 0.25 * (kids[:k] + kids[k:2 * k] + kids[2 * k:3 * k] + kids[3 * k:])
        out *= 1.0 + SUM_ROUND
    return np.where(np.isnan(out), np.inf, out)


def longest_edges(A: Array, B: Array, C: Array) -> Array:
    """The longest edge of each triangle (k,)."""
    return np.maximum(np.maximum(np.hypot(*(B - A).T), np.hypot(*(C - B).T)), np.hypot(*(A - C).T))


def adaptive_means(evaluate: Evaluate, A: Array, B: Array, C: Array, rtol: float = RTOL,
                   atol: float = ATOL, max_depth: int = MAX_DEPTH, bound: Bound | None = None,
                   bound_rtol: float | Array = BOUND_RTOL, resolution: float | None = None,
                   spare: bool = True) -> tuple[Array, Array]:
    """Element means of a field over triangles (A, B, C) (each (M, 2)): components (M, 3) and an
    error bound (M,) in the Frobenius norm.

    Level by level, every live piece p (a 4^-L share of its triangle T) has its coarse average
    (the 7-point rule on p) and its fine one (the rule on its 4 midpoint children) with
    difference d_p = ‖fine − coarse‖_F. The pieces of T all end when Σ 4^-L d_p over T (with the
    pieces ended before) is ≤ tol_T = rtol ‖Q̄_T‖_F + atol; otherwise a piece ends when d_p ≤ tol_T
    (its share 4^-L of the tolerance) and the others are split. An ended piece contributes its fine
    average, and its 4^-L d_p to the bound: the bound is the last difference, which for a smooth
    field overestimates the fine rule's error (that shrinks ~64× per level) but is blind to what
    no sample sees (a jump no sample straddles, a bump between samples). Work per level is
    capped (MIN_BUDGET); at `max_depth`, or past the cap, pieces end as they are and the bound
    carries what is left.

    With `bound` (a text formula: `enclosure_bound`), each piece's e_p, the mean of its 4
    children's bound(child) (`children_bound`), is a proven bound of the error of any rule on it
    made of rules with positive weights, exact for degree 3, on each child: a piece ends only
    when, beside the rule's test, it is resolved — e_p ≤ btol_T = bound_rtol ‖Q̄_T‖_F + atol
    (`bound_rtol` a number or one per triangle), or its triangle's bound so far with every live
    piece's 4^-L e_p is ≤ btol_T (then all of them are), or (`spare`) where T's live pieces'
    bounds fell SHRINK-fold at least since their parents', it is not among the pieces of the
    largest 4^-L e_p that, split and counted on to fall SHRINK-fold, bring T within btol_T
    (`_spared`) — or at BOUND_DEPTH; a triangle that spared such a piece and still ends above
    btol_T is computed again without sparing (every piece above btol_T split). A piece adds its
    4^-L e_p to the bound once: when it is resolved (its pieces are then resolved without a look:
    whatever rules the quadrature ends with on them make one such rule on each child, within its
    e_p), or when it ends unresolved (a jump crosses it); so the bound is proven, and a jump or a
    bump no sample sees is in it. The one exception: a piece still unbounded at BOUND_DEPTH (the
    text divides by zero at a point of it) adds the rule's estimate d_p.

    With `resolution` h (a callable, whose values between samples nothing bounds), a piece is
    split while its children's longest edge exceeds h, up to BOUND_DEPTH and outside the work
    cap.

    The field is evaluated in as few calls as CHUNK allows: the triangles and their children
    together, then all the children of a level's split pieces at once (each piece's rule sums
    its own 7 points in the same order whatever the batch, so the batching does not change a bit
    of the result)."""
    M = len(A)
    A0, B0, C0 = A, B, C
    spared = np.zeros(M, bool)            # triangles that spared a piece above the tolerance
    total, err, rule_err = np.zeros((M, 3)), np.zeros(M), np.zeros(M)
    owner = np.arange(M)
    KA, KB, KC = _children(A, B, C)
    both = rule_averages(evaluate, np.concatenate([A, KA]), np.concatenate([B, KB]),
                         np.concatenate([C, KC]))
    coarse, kid_avg = both[:M], both[M:]
    known = np.zeros(M, bool)
    last = np.zeros(M)                    # the bound of each triangle's pieces split last
    budget = max(4 * M, MIN_BUDGET)
    deepest = max_depth if bound is None and resolution is None else max(max_depth, BOUND_DEPTH)
    for level in range(deepest + 1):
        if level:
            KA, KB, KC = _children(A, B, C)
            kid_avg = rule_averages(evaluate, KA, KB, KC)
        k = len(A)
        fine = _fine(kid_avg)
        d = frobenius(fine - coarse)
        share = 0.25 ** level
        estimate = total + _sum_by(owner, share * fine, M)
        size = frobenius(estimate)
        tol = rtol * size + atol
        end = (rule_err + _sum_by(owner, share * d, M) <= tol)[owner] | (d <= tol[owner])
        if level >= max_depth:
            end[:] = True
        forced = np.zeros(k, bool)
        if bound is not None:
            e = np.zeros(k)                   # a piece of a resolved one: resolved (see above)
            ask = np.flatnonzero(~known)
            if len(ask):                      # its fine average's: its children's enclosures
                rows = (np.arange(4)[:, None] * k + ask).ravel()
                e[ask] = children_bound(bound, KA[rows], KB[rows], KC[rows])
            if level >= BOUND_DEPTH:          # unbounded this deep: a point the text divides by 0
                e = np.where(np.isfinite(e), e, d)
            btol = bound_rtol * size + atol
            part = np.where(known, 0.0, share * e)
            now = _sum_by(owner, part, M)
            so_far = err + now
            settled = so_far <= btol
            # a triangle whose pieces' bounds fell SHRINK-fold at least where they were last
            # split (a smooth text there, not a point where it has no limit) splits only the
            # pieces it needs (`_spared`)
            smooth = np.isfinite(now) & (now * SHRINK <= last) & spare
            over = np.where(smooth, so_far - btol, 0.0)
            kept = _spared(owner, part, over) & ~known & (e > btol[owner])
            spared[owner[kept]] = True
            resolved = known | (e <= btol[owner]) | settled[owner] | kept
            end &= resolved | (share * e <= NEGLIGIBLE * btol[owner]) | (level >= BOUND_DEPTH)
        if resolution is not None:
            forced = (0.5 * longest_edges(A, B, C) > resolution) & (level < BOUND_DEPTH)
            end &= ~forced
        if level == deepest:
            end[:] = True
            forced[:] = False
        split = np.flatnonzero(~end & ~forced)
        if 4 * len(split) > budget:                       # the worst pieces first
            worst = -d[split] if bound is None else -np.minimum(e[split] / btol[owner[split]], 1e300)
            keep = split[np.argpartition(worst, budget // 4)[:budget // 4]]
            end[split] = True
            end[keep] = False
        split = np.flatnonzero(~end)
        total += _sum_by(owner[end], share * fine[end], M)
        rule_err += _sum_by(owner[end], share * d[end], M)
        if bound is not None:             # proven once a piece: where resolved, or where it ends
            said = ~known & (resolved | end)
            err += _sum_by(owner[said], share * e[said], M)
            last = _sum_by(owner[split], np.where(resolved[split], 0.0, share * e[split]), M)
        if len(split) == 0:
            break
        rows = (np.arange(4)[:, None] * k + split).ravel()   # the split pieces' children
        A, B, C, coarse = KA[rows], KB[rows], KC[rows], kid_avg[rows]
        owner = np.tile(owner[split], 4)
        if bound is not None:
            known = np.tile(resolved[split], 4)
    if bound is None:
        return total, rule_err
    err *= 1.0 + SUM_ROUND
    # a triangle whose split pieces fell less than counted on (beside a point where the text
    # has no limit) ends above its tolerance: computed again splitting every piece above it
    late = np.flatnonzero(spared & (err > bound_rtol * frobenius(total) + atol))
    if len(late):
        asked: float | Array = (bound_rtol if isinstance(bound_rtol, (int, float)) else
                                np.asarray(bound_rtol, dtype=float)[late])
        total[late], err[late] = adaptive_means(
            evaluate, A0[late], B0[late], C0[late], rtol=rtol, atol=atol, max_depth=max_depth,
            bound=bound, bound_rtol=asked, resolution=resolution, spare=False)
    return total, err


SHRINK = 8.0
"""What splitting a piece is counted on to divide its share of a triangle's bound by (`_spared`):
a piece's children's enclosures bound it about 16 times tighter (the third-order remainder falls
as the fourth power of the size); half of that, so that the pieces split are enough as a rule."""


def _spared(owner: NDArray[np.intp], part: Array, over: Array) -> NDArray[np.bool_]:
    """The pieces of each triangle whose bound `part` (a share of it each; 0 for those already
    said) can stay as it is: its pieces of the largest parts are split, one after the other, until
    splitting them lowers the triangle's bound by its excess `over` the tolerance (each split
    piece's part counted on to fall SHRINK-fold), and the others spared. Against splitting every
    piece above the tolerance, the proof of the spiral's meshes (benchmarks/bench_fields.py)
    encloses a fifth fewer pieces of its refined triangles at 2 000 vertices and an eighth fewer
    at 20 000."""
    spare = np.zeros(len(part), bool)
    late = np.flatnonzero(over[owner] > 0)
    if not len(late):
        return spare
    o, p = owner[late], part[late]
    order = np.lexsort((-p, o))                    # by triangle, the largest part first
    o, p = o[order], p[order]
    first = np.r_[True, o[1:] != o[:-1]]
    before = np.cumsum(p) - p                      # the parts ahead of each, in its triangle
    before -= before[first][np.cumsum(first) - 1]
    needed = before * (1.0 - 1.0 / SHRINK) < over[o]
    spare[late[order]] = ~needed
    return spare


GAUSS_BOX_POINTS = 4
"""Gauss–Legendre points per axis of `gauss_box_means` (degree 7 in each variable). An even count
has no node at the square's centre, where a field singular at a vertex (FVCA5 test 5's rotation
centre) would otherwise be evaluated."""


def gauss_box_means(evaluate: Evaluate, P: Array, half_width: Array,
                    n: int = GAUSS_BOX_POINTS) -> Array:
    """Mean of Q over the square [x ± h] × [y ± h] around each point P (k, 2), h = half_width (k,):
    the tensor-product n × n Gauss–Legendre rule → components (k, 3)."""
    t, w = gauss_legendre(n)
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
    x[i] and x[i+1]; w, h the cell widths and heights). The edges are stored relative to the
    raster's lower-left corner `origin` (x[0] = y[0] = 0), and every method shifts the points it
    is given the same way: round-off then scales with the raster's size, not with its distance
    from (0, 0).

    - row[j, i] = Σ_{i' < i} q[j, i'] w[i']          (ny, nx+1, 3): G at x[i] in row j;
    - row_abs[j] = ‖Σ_i |q[j, i]| w[i]‖_F           (ny,): bounds |G| in row j, for round-off;
    - col[j, i] = Σ_{j' < j} q[j', i] h[j']          (ny+1, nx, 3);
    - sat[j, i] = Σ_{j' < j, i' < i} q[j', i'] w h   (ny+1, nx+1, 3): the summed-area table.
    """

    origin: Array
    x: Array
    y: Array
    q: Array
    row: Array
    row_abs: Array
    col: Array
    sat: Array

    @classmethod
    def build(cls, x: Array, y: Array, q: Array, rows: int | None = None) -> "Raster":
        """The tables of cells q (ny, nx, 3) on edges x, y (user coordinates), built `rows` rows
        at a time (default: about TABLE_CELLS cells; `_Tables`)."""
        tables = _Tables(x, y, q.shape[:2])
        for j0, j1 in tables.bands(rows):
            tables.add(j0, q[j0:j1])
        return tables.raster()

    @classmethod
    def from_principal(cls, x: Array, y: Array, k1: Array, k2: Array, angle_deg: Array,
                       rows: int | None = None) -> "Raster":
        """Cells of principal values k1, k2 (ny, nx) along and across `angle_deg` degrees
        counter-clockwise, Q = R diag(k1, k2) Rᵀ: each band of rows' tensors made and entered into
        the tables in turn, so only the tables and one band's temporaries are ever held."""
        tables = _Tables(x, y, np.shape(k1))
        for j0, j1 in tables.bands(rows):
            t = np.deg2rad(angle_deg[j0:j1])
            a, b = k1[j0:j1], k2[j0:j1]
            c, s = np.cos(t), np.sin(t)
            q = np.stack([a * c * c + b * s * s, (a - b) * c * s, a * s * s + b * c * c], axis=-1)
            tables.add(j0, q)
        return tables.raster()

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx): rows × columns of cells."""
        return self.q.shape[0], self.q.shape[1]

    def cell_of(self, X: Array, Y: Array) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """(row j, column i) of the cell holding each point (inside the raster; a point on a cell
        line takes the cell above or to the right of it, the last row or column at the far edge)."""
        ny, nx = self.shape
        i = np.clip(np.searchsorted(self.x, X - self.origin[0], side="right") - 1, 0, nx - 1)
        j = np.clip(np.searchsorted(self.y, Y - self.origin[1], side="right") - 1, 0, ny - 1)
        return j, i

    def primitive(self, X: Array, Y: Array) -> Array:
        """F(X, Y) = ∫_{x0}^{X} ∫_{y0}^{Y} Q, bilinear in each cell, for points inside → (k, 3):
        full cells below-left, the partial column and row, and the corner piece."""
        j, i = self.cell_of(X, Y)
        u = (X - self.origin[0] - self.x[i])[:, None]
        v = (Y - self.origin[1] - self.y[j])[:, None]
        return self.sat[j, i] + v * self.row[j, i] + u * self.col[j, i] + u * v * self.q[j, i]


class _Tables:
    """The Raster's tables filled one band of rows at a time, each band with the formulas of the
    whole (cumulative sums along a row stay in the row; down the columns each band's sums start
    from the last row of the band before, added first: the same additions in the same order),
    so the result does not depend on the bands by a bit."""

    def __init__(self, x: Array, y: Array, shape: tuple[int, int]):
        self.origin = np.array([x[0], y[0]])
        self.x, self.y = x - x[0], y - y[0]
        self.w, self.h = np.diff(self.x), np.diff(self.y)
        ny, nx = shape
        self.q = np.empty((ny, nx, 3))
        self.row = np.zeros((ny, nx + 1, 3))
        self.row_abs = np.empty(ny)
        self.col = np.zeros((ny + 1, nx, 3))
        self.sat = np.zeros((ny + 1, nx + 1, 3))

    def bands(self, rows: int | None) -> list[tuple[int, int]]:
        ny, nx = self.q.shape[:2]
        step = max(1, rows if rows is not None else TABLE_CELLS // max(nx, 1))
        return [(j, min(j + step, ny)) for j in range(0, ny, step)]

    def add(self, j0: int, q: Array) -> None:
        """Rows j0 … j0 + len(q) of cells q (k, nx, 3) into the tables."""
        j1 = j0 + len(q)
        w, h = self.w[None, :, None], self.h[j0:j1, None, None]
        self.q[j0:j1] = q
        np.cumsum(q * w, axis=1, out=self.row[j0:j1, 1:])
        self.row_abs[j0:j1] = frobenius(np.sum(np.abs(q) * w, axis=1))
        for table, terms in ((self.col, q * h), (self.sat[:, 1:], self.row[j0:j1, 1:] * h)):
            run = np.concatenate([table[j0][None], terms])       # the sum so far, then the band
            np.cumsum(run, axis=0, out=run)
            table[j0 + 1:j1 + 1] = run[1:]

    def raster(self) -> Raster:
        return Raster(self.origin, self.x, self.y, self.q, self.row, self.row_abs, self.col,
                      self.sat)


TABLE_CELLS = 1 << 16
"""Cells per band of rows while the tables are built: a band's temporaries are a few MB."""
EDGE_PIECES = 1 << 16
"""Pieces (a segment's parts inside one cell) cut at once by `raster_edge_integrals`: whole
segments are taken while their pieces fit, so the memory is that of EDGE_PIECES pieces or of one
segment's (at most nx + ny + 1), not of all the edges' crossings at once."""


def _cut(s0: Array, s1: Array, lines: Array) -> tuple[NDArray[np.intp], NDArray[np.intp],
                                                        NDArray[np.intp], NDArray[np.intp]]:
    """Segments running from coordinate s0 to s1 (k,), cut at the grid `lines` strictly between
    them, in the order of travel: per piece (segment, the line it starts on or -1 at the
    segment's start, the line it ends on or -1 at its end, the cell between lines it lies in)."""
    lo, hi = np.minimum(s0, s1), np.maximum(s0, s1)
    a = np.searchsorted(lines, lo, side="right")      # lines[a - 1] <= lo < lines[a]
    b = np.searchsorted(lines, hi, side="left")       # lines[b - 1] < hi <= lines[b]
    n_cross = np.maximum(b - a, 0)
    seg = np.repeat(np.arange(len(s0)), n_cross + 1)
    k = np.arange(len(seg)) - np.repeat(np.cumsum(n_cross + 1) - (n_cross + 1), n_cross + 1)
    up, a, b, n_cross = s1[seg] >= s0[seg], a[seg], b[seg], n_cross[seg]
    cell = np.where(up, a - 1 + k, b - 1 - k)
    start = np.where(k == 0, -1, np.where(up, a + k - 1, b - k))
    end = np.where(k == n_cross, -1, np.where(up, a + k, b - 1 - k))
    return seg, start, end, np.clip(cell, 0, len(lines) - 2)


def raster_edge_integrals(R: Raster, P0: Array, P1: Array,
                          pieces: int = EDGE_PIECES) -> tuple[Array, Array]:
    """∫_e G dy along each segment e = P0 → P1 (E, 2) inside the raster → (E, 3), with a bound of
    its round-off (E,): runs of whole segments of about `pieces` pieces at a time (each segment's
    result its own: the same bits whatever the runs, `_edge_integrals`)."""
    E = len(P0)
    out, bound = np.zeros((E, 3)), np.zeros(E)
    if E == 0:
        return out, bound
    crossed = 1
    for c, lines in ((0, R.x + R.origin[0]), (1, R.y + R.origin[1])):
        lo, hi = np.minimum(P0[:, c], P1[:, c]), np.maximum(P0[:, c], P1[:, c])
        crossed = crossed + np.maximum(np.searchsorted(lines, hi) - np.searchsorted(lines, lo), 0)
    total = np.cumsum(crossed)
    start = 0
    while start < E:
        before = total[start - 1] if start else 0
        stop = max(int(np.searchsorted(total, before + pieces, side="right")), start + 1)
        out[start:stop], bound[start:stop] = _edge_integrals(R, P0[start:stop], P1[start:stop])
        start = stop
    return out, bound


def _edge_integrals(R: Raster, P0: Array, P1: Array) -> tuple[Array, Array]:
    """`raster_edge_integrals` of segments cut all at once.

    The segment is cut at the grid lines x = x_i it crosses (pieces in one column each), then
    each of those at the lines y = y_j (pieces in one cell each, the cell known from the
    order of the cuts, not searched). In cell (j, i), G(x, y) = row[j, i] + q[j, i](x − x_i) is
    linear along the piece, so G at the piece's midpoint times the piece's dy is its exact
    integral. Horizontal segments have dy = 0 and contribute nothing. No sorting: O(pieces).

    Round-off (coordinates relative to the raster's corner, W × H its size, g_j = ‖Σ_i |q| w‖
    of row j ≥ |G| there): G at a midpoint carries (nx + 4) ε g_j (a cumulative sum of up to nx
    terms) and 2 ε W ‖q‖ (the midpoint's x), times |dy|; a cut's y carries 2 ε H, which moves
    the two pieces meeting there by the difference of their G — ≤ ‖q‖ |dx| of each within a row
    (cuts on row lines are exact); a vertex shifted to the corner's coordinates moves by
    ε (W + H), which changes the integral by at most max ‖q‖ times the segment's length."""
    E = len(P0)
    P0, P1 = P0 - R.origin, P1 - R.origin
    out, bound = np.zeros((E, 3)), np.zeros(E)
    d = P1 - P0
    live = np.flatnonzero(d[:, 1] != 0)
    if len(live) == 0:
        return out, bound
    p0, dd = P0[live], d[live]
    x, y = R.x, R.y
    ny, nx = R.shape
    # 1. cut at the columns' lines: parameters t in [0, 1] along the segment
    e1, s1, f1, col = _cut(p0[:, 0], p0[:, 0] + dd[:, 0], x)
    with np.errstate(divide="ignore", invalid="ignore"):
        ta = np.where(s1 < 0, 0.0, (x[s1] - p0[e1, 0]) / dd[e1, 0])
        tb = np.where(f1 < 0, 1.0, (x[f1] - p0[e1, 0]) / dd[e1, 0])
    ya, yb = p0[e1, 1] + ta * dd[e1, 1], p0[e1, 1] + tb * dd[e1, 1]
    ya[s1 < 0] = p0[e1[s1 < 0], 1]
    yb[f1 < 0] = p0[e1[f1 < 0], 1] + dd[e1[f1 < 0], 1]
    # 2. cut each at the rows' lines: y at the ends exact where they are grid lines
    e2, s2, f2, row = _cut(ya, yb, y)
    y_a = np.where(s2 < 0, ya[e2], y[s2])
    y_b = np.where(f2 < 0, yb[e2], y[f2])
    e, i = e1[e2], col[e2]
    tm = (0.5 * (y_a + y_b) - p0[e, 1]) / dd[e, 1]   # dy ≠ 0 on every live segment
    mx = p0[e, 0] + tm * dd[e, 0]
    dy = y_b - y_a
    u = mx - x[i]
    G = R.row.reshape(-1, 3)[row * (nx + 1) + i] + R.q.reshape(-1, 3)[row * nx + i] * u[:, None]
    n = len(live)
    out[live] = _sum_by(e, G * dy[:, None], n)
    eps = np.finfo(float).eps
    qn = frobenius(R.q.reshape(-1, 3)[row * nx + i])
    dx = (y_b - y_a) / dd[e, 1] * dd[e, 0]
    per_piece = ((nx + 4) * R.row_abs[row] + 2 * x[-1] * qn) * np.abs(dy) + 2 * y[-1] * qn * np.abs(dx)
    starts = np.flatnonzero(np.r_[True, e[1:] != e[:-1]])   # e is sorted: every live segment has pieces
    q_max = np.maximum.reduceat(qn, starts)
    ends = 2 * (x[-1] + y[-1]) * q_max * (np.abs(dd[:, 0]) + np.abs(dd[:, 1]))
    bound[live] = eps * (_sum_by(e, per_piece, n) + ends)
    return out, bound


def raster_means(R: Raster, points: Array, triangles: NDArray[np.intp]) -> tuple[Array, Array]:
    """Exact area-weighted means of the raster's cells over each triangle (inside the raster) →
    components (M, 3), and a bound of their round-off (M,) (Frobenius norm).

    Q̄_T = (1/|T|) ∮_∂T G dy (Green's theorem with ∂G/∂x = Q), the boundary in the triangle's own
    vertex order and |T| its signed area, so either orientation gives the mean. Each edge shared
    by two triangles is integrated once. The round-off bound is that of the edges' integrals
    (`raster_edge_integrals`) over |T|: ∮ G dy cancels the large part of G that is constant
    along the boundary, so the error grows with the raster's size over the triangle's.
    Coordinates are taken relative to the raster's corner. MEAN_TRIANGLES triangles at a time
    (an edge two of them share, in two runs, is integrated in each, to the same bits): the
    memory is that of a run, not of the whole mesh's edges."""
    M = len(triangles)
    q, bound = np.empty((M, 3)), np.empty(M)
    for s in range(0, M, MEAN_TRIANGLES):
        part = slice(s, min(s + MEAN_TRIANGLES, M))
        q[part], bound[part] = _raster_means(R, points, triangles[part], s)
    return q, bound


MEAN_TRIANGLES = 1 << 16
"""Triangles whose raster means `raster_means` computes at once: their edges' temporaries are a
few tens of MB."""


def _raster_means(R: Raster, points: Array, triangles: NDArray[np.intp],
                  first: int) -> tuple[Array, Array]:
    """`raster_means` of one run of triangles, the first numbered `first` in the mesh."""
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
    A, B, C = (points[triangles[:, k]] - R.origin for k in range(3))
    area = 0.5 * ((B[:, 0] - A[:, 0]) * (C[:, 1] - A[:, 1]) - (B[:, 1] - A[:, 1]) * (C[:, 0] - A[:, 0]))
    flat = np.flatnonzero(area == 0)
    if len(flat):
        t = flat[0]
        raise QmeshError(f"triangle {first + t} (vertices {points[triangles[t]].tolist()}) has "
                         "zero area: its mean over raster cells is not defined")
    return integral / area[:, None], bound / np.abs(area)


def raster_box_means(R: Raster, P: Array, half_width: Array) -> Array:
    """Exact mean of the cells over each square [x ± h] × [y ± h] clipped to the raster →
    components (k, 3): F(b, d) − F(a, d) − F(b, c) + F(a, c) over the clipped area, F the
    summed-area primitive (`Raster.primitive`). The caller checks the squares meet the raster."""
    lo, hi = R.origin, R.origin + [R.x[-1], R.y[-1]]
    x0, x1 = np.clip(P[:, 0] - half_width, lo[0], hi[0]), np.clip(P[:, 0] + half_width, lo[0], hi[0])
    y0, y1 = np.clip(P[:, 1] - half_width, lo[1], hi[1]), np.clip(P[:, 1] + half_width, lo[1], hi[1])
    F = R.primitive
    integral = F(x1, y1) - F(x0, y1) - F(x1, y0) + F(x0, y0)
    return integral / ((x1 - x0) * (y1 - y0))[:, None]
