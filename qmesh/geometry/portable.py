"""Arithmetic whose every bit is the same on every CPU, for the numbers the mesher decides on.

NumPy sends `exp`, `log`, `arctan2`, `power`, `tan`, … to per-CPU SIMD kernels (SVML where the
CPU has AVX-512) and matrix products and `numpy.linalg` to per-CPU BLAS/LAPACK kernels, so their
last bits differ between machines; a comparison that reads those bits changes the mesh with the
machine. Here: only + − × ÷, `sqrt` and `hypot` (correctly rounded or exact, the same on every
machine, and never fused by NumPy), `frexp`/`ldexp` (exact) and NumPy's own `sin`/`cos` (one
implementation for every x86 SIMD level), in a fixed order. Functions agree with NumPy's to a few
units in the last place; they cost a few times more, which only matters where they are called on
every quadrature point of a text formula.

The 2 × 2 algebra returns what `numpy.linalg` returns for symmetric positive definite input
(`cholesky2` the lower factor, `eigh2` ascending eigenvalues with unit eigenvectors in columns).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

F = NDArray[np.float64]

# ln 2 split so that k·LN2_HI is exact for |k| < 2^20 (fdlibm's constants)
LN2_HI = 6.93147180369123816490e-01
LN2_LO = 1.90821492927058770002e-10
INV_LN2 = 1.44269504088896338700e+00
SQRT_HALF = 0.70710678118654752440
HALF_PI = 1.57079632679489661923
_ROOTS = [1.0, math.sqrt(math.sqrt(2.0)), math.sqrt(2.0),           # 2^(j/4), from square roots
          math.sqrt(2.0) * math.sqrt(math.sqrt(2.0))]
# Taylor coefficients, each a correctly rounded quotient of integers
_EXP = [1.0 / math.factorial(n) for n in range(14)]                 # |r| ≤ ln2/2: error < 1e-17
_ATANH = [1.0 / (2 * n + 1) for n in range(12)]                    # |f| ≤ 0.172
_ATAN = [(-1.0) ** n / (2 * n + 1) for n in range(13)]             # |t| ≤ tan(π/16)
_SINH = [1.0 / math.factorial(2 * n + 1) for n in range(11)]       # |x| ≤ 1


def _horner(x: F, coefficients: list[float]) -> F:
    """Σ c_n xⁿ, innermost term first: one fixed order of roundings."""
    p = np.full_like(x, coefficients[-1])
    for c in coefficients[-2::-1]:
        p = p * x + c
    return p


def _float(x: ArrayLike) -> F:
    return np.asarray(x, dtype=np.float64)


def exp(x: ArrayLike) -> F:
    """eˣ: x = k ln 2 + r (Cody–Waite), eʳ by its Taylor polynomial, times 2ᵏ exactly."""
    x = _float(x)
    with np.errstate(all="ignore"):
        k = np.rint(np.clip(x, -1100.0, 1100.0) * INV_LN2)
        r = (x - k * LN2_HI) - k * LN2_LO
        out = np.ldexp(_horner(r, _EXP), np.nan_to_num(k).astype(np.int64))
    out = np.where(x > 709.782712893384, np.inf, out)
    out = np.where(x < -745.2, 0.0, out)
    return np.where(np.isnan(x), np.nan, out)


def log(x: ArrayLike) -> F:
    """ln x: x = m 2ᵉ with m in [√½, √2), ln m = 2 atanh((m − 1)/(m + 1)) by its series."""
    x = _float(x)
    m, e = np.frexp(x)
    low = m < SQRT_HALF
    m = np.where(low, 2.0 * m, m)
    e = (e - low).astype(np.float64)
    with np.errstate(all="ignore"):
        f = (m - 1.0) / (m + 1.0)
        s = f * f
        lm = f * (2.0 + s * (2.0 * _horner(s, _ATANH[1:])))
        out = e * LN2_HI + (lm + e * LN2_LO)
    out = np.where(x == 0, -np.inf, out)
    out = np.where(x == np.inf, np.inf, out)
    return np.where((x < 0) | np.isnan(x), np.nan, out)


def log1p(x: ArrayLike) -> F:
    """ln(1 + x), with the rounding of 1 + x corrected (Goldberg's formula)."""
    x = _float(x)
    u = 1.0 + x
    with np.errstate(all="ignore"):
        corrected = log(u) * (x / (u - 1.0))
    return np.where(u == 1.0, x, np.where(np.isinf(x), log(u), corrected))


def tan(x: ArrayLike) -> F:
    x = _float(x)
    with np.errstate(all="ignore"):
        return np.sin(x) / np.cos(x)


def sinh(x: ArrayLike) -> F:
    x = _float(x)
    a = np.abs(x)
    with np.errstate(all="ignore"):
        small = x * _horner(x * x, _SINH)
        ea = exp(np.minimum(a, 709.0))
        big = np.where(a > 709.0, exp(a - LN2_HI), 0.5 * (ea - 1.0 / ea))
    return np.where(a <= 1.0, small, np.copysign(big, x))


def cosh(x: ArrayLike) -> F:
    a = np.abs(_float(x))
    with np.errstate(all="ignore"):
        ea = exp(np.minimum(a, 709.0))
        return np.where(a > 709.0, exp(a - LN2_HI), 0.5 * (ea + 1.0 / ea))


def tanh(x: ArrayLike) -> F:
    x = _float(x)
    with np.errstate(all="ignore"):
        t = sinh(x) / cosh(x)
    return np.where(np.abs(x) > 20.0, np.copysign(1.0, x), t)


def arctan(x: ArrayLike) -> F:
    """atan x: 1/|x| above 1, two half-angle steps t ← t/(1 + √(1 + t²)), then the series."""
    x = _float(x)
    a = np.abs(x)
    inv = a > 1.0
    with np.errstate(all="ignore"):
        t = np.where(inv, 1.0 / a, a)
        for _ in range(2):
            t = t / (1.0 + np.sqrt(1.0 + t * t))
        r = 4.0 * (t * _horner(t * t, _ATAN))
    r = np.where(inv, HALF_PI - r, r)
    return np.where(np.isnan(x), np.nan, np.copysign(r, x))


def arctan2(y: ArrayLike, x: ArrayLike) -> F:
    """The angle of (x, y) in (−π, π], as numpy.arctan2 on finite input."""
    y, x = np.broadcast_arrays(_float(y), _float(x))
    ax, ay = np.abs(x), np.abs(y)
    with np.errstate(all="ignore"):
        r = np.where(ay <= ax, arctan(ay / ax), HALF_PI - arctan(ax / ay))
    r = np.where((ax == 0) & (ay == 0), 0.0, r)
    r = np.where(np.signbit(x), np.pi - r, r)
    return np.copysign(r, y)


def _whole_power(b: F, n: NDArray[np.int64]) -> F:
    """bⁿ for whole n (|n| ≤ 64, one per element or one for all) by repeated squaring: at most
    two products per bit of n, the same on every machine."""
    if np.ndim(n) == 0:                                   # one exponent: only its own bits
        k, out, base = abs(int(n)), None, b
        while k:
            if k & 1:
                out = base if out is None else out * base
            k >>= 1
            if k:
                base = base * base
        out = np.ones_like(b) if out is None else out
        with np.errstate(all="ignore"):
            return 1.0 / out if n < 0 else out
    k = np.abs(n)
    out, base = np.ones(np.broadcast(b, k).shape), b
    with np.errstate(all="ignore"):
        for bit in range(7):
            out = np.where((k >> bit) & 1, out * base, out)
            base = base * base
        return np.where(n < 0, 1.0 / out, out)


def power(b: ArrayLike, e: ArrayLike) -> F:
    """bᵉ: whole exponents up to 64 by products, half-whole constant ones on √b, the rest as
    exp(e ln b) (negative b: a whole e only, as numpy.power)."""
    b = _float(b)
    if np.ndim(e) == 0 and abs(float(e)) <= 64 and 2 * float(e) == round(2 * float(e)):
        ev = float(e)
        if ev == round(ev):
            return _whole_power(b, np.int64(ev))
        with np.errstate(all="ignore"):
            return _whole_power(np.sqrt(b), np.int64(2 * ev))
    e = _float(e)
    whole = (e == np.round(e)) & (np.abs(e) <= 64)
    with np.errstate(all="ignore"):
        general = exp(e * log(np.abs(b)))
        odd = (e == np.round(e)) & (np.fmod(e, 2.0) != 0)
        general = np.where(b < 0, np.where(e == np.round(e), np.where(odd, -general, general), np.nan),
                           general)
        return np.where(whole, _whole_power(b, np.where(whole, e, 0).astype(np.int64)), general)


def round_log2(x: ArrayLike) -> NDArray[np.int64]:
    """The k with 2ᵏ nearest to x in ratio (round(log₂ x)), exactly: x = m 2ᵉ, m in [½, 1)."""
    m, e = np.frexp(_float(x))
    return (e - (m < SQRT_HALF)).astype(np.int64)


def floor_log2(x: ArrayLike) -> NDArray[np.int64]:
    """⌊log₂ x⌋ exactly, for x > 0."""
    return (np.frexp(_float(x))[1] - 1).astype(np.int64)


def ceil_log2(x: ArrayLike) -> NDArray[np.int64]:
    """⌈log₂ x⌉ exactly, for x > 0."""
    m, e = np.frexp(_float(x))
    return (e - (m == 0.5)).astype(np.int64)


def floor_log2_steps(x: ArrayLike, steps: int) -> NDArray[np.int64]:
    """⌊steps · log₂ x⌋ for x > 0 and steps 1, 2 or 4, by comparing the mantissa with the
    powers 2^(j/steps) (square roots of 2, never pow)."""
    m, e = np.frexp(_float(x))
    m = 2.0 * m                                           # x = m 2^(e−1), m in [1, 2)
    bounds = np.array(_ROOTS[4 // steps::4 // steps])
    return (steps * (e - 1) + np.searchsorted(bounds, m, side="right")).astype(np.int64)


def ceil_pow2_steps(x: float, steps: int) -> float:
    """The least 2^(j/steps) ≥ x (x > 0, steps 1, 2 or 4)."""
    for j in (int(floor_log2_steps(x, steps)) + k for k in (0, 1)):
        value = float(np.ldexp(_ROOTS[(4 // steps) * (j % steps)], j // steps))
        if value >= x:
            break
    return value


def gauss_legendre(n: int) -> tuple[F, F]:
    """numpy.polynomial.legendre.leggauss(n) without LAPACK: Newton's method on the three-term
    recurrence from Tricomi's first guesses, a fixed number of steps, symmetrised."""
    k = np.arange(1, n + 1, dtype=np.float64)
    x = -np.cos(np.pi * (k - 0.25) / (n + 0.5))          # ascending
    for _ in range(13):
        p0, p1 = np.ones_like(x), x
        for j in range(2, n + 1):
            p0, p1 = p1, ((2 * j - 1) * x * p1 - (j - 1) * p0) / j
        dp = n * (x * p1 - p0) / (x * x - 1.0)           # P_n'(x), from P_n and P_{n−1}
        x = x - p1 / dp if _ < 12 else x
    w = 2.0 / ((1.0 - x * x) * dp * dp)
    return 0.5 * (x - x[::-1]), 0.5 * (w + w[::-1])


# ---- 2 × 2 matrices, stacked over leading axes ------------------------------------------------

def det2(M: ArrayLike) -> F:
    M = _float(M)
    return M[..., 0, 0] * M[..., 1, 1] - M[..., 0, 1] * M[..., 1, 0]


def inv2(M: ArrayLike) -> F:
    M = _float(M)
    d = det2(M)
    out = np.empty_like(M)
    out[..., 0, 0], out[..., 1, 1] = M[..., 1, 1] / d, M[..., 0, 0] / d
    out[..., 0, 1], out[..., 1, 0] = -M[..., 0, 1] / d, -M[..., 1, 0] / d
    return out


def solve2(M: ArrayLike, b: ArrayLike) -> F:
    """x with M x = b for stacks of 2 × 2 matrices M (..., 2, 2) and vectors b (..., 2)."""
    M, b = _float(M), _float(b)
    d = det2(M)
    return np.stack([(M[..., 1, 1] * b[..., 0] - M[..., 0, 1] * b[..., 1]) / d,
                     (M[..., 0, 0] * b[..., 1] - M[..., 1, 0] * b[..., 0]) / d], axis=-1)


def cholesky2(H: ArrayLike) -> F:
    """The lower L with H = L Lᵀ (H symmetric positive definite)."""
    H = _float(H)
    L = np.zeros_like(H)
    L[..., 0, 0] = np.sqrt(H[..., 0, 0])
    L[..., 1, 0] = H[..., 1, 0] / L[..., 0, 0]
    L[..., 1, 1] = np.sqrt(H[..., 1, 1] - L[..., 1, 0] * L[..., 1, 0])
    return L


def eigvalsh2(H: ArrayLike) -> F:
    """Ascending eigenvalues of symmetric H; the smaller from det/larger where both are positive
    (no cancellation for a strongly anisotropic metric)."""
    H = _float(H)
    a, b, c = H[..., 0, 0], H[..., 0, 1], H[..., 1, 1]
    mid, rad = 0.5 * (a + c), np.hypot(0.5 * (a - c), b)
    big = mid + rad
    with np.errstate(all="ignore"):
        small = np.where((mid > 0) & (big > 0), (a * c - b * b) / big, mid - rad)
    small = np.where(np.isfinite(small), small, mid - rad)
    return np.stack([small, big], axis=-1)


def eigh2(H: ArrayLike) -> tuple[F, F]:
    """Ascending eigenvalues and unit eigenvectors (columns) of symmetric H, rotation-handed."""
    H = _float(H)
    w = eigvalsh2(H)
    a, b, c = H[..., 0, 0], H[..., 0, 1], H[..., 1, 1]
    lam = w[..., 1]
    u = np.stack([b, lam - a], axis=-1)                   # (H − λ)u = 0, from the first row …
    v = np.stack([lam - c, b], axis=-1)                   # … or the second, whichever is longer
    n_u, n_v = np.hypot(u[..., 0], u[..., 1]), np.hypot(v[..., 0], v[..., 1])
    big = np.where((n_u >= n_v)[..., None], u / np.where(n_u > 0, n_u, 1)[..., None],
                   v / np.where(n_v > 0, n_v, 1)[..., None])
    big = np.where((np.maximum(n_u, n_v) > 0)[..., None], big, np.array([0.0, 1.0]))  # H = λ I
    V = np.empty(H.shape)
    V[..., 0, 1], V[..., 1, 1] = big[..., 0], big[..., 1]
    V[..., 0, 0], V[..., 1, 0] = big[..., 1], -big[..., 0]
    return w, V


def dot2(u: ArrayLike, v: ArrayLike) -> F:
    """u · v over a last axis of size 2."""
    u, v = _float(u), _float(v)
    return u[..., 0] * v[..., 0] + u[..., 1] * v[..., 1]


def times2(X: ArrayLike, M: ArrayLike) -> F:
    """X @ M for points X (..., 2) and one 2 × 2 (or 2 × k) matrix M: x·M[0, j] + y·M[1, j]
    per column j, written into one array (the broadcast X[..., :1] * M[0] + X[..., 1:] * M[1],
    the same bits, made three temporaries of X's size, and took four times as long at 1e6)."""
    X, M = _float(X), _float(M)
    if M.ndim != 2 or M.shape[0] != 2 or X.shape[-1:] != (2,):
        return X[..., :1] * M[0] + X[..., 1:] * M[1]
    out = np.empty(X.shape[:-1] + M.shape[1:])
    x, y = X[..., 0], X[..., 1]
    for j in range(M.shape[1]):
        column = out[..., j]
        np.multiply(x, M[0, j], out=column)
        column += y * M[1, j]
    return out


def matmul2(A: ArrayLike, B: ArrayLike) -> F:
    """A @ B for stacks of 2 × 2 matrices (broadcast over the leading axes)."""
    A, B = _float(A), _float(B)
    return A[..., :, :1] * B[..., None, 0, :] + A[..., :, 1:] * B[..., None, 1, :]


def moments2(D: ArrayLike, w: ArrayLike) -> F:
    """Σₙ wₙ Dₙ Dₙᵀ for points D (..., n, 2) with weights w (..., n): each entry one pairwise sum
    along n, so a stack of point sets gives every set the bits it gives alone."""
    D, w = _float(D), _float(w)
    x, y = D[..., 0], D[..., 1]
    xx, xy, yy = (w * x * x).sum(axis=-1), (w * x * y).sum(axis=-1), (w * y * y).sum(axis=-1)
    return np.stack([np.stack([xx, xy], axis=-1), np.stack([xy, yy], axis=-1)], axis=-2)


def cov2(X: ArrayLike) -> F:
    """numpy.cov(X.T) for points X (n, 2), with NumPy's own pairwise sums instead of BLAS."""
    X = _float(X)
    D = X - X.sum(axis=0) / len(X)
    return moments2(D, np.ones(len(X))) / (len(X) - 1)
