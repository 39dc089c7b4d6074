"""Per-triangle geometry shared by the mesher and the measurements.

Areas, the vertex gradients of the area, metric edge lengths and the metric quality (2.94).
Everything is vectorised over the (M, 3) triangle array.
"""

from __future__ import annotations

import numpy as np

CHUNK = 1 << 14        # triangles per block of a per-triangle pass (bounds its temporaries)


def chunks(m: int) -> list[slice]:
    """Slices of CHUNK triangles covering range(m): per-triangle passes over a whole mesh of
    1e6 vertices made a Frame's seven (M, 3) arrays at once, the mesher's peak memory. A block's
    temporaries (0.4 MB each) stay in the cache and are reused by the allocator: with blocks of
    2^18 triangles (6 MB arrays) newton_rhs, limit_moves and metric_measures took 1.3 to 1.9
    times as long at 1e6 vertices."""
    return [slice(k, min(k + CHUNK, m)) for k in range(0, max(m, 1), CHUNK)]


def columns(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """P's x and y as contiguous 1-D arrays: made once for a pass over many blocks of triangles
    (each block's `corners` copied both columns again: 16 MB a block at 1e6 vertices)."""
    return np.ascontiguousarray(P[:, 0]), np.ascontiguousarray(P[:, 1])


def extent(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """P.min(axis=0) and P.max(axis=0) for points P (n, 2), a column at a time: the same
    numbers, a tenth of the time (NumPy reduces an (n, 2) array along its long axis two
    numbers at a time)."""
    x, y = P[:, 0], P[:, 1]
    return np.array([x.min(), y.min()]), np.array([x.max(), y.max()])


def corners(P, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Corner coordinates x (M, 3) and y (M, 3); P is the (N, 2) points or their `columns`.

    Gathering each coordinate from a contiguous 1-D array is about ten times faster than
    P[T] on the (N, 2) array, and this gather is the main cost of every per-triangle pass:
    a pass over many blocks takes the `columns` once. Given the points, each coordinate is
    gathered as P[T, 0] (half as fast as from a column, but no copy of the column: a block of
    2^14 triangles of a mesh of 1e6 vertices costs less than copying its two columns).
    """
    if isinstance(P, tuple):
        return np.take(P[0], T), np.take(P[1], T)
    return P[T, 0], P[T, 1]


def signed_areas(P, T: np.ndarray) -> np.ndarray:
    """Signed area of every triangle (> 0 when counter-clockwise)."""
    return _signed_areas(*corners(P, T))


def _signed_areas(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return 0.5 * ((x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (y[:, 1] - y[:, 0]) * (x[:, 2] - x[:, 0]))


FLAT = 1e-12   # a triangle whose area is below this share of its longest edge squared is flat


def proper(P, T: np.ndarray) -> np.ndarray:
    """Which triangles are counter-clockwise and not flat to round-off: area above FLAT times
    the square of the longest edge. Three points of one straight side, each off it by a last
    bit, make a positive area of 1e-16 of that square: a triangle of no width, whose mean over
    raster cells (its points clipped to the raster) is undefined."""
    x, y = corners(P, T)
    ex, ey = np.roll(x, -1, axis=1) - x, np.roll(y, -1, axis=1) - y
    longest = np.max(ex * ex + ey * ey, axis=1)
    return _signed_areas(x, y) > FLAT * longest


class Frame:
    """Per-triangle quantities of one stage, from one gather of the corner coordinates.

    x, y (M, 3) corners; ex, ey (M, 3) the edge opposite each corner, from corner c+1 to c+2;
    A (M,) signed areas; gx, gy (M, 3) the area gradients ∇_{x_c}|T| = ½ (−e_c,y, e_c,x)
    (MATH.md, below (2.85): for a counter-clockwise (i, j, k), ∇_{x_i}|T| = ½ (y_j − y_k, x_k − x_j)).
    """

    __slots__ = ("x", "y", "ex", "ey", "A", "gx", "gy")

    def __init__(self, P, T: np.ndarray):
        x, y = corners(P, T)
        self.x, self.y = x, y
        self.ex, self.ey = np.empty_like(x), np.empty_like(y)
        for e, c in ((self.ex, x), (self.ey, y)):
            np.subtract(c[:, 2], c[:, 1], out=e[:, 0])
            np.subtract(c[:, 0], c[:, 2], out=e[:, 1])
            np.subtract(c[:, 1], c[:, 0], out=e[:, 2])
        self.A = 0.5 * (self.ex[:, 1] * self.ey[:, 2] - self.ey[:, 1] * self.ex[:, 2])
        self.gx = -0.5 * self.ey
        self.gy = 0.5 * self.ex

    @property
    def E(self) -> np.ndarray:
        """Opposite edges as (M, 3, 2) vectors."""
        return np.stack([self.ex, self.ey], axis=-1)


def area_gradients(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """∇_{x_a}|T| for each corner a of each triangle, shape (M, 3, 2) (MATH.md, below (2.85))."""
    F = Frame(P, T)
    return np.stack([F.gx, F.gy], axis=-1)


def centroids(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    x, y = corners(P, T)
    return np.column_stack([x.mean(axis=1), y.mean(axis=1)])


def metric_hessians(anisotropy, P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """The metric H = ∇²s of each triangle, evaluated at its centroid: (M, 2, 2)."""
    if anisotropy.is_constant:
        return np.broadcast_to(anisotropy.H, (len(T), 2, 2))
    return np.asarray(anisotropy.hessian(centroids(P, T)), dtype=float)


def quadratic_form_xy(x: np.ndarray, y: np.ndarray, H: np.ndarray) -> np.ndarray:
    """(x, y) H (x, y)ᵀ for one 2×2 matrix H."""
    (a, b), (_, c) = H
    return a * x * x + 2.0 * b * x * y + c * y * y


def quadratic_form(E: np.ndarray, H: np.ndarray) -> np.ndarray:
    """eᵀHe for vectors E (M, k, 2) and metrics H (M, 2, 2); fast when H is one broadcast matrix.
    Otherwise the four terms e_i H_ij e_j summed in einsum's order ("mki,mij,mkj->mk": the same
    bits), without its generic three-operand loop."""
    if H.ndim == 2 or H.strides[0] == 0:
        return quadratic_form_xy(E[..., 0], E[..., 1], H if H.ndim == 2 else H[0])
    e0, e1 = E[..., 0], E[..., 1]
    h = H.reshape(len(H), *([1] * (E.ndim - 2)), 4)
    return ((e0 * h[..., 0] * e0 + e0 * h[..., 1] * e1) + e1 * h[..., 2] * e0) + e1 * h[..., 3] * e1


def metric_edge_lengths2(P: np.ndarray, T: np.ndarray, H: np.ndarray) -> np.ndarray:
    """Squared metric lengths eᵀHe of the three edges opposite each corner: (M, 3)."""
    return _edge_lengths2(Frame(P, T), H)


def _edge_lengths2(F: Frame, H: np.ndarray) -> np.ndarray:
    if H.ndim == 2 or H.strides[0] == 0:
        return quadratic_form_xy(F.ex, F.ey, H if H.ndim == 2 else H[0])
    return quadratic_form(F.E, H)


def metric_areas(P: np.ndarray, T: np.ndarray, H: np.ndarray) -> np.ndarray:
    """Area in metric space: √det H · |T|; NaN where H is not positive definite.

    That happens only at tentative positions outside Ω, where a user's s need not be convex
    (boundary.py tries moves before accepting them): NaN says so without a NumPy warning.
    """
    return _metric_areas(signed_areas(P, T), H)


def _metric_areas(areas: np.ndarray, H: np.ndarray) -> np.ndarray:
    if H.strides[0] == 0:
        H = H[:1]
    e = None
    top = max(float(H.max(initial=0.0)), -float(H.min(initial=0.0)))   # no |H| temporary
    if top > 1e100 or 0.0 < top < 1e-100:      # det H would over- or underflow (a region's
        e = np.frexp(np.abs(H).max(axis=(1, 2)))[1]         # adj Q may hold 1e300): scaled by
        H = np.ldexp(H, -e[:, None, None])                  # a power of two, bit-exact
    det = H[:, 0, 0] * H[:, 1, 1] - H[:, 0, 1] * H[:, 1, 0]
    with np.errstate(invalid="ignore"):
        root = np.sqrt(det)
    return root * areas if e is None else np.ldexp(root, e) * areas


def metric_quality(P: np.ndarray, T: np.ndarray, H: np.ndarray) -> np.ndarray:
    """Quality (2.94) in metric space, normalised to 1 for an equilateral triangle: 4√3 Ã / Σ l̃²
    (CHUNK triangles at a time: the values do not depend on it)."""
    if len(T) <= CHUNK:
        return _metric_quality(P, T, H)
    out = np.empty(len(T))
    xy = columns(P)                                     # once, not for every block
    for c in chunks(len(T)):
        out[c] = _metric_quality(xy, T[c], H[c] if H.ndim == 3 else H)
    return out


def worst_metric_quality(P: np.ndarray, T: np.ndarray, anisotropy) -> float:
    """The lowest quality (2.94) of the triangles T in the metric of `anisotropy`."""
    return float(metric_quality(P, T, metric_hessians(anisotropy, P, T)).min())


def _metric_quality(P: np.ndarray, T: np.ndarray, H: np.ndarray) -> np.ndarray:
    return _quality(metric_areas(P, T, H), metric_edge_lengths2(P, T, H))


def _quality(area: np.ndarray, L2: np.ndarray) -> np.ndarray:
    """4√3 Ã / Σ l̃² (2.94); the sum written out (= sum(axis=1), without its overhead)."""
    return 4.0 * np.sqrt(3.0) * area / (L2[:, 0] + L2[:, 1] + L2[:, 2])


def rounded(x: np.ndarray, bits: int = 32) -> np.ndarray:
    """x with its mantissa rounded to `bits` bits (about 1e-10 relative).

    Decisions made by comparing or ranking measured values (which triangle to refine first,
    which is larger than a threshold) then do not depend on round-off, so a domain moved far
    away or scaled gives the same choices, ties included, as at the origin.
    """
    m, e = np.frexp(np.asarray(x, dtype=float))
    return np.ldexp(np.round(m * 2.0**bits) / 2.0**bits, e)


def metric_measures(P: np.ndarray, T: np.ndarray, H: np.ndarray, rounding: bool = False):
    """metric_areas, metric_quality and metric_edge_lengths2 of every triangle, CHUNK triangles
    at a time, from one gather of the corners per block (each value exactly what the
    whole-array functions give: the same operations in the same order). `rounding`: each of
    the three `rounded` (the quality from the unrounded ones), a block at a time: rounding the
    whole arrays afterwards made five temporaries of their size each, and took as long as
    measuring."""
    area, quality, L2 = np.empty(len(T)), np.empty(len(T)), np.empty(T.shape)
    xy = columns(P)
    for c in chunks(len(T)):
        F = Frame(xy, T[c])
        a = _metric_areas(_signed_areas(F.x, F.y), H[c])
        l2 = _edge_lengths2(F, H[c])
        q = _quality(a, l2)
        if rounding:
            a, q, l2 = rounded(a), rounded(q), rounded(l2)
        area[c], quality[c], L2[c] = a, q, l2
    return area, quality, L2
