"""Rigorous enclosures of a checked text formula over boxes: its range and its gradient's.

A quadrature that compares samples cannot see what lies between them (a jump no sample
straddles, a bump narrower than their spacing), so the error bound of a text formula's element
means comes from here (`means.adaptive_means`'s `bound`). The checked form of a text
(`expression.check`: numbers, x, y, + − * / **, unary −, the whitelisted functions) is evaluated
on intervals [lo, hi], vectorised over boxes, in forward mode to third order: every node gives
an enclosure of its value, its gradient, its Hessian and its third derivatives over the box
(`DERIVATIVES`; Leibniz's rule for products and quotients, Faà di Bruno's for functions; an exact
zero, the derivatives of a number or of x and y, is carried as None and costs nothing; a
subexpression the forms share is enclosed once). The third derivatives are what lets the error
bound (`means.enclosure_bound`) subtract the cubic Taylor polynomial, which the degree-5 rule
integrates exactly, so its remainder falls as the fourth power of a piece's size. Every result
is widened outward — by at least one ulp after + − × ÷, by a few ulps plus the smallest normal after a function (NumPy's and
`geometry.portable`'s functions agree with the true one to a few ulps) — so the enclosure holds
whatever the CPU's last bits; the functions are `portable`'s, so the enclosure itself is the same
on every CPU.

The operations assume NumPy's floating-point warnings off (∞ − ∞ and 0 · ∞ are meant, and
`_clean` handles them): `evaluate_all` turns them off once for the whole walk, where setting
them in each of the thousand operations of a piece's enclosure cost an eighth of its time.

What cannot be bounded is said so: a division by an interval holding 0, a logarithm or a root
reaching 0, `tan` across a pole give [−∞, ∞]. Where a function is not differentiable its
gradient enclosure is the Clarke one (`abs`: [−1, 1] across 0, its Hessian unbounded there),
valid for the mean-value inequality since `abs` is Lipschitz; `c·abs(u)/u` and `u/abs(u)` (a
sign, a jump) are recognised: their value lies in c·[−1, 1] and their derivatives are unbounded
across u = 0; so are steps spelled (α·abs(u) + β·u)/(m·u) for numbers α, β, m (a Heaviside
(u + abs(u))/(2*u); abs(u) also as sqrt(u**2)), whose value lies between the two sides'
(`step_of`); where u is affine the jump's triangles are not enclosed across it but cut along
it (`sides`). A principal field's angle matters modulo 180° only: an arctangent of a quotient
that it holds as a whole number of half turns (`180/pi*atan(y/x)`, a polar angle as a direction)
is enclosed on each box by the branch whose quotient is bounded there (`principal_forms`).
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from numpy.typing import NDArray

from qmesh.geometry import portable

Array = NDArray[np.float64]
Interval = tuple[Array, Array]
Node = tuple[Interval, ...]     # value, ∂x, ∂y, ∂xx, ∂xy, ∂yy[, ∂xxx, ∂xxy, ∂xyy, ∂yyy]
Zeroable = Interval | None      # None: an exact 0 (a derivative of a number, ∂x/∂y, ...)

DERIVATIVES = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2), (3, 0), (2, 1), (1, 2), (0, 3))
"""What a Node holds, as (times ∂x, times ∂y): the value, ∂x, ∂y, ∂xx, ∂xy, ∂yy, ∂xxx, ∂xxy,
∂xyy, ∂yyy; a node of order 2 the first 6 of them."""
ORDER = 3
"""The order `evaluate_all` goes to by default: third derivatives (`means.enclosure_bound`'s
cubic Taylor remainder)."""
_AT = {d: i for i, d in enumerate(DERIVATIVES)}

ULPS = 1e-15          # relative widening after a function (4–9 ulps each side)
TINY = 1e-300         # absolute widening after a function
INF = math.inf


def _clean(lo: Array, hi: Array) -> Interval:
    """NaN anywhere (∞ − ∞, 0 · ∞ of an unbounded operand): the whole line. The least of each
    end (`np.minimum` keeps a NaN) is NaN only where that end holds one, and their sum besides
    only where the lower ends reach +∞ and the upper ones −∞ (then the mask finds none), so a
    whole line [−∞, ∞] met on the way does not send every later operation to the mask; a
    minimum is a third of the time of the sum it replaces."""
    least = _LEAST(lo, axis=None, initial=INF) + _LEAST(hi, axis=None, initial=INF)
    if least == least:
        return lo, hi                       # no NaN in any row (a pass an end, no mask)
    bad = np.isnan(lo) | np.isnan(hi)
    if not bad.any():
        return lo, hi
    return np.where(bad, -INF, lo), np.where(bad, INF, hi)


_LEAST = np.minimum.reduce   # NaN where a NaN is met (`_clean`)
HALF_ULP = 2.0 ** -52      # twice a normal float's half-ulp (relative)
DENORMAL = 5e-324          # the smallest subnormal


def _round(lo: Array, hi: Array) -> Interval:
    """Outward past the rounding of a correctly rounded + − × ÷ (at most half an ulp): each end
    moved by |v|·2^-52 plus the smallest subnormal, a move of at least one ulp that rounding to
    nearest cannot undo (four times cheaper than `np.nextafter`)."""
    return _clean(_outward(lo, np.subtract), _outward(hi, np.add))


def _outward(v: Array, move: np.ufunc) -> Array:
    """v ∓ (|v|·2^-52 + DENORMAL), in one buffer (the same operations in the same order)."""
    t = np.empty_like(v)
    np.abs(v, out=t)
    np.multiply(t, HALF_ULP, out=t)
    np.add(t, DENORMAL, out=t)
    return move(v, t, out=t)


def _widen(lo: Array, hi: Array) -> Interval:
    """A few ulps outward: after a function accurate to a few ulps. Each end moves by
    (ULPS + 2^-52)|v| + TINY: rounding the move loses at most half an ulp of it, so at least
    ULPS|v| + TINY and half an ulp are left (as `np.nextafter` after ULPS|v| + TINY leaves,
    in a third of its time)."""
    lo, hi = _clean(lo, hi)
    return _moved(lo, np.subtract), _moved(hi, np.add)


def _moved(v: Array, move: np.ufunc) -> Array:
    """v ∓ ((ULPS + 2^-52)|v| + TINY), in one buffer."""
    t = np.empty_like(v)
    np.abs(v, out=t)
    np.multiply(t, ULPS + HALF_ULP, out=t)
    np.add(t, TINY, out=t)
    return move(v, t, out=t)


def _const(c: float, shape: tuple) -> Interval:
    """The point [c, c]: both ends one array (never written to), which `mul` recognises."""
    v = np.full(shape, c)
    return v, v


def add(a: Zeroable, b: Zeroable) -> Zeroable:
    if a is None or b is None:
        return b if a is None else a
    return _round(a[0] + b[0], a[1] + b[1])


def sub(a: Zeroable, b: Zeroable) -> Zeroable:
    if a is None or b is None:
        return a if b is None else neg(b)
    return _round(a[0] - b[1], a[1] - b[0])


def neg(a: Zeroable) -> Zeroable:
    return None if a is None else (-a[1], -a[0])


def mul(a: Zeroable, b: Zeroable) -> Zeroable:
    """The four corner products, an exact 0 (None) times anything an exact 0. A 0 · ∞ (NaN) is
    left out of the least and the largest (`np.fmin`, `np.fmax`): a corner 0 · ∞ has a neighbour
    corner 0 · (a finite end) = 0 unless both ends are infinite, where the others give ±∞ or NaN
    too, and all NaN is the whole line (`_clean`): never narrower than 0 · ∞ = 0 would give."""
    if a is None or b is None:
        return None
    if b[0] is b[1]:
        a, b = b, a
    if a[0] is a[1]:                       # a point (`_const`): its corners are two of the four
        p0, p1 = a[0] * b[0], a[0] * b[1]
        return _round(np.fmin(p0, p1), np.fmax(p0, p1))
    p = [a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1]]
    lo = np.fmin(np.fmin(p[0], p[1]), np.fmin(p[2], p[3]))
    hi = np.fmax(np.fmax(p[0], p[1]), np.fmax(p[2], p[3]))
    return _round(lo, hi)


def div(a: Zeroable, b: Interval) -> Zeroable:
    """a / b; the whole line where b holds 0 (an exact 0 over b elsewhere: an exact 0)."""
    return _times_inverse(a, _inverse(b))


def _inverse(b: Interval) -> tuple[Interval, NDArray[np.bool_], bool]:
    """1/b rounded outward (1 where b holds 0), where b holds 0, and whether it does anywhere:
    what `div` by b needs, computed once for the several numerators of a quotient's derivatives."""
    zero = (b[0] <= 0) & (b[1] >= 0)
    inv = (np.where(zero, 1.0, 1.0 / b[1]), np.where(zero, 1.0, 1.0 / b[0]))
    return _round(*inv), zero, bool(zero.any())


def _times_inverse(a: Zeroable, inverse: tuple[Interval, NDArray[np.bool_], bool]) -> Zeroable:
    """a / b from b's `_inverse`."""
    inv, zero, anywhere = inverse
    if a is None:
        return None if not anywhere else (np.where(zero, -INF, 0.0), np.where(zero, INF, 0.0))
    lo, hi = mul(a, inv)
    if not anywhere:
        return lo, hi
    return np.where(zero, -INF, lo), np.where(zero, INF, hi)


def _contains_zero(a: Interval) -> NDArray[np.bool_]:
    return (a[0] <= 0) & (a[1] >= 0)


def whole_power(a: Zeroable, n: int) -> Zeroable:
    """aⁿ for a whole n: even powers through |a|, odd ones monotone, negative ones as 1/a^|n|."""
    if a is None:                     # an exact 0 to a power n > 0 (derivatives only)
        return None
    if n == 0:
        return _const(1.0, a[0].shape)
    if n < 0:
        return div(_const(1.0, a[0].shape), whole_power(a, -n))
    if n == 1:
        return a
    lo, hi = a
    if n % 2:
        return _widen(portable.power(lo, n), portable.power(hi, n))
    m = np.maximum(np.abs(lo), np.abs(hi))
    low = np.where(_contains_zero(a), 0.0, np.minimum(np.abs(lo), np.abs(hi)))
    if n == 2:                    # one correctly rounded product a side: `_round` covers it
        out_lo, out_hi = _round(low * low, m * m)
    else:
        out_lo, out_hi = _widen(portable.power(low, n), portable.power(m, n))
    return np.maximum(out_lo, 0.0), out_hi


def real_power(a: Interval, p: float) -> Interval:
    """aᵖ for a constant p that is not whole: defined for a ≥ 0 only (the whole line where a
    reaches below 0), increasing for p > 0, decreasing (and unbounded at 0) for p < 0."""
    lo, hi = a
    bad = lo < 0
    l0, h0 = np.maximum(lo, 0.0), np.maximum(hi, 0.0)
    if p > 0:
        r = _widen(portable.power(l0, p), portable.power(h0, p))
    else:
        r = _widen(portable.power(h0, p), np.where(l0 > 0, portable.power(l0, p), INF))
    return np.where(bad, -INF, np.maximum(r[0], 0.0)), np.where(bad, INF, r[1])


def _monotone(f: Callable[[Array], Array], a: Interval, lo_ok: Array | float = -INF) -> Interval:
    """An increasing function defined above `lo_ok` (the whole line where a reaches below)."""
    bad = a[0] < lo_ok
    r = _widen(f(np.maximum(a[0], lo_ok)), f(a[1]))
    return np.where(bad, -INF, r[0]), np.where(bad, INF, r[1])


def _periodic(a: Interval, peak: float) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Whether [lo, hi] holds a point peak + 2kπ (a maximum) and peak + π + 2kπ (a minimum),
    deciding "yes" near the ends (an enclosure may only grow)."""
    lo, hi = a
    two_pi = 2.0 * math.pi
    slack = 1e-12 * (1.0 + np.maximum(np.abs(lo), np.abs(hi)))
    k_max = np.ceil((lo - slack - peak) / two_pi)
    k_min = np.ceil((lo - slack - peak - math.pi) / two_pi)
    has_max = peak + two_pi * k_max <= hi + slack
    has_min = peak + math.pi + two_pi * k_min <= hi + slack
    wide = ~np.isfinite(lo) | ~np.isfinite(hi) | (hi - lo >= two_pi)
    return has_max | wide, has_min | wide


def sin(a: Interval) -> Interval:
    top, bottom = _periodic(a, 0.5 * math.pi)
    u, v = np.sin(np.nan_to_num(a[0])), np.sin(np.nan_to_num(a[1]))
    lo, hi = _widen(np.minimum(u, v), np.maximum(u, v))
    return np.where(bottom, -1.0, np.maximum(lo, -1.0)), np.where(top, 1.0, np.minimum(hi, 1.0))


def cos(a: Interval) -> Interval:
    top, bottom = _periodic(a, 0.0)
    u, v = np.cos(np.nan_to_num(a[0])), np.cos(np.nan_to_num(a[1]))
    lo, hi = _widen(np.minimum(u, v), np.maximum(u, v))
    return np.where(bottom, -1.0, np.maximum(lo, -1.0)), np.where(top, 1.0, np.minimum(hi, 1.0))


def tan(a: Interval) -> Interval:
    """Increasing between poles; the whole line across one (π/2 + kπ)."""
    pole, _ = _periodic(a, 0.5 * math.pi)
    other, _ = _periodic(a, 1.5 * math.pi)
    across = pole | other | (a[1] - a[0] >= math.pi)
    r = _widen(portable.tan(a[0]), portable.tan(a[1]))
    return np.where(across, -INF, r[0]), np.where(across, INF, r[1])


def absolute(a: Interval) -> Interval:
    lo, hi = a
    z = _contains_zero(a)
    return (np.where(z, 0.0, np.minimum(np.abs(lo), np.abs(hi))),
            np.maximum(np.abs(lo), np.abs(hi)))


def cosh(a: Interval) -> Interval:
    m = absolute(a)
    r = _widen(portable.cosh(m[0]), portable.cosh(m[1]))
    return np.maximum(r[0], 1.0), r[1]


def _clip(a: Interval, lo: float, hi: float) -> Interval:
    return np.clip(a[0], lo, hi), np.clip(a[1], lo, hi)


VALUES = {
    "exp": lambda a: _monotone(portable.exp, a),
    "log": lambda a: _monotone(portable.log, a, 0.0),
    "log1p": lambda a: _monotone(portable.log1p, a, -1.0),
    "sqrt": lambda a: _monotone(np.sqrt, a, 0.0),
    "sin": sin, "cos": cos, "tan": tan,
    "sinh": lambda a: _monotone(portable.sinh, a),
    "cosh": cosh,
    "tanh": lambda a: _clip(_monotone(portable.tanh, a), -1.0, 1.0),
    "arctan": lambda a: _clip(_monotone(portable.arctan, a), -2.0, 2.0),
    "atan": lambda a: _clip(_monotone(portable.arctan, a), -2.0, 2.0),
    "abs": absolute,
}


def _slopes(name: str, u: Interval, value: Interval, order: int = ORDER,
            values: dict | None = None) -> list[Zeroable]:
    """Enclosures of f', f'' and f''' over u (the first `order` of them), given f(u)'s (`value`);
    f'' and f''' are the whole line where f has a kink in u (`abs` across 0: its second
    derivative is a Dirac mass there). `values`: the functions' values over u enclosed so far,
    by name (a sine's slope is the cosine of the same argument), kept for the next."""
    shape = u[0].shape
    one, two = _const(1.0, shape), _const(2.0, shape)
    d3: Zeroable = None
    if name == "exp":
        d1 = d2 = d3 = value
    elif name in ("log", "log1p"):
        d1 = div(one, u if name == "log" else add(one, u))
        d2 = neg(whole_power(d1, 2))
        if order > 2:
            d3 = mul(two, whole_power(d1, 3))
    elif name == "sqrt":
        d1 = div(_const(0.5, shape), value)
        d2 = div(neg(d1), mul(two, u))
        if order > 2:                                   # (√u)''' = −(3/2) (√u)'' / u
            d3 = mul(_const(-1.5, shape), div(d2, u))
    elif name in ("sin", "cos"):
        other = "cos" if name == "sin" else "sin"
        values = {} if values is None else values
        if other not in values:
            values[other] = VALUES[other](u)
        d1 = values[other] if name == "sin" else neg(values[other])
        d2, d3 = neg(value), neg(d1)
    elif name in ("tan", "tanh"):                       # f' = 1 ± f², f'' = ±2 f f',
        sign = 1.0 if name == "tan" else -1.0           # f''' = ±2 (f'² + f f'')
        d1 = (add if name == "tan" else sub)(one, whole_power(value, 2))
        d2 = mul(_const(2.0 * sign, shape), mul(value, d1))
        if order > 2:
            d3 = mul(_const(2.0 * sign, shape), add(whole_power(d1, 2), mul(value, d2)))
    elif name in ("sinh", "cosh"):
        d1 = cosh(u) if name == "sinh" else VALUES["sinh"](u)
        d2, d3 = value, d1
    elif name in ("arctan", "atan"):                    # f' = 1/(1 + u²), f'' = −2u f'²,
        d1 = div(one, add(one, whole_power(u, 2)))      # f''' = (6u² − 2) f'³
        d2 = neg(mul(mul(two, u), whole_power(d1, 2)))
        if order > 2:
            d3 = mul(sub(mul(_const(6.0, shape), whole_power(u, 2)), two), whole_power(d1, 3))
    else:
        assert name == "abs"
        z = _contains_zero(u)
        d1 = np.where(z | (u[0] < 0), -1.0, 1.0), np.where(z | (u[1] > 0), 1.0, -1.0)
        d2 = d3 = (np.where(z, -INF, 0.0), np.where(z, INF, 0.0))
    return [d1, d2, d3][:order]


def sign_of(f: tuple) -> tuple | None:
    """(u, c) when f is c·abs(u)/u or c·u/abs(u) (c·sign(u): a jump across u = 0; c = None for
    1), else None."""
    if f[0] != "/":
        return None
    a, b = f[1], f[2]
    if a == ("call", "abs", b):
        return b, None
    if b[0] == "call" and b[1] == "abs" and a == b[2]:
        return a, None
    if a[0] == "*":
        for c, d in ((a[1], a[2]), (a[2], a[1])):
            if d == ("call", "abs", b):
                return b, c
    return None


def step_of(f: tuple) -> tuple | None:
    """(u, a, b) when f is (α·abs(u) + β·u) / (m·u) for numbers α ≠ 0, β, m (in any order of
    sums and factors): a step, a = (β − α)/m where u < 0 and b = (α + β)/m where u > 0 — the
    Heaviside (u + abs(u))/(2*u), abs(u)/(2*u); else None (`sign_of` takes c·abs(u)/u)."""
    if f[0] != "/":
        return None
    u, m = f[2], 1.0
    if u[0] == "*":
        for c, d in ((u[1], u[2]), (u[2], u[1])):
            if c[0] == "num":
                u, m = d, c[1]
                break
    linear = _linear_in(f[1], u)
    if linear is None or linear[0] == 0 or m == 0:
        return None
    alpha, beta = linear
    return u, (beta - alpha) / m, (alpha + beta) / m


def _linear_in(f: tuple, u: tuple) -> tuple[float, float] | None:
    """(α, β) when f is α·abs(u) + β·u for numbers α, β (abs(u) also spelled sqrt(u**2)), else
    None."""
    if f == ("call", "abs", u) or f == ("call", "sqrt", ("**", u, ("num", 2.0))):
        return 1.0, 0.0
    if f == u:
        return 0.0, 1.0
    if f[0] == "neg":
        inner = _linear_in(f[1], u)
        return None if inner is None else (-inner[0], -inner[1])
    if f[0] in ("+", "-"):
        a, b = _linear_in(f[1], u), _linear_in(f[2], u)
        if a is None or b is None:
            return None
        k = 1.0 if f[0] == "+" else -1.0
        return a[0] + k * b[0], a[1] + k * b[1]
    if f[0] == "*":
        for c, d in ((f[1], f[2]), (f[2], f[1])):
            if c[0] == "num":
                inner = _linear_in(d, u)
                return None if inner is None else (c[1] * inner[0], c[1] * inner[1])
    return None


def _compose(v: Interval, slopes: list[Zeroable], u: Node, products: dict | None = None) -> Node:
    """f(u) from u's value and derivatives, f^(k)(u) ∈ slopes[k − 1] (Faà di Bruno's formula to
    the node's order: ∂_α f(u) = Σ over the partitions of α's directions into k blocks of
    f^(k)(u) Π_blocks ∂_block u, e.g. ∇²f = f'' ∇u ∇uᵀ + f' ∇²u). `products`: the products
    of u's derivatives formed so far, by their factors (the sine and the cosine of one argument
    share them), kept for the next."""
    products = {} if products is None else products
    out = [v]
    for terms in _FAA_DI_BRUNO[1:len(u)]:
        total: Zeroable = None
        for coef, k, factors in terms:
            if factors not in products:
                products[factors] = _product(u, factors)
            total = add(total, _scaled(coef, mul(slopes[k - 1], products[factors])))
        out.append(total)
    return tuple(out)


def _times(a: Node, b: Node) -> Node:
    """a · b to the nodes' order (Leibniz: ∂_α(ab) = Σ_β≤α C(α, β) ∂_β a ∂_α−β b)."""
    out = []
    for terms in _LEIBNIZ[:len(a)]:
        total: Zeroable = None
        for coef, i, j in terms:
            total = add(total, _scaled(coef, mul(a[i], b[j])))
        out.append(total)
    return tuple(out)


def _over(a: Node, b: Node) -> Node:
    """q = a / b to the nodes' order, from a = q b by Leibniz, lowest orders first:
    ∂_α q = (∂_α a − Σ_β<α C(α, β) ∂_β q ∂_α−β b) / b (∇q = (∇a − q ∇b)/b, ...)."""
    inverse = _inverse(b[0])
    q: list[Zeroable] = [_times_inverse(a[0], inverse)]
    for terms in _LEIBNIZ[1:len(a)]:
        total = a[len(q)]
        for coef, i, j in terms:
            if i < len(q):                     # β < α: the term of ∂_α q itself is left out
                total = sub(total, _scaled(coef, mul(q[i], b[j])))
        q.append(_times_inverse(total, inverse))
    return tuple(q)


def _scaled(c: int, a: Zeroable) -> Zeroable:
    """c · a for a whole c ≥ 1: both ends times c (c > 0 keeps their order), exact for a power of
    two (an overflow to ±∞ only widens), else rounded outward."""
    if c == 1 or a is None:
        return a
    lo, hi = a[0] * float(c), a[1] * float(c)
    return (lo, hi) if c & (c - 1) == 0 else _round(lo, hi)


def _product(u: Node, factors: tuple[int, ...]) -> Zeroable:
    """Π u[i] over `factors` (indices into u), a repeated one as a whole power (u_x² ≥ 0)."""
    parts = [u[i] if factors.count(i) == 1 else whole_power(u[i], factors.count(i))
             for i in sorted(set(factors))]
    out = parts[0]
    for p in parts[1:]:
        out = mul(out, p)
    return out


def _leibniz_terms() -> list[list[tuple[int, int, int]]]:
    """For each derivative α: (C(α, β), index of β, index of α − β) over β ≤ α."""
    return [[(math.comb(ax, bx) * math.comb(ay, by), _AT[(bx, by)], _AT[(ax - bx, ay - by)])
             for bx in range(ax + 1) for by in range(ay + 1)] for ax, ay in DERIVATIVES]


def _partitions(items: list[int]) -> list[list[list[int]]]:
    """Every partition of `items` into non-empty blocks."""
    if not items:
        return [[]]
    first, rest = items[0], items[1:]
    out = []
    for p in _partitions(rest):
        out.append([[first]] + p)
        for i in range(len(p)):
            out.append(p[:i] + [[first] + p[i]] + p[i + 1:])
    return out


def _faa_di_bruno_terms() -> list[list[tuple[int, int, tuple[int, ...]]]]:
    """For each derivative α: (how many partitions give it, k blocks, the blocks' derivative
    indices) over the partitions of α's directions (x x y for ∂xxy) into k blocks."""
    out = []
    for ax, ay in DERIVATIVES:
        directions = [0] * ax + [1] * ay
        count: dict[tuple[int, tuple[int, ...]], int] = {}
        for p in _partitions(list(range(ax + ay))) if ax + ay else []:
            blocks = tuple(sorted(_AT[(sum(1 for i in b if directions[i] == 0),
                                       sum(1 for i in b if directions[i] == 1))] for b in p))
            count[(len(p), blocks)] = count.get((len(p), blocks), 0) + 1
        out.append([(c, k, blocks) for (k, blocks), c in sorted(count.items())])
    return out


_LEIBNIZ = _leibniz_terms()
_FAA_DI_BRUNO = _faa_di_bruno_terms()


def evaluate(form: tuple, X: Interval, Y: Interval, order: int = ORDER) -> Node:
    """Enclosures of the value, the gradient (∂x, ∂y), the Hessian (∂xx, ∂xy, ∂yy) and, to order
    3, the third derivatives (∂xxx, ∂xxy, ∂xyy, ∂yyy) of the checked `form` over the boxes X × Y
    (each an interval of arrays of one shape): `DERIVATIVES`' first 6 or 10."""
    return evaluate_all([form], X, Y, order)[0]


def evaluate_all(forms: list[tuple], X: Interval, Y: Interval, order: int = ORDER) -> list[Node]:
    """`evaluate` of each form, a subexpression they share (x² + y² in three components, the
    angle's cos and sin in a principal field's) enclosed once."""
    shape = X[0].shape
    size = {2: 6, 3: 10}[order]
    zeros = (None,) * (size - 3)      # an exact 0: the derivatives of numbers and of x, y
    one = _const(1.0, shape)
    seen: dict[tuple, Node] = {}
    shared: dict[int, tuple[dict, dict]] = {}   # by a node's id: its functions' values and the
                                                # products of its derivatives (`_compose`)

    def walk(f: tuple) -> Node:
        if f not in seen:
            seen[f] = _walk(f)
        return seen[f]

    def _walk(f: tuple) -> Node:
        kind = f[0]
        if kind == "num":
            return (_const(f[1], shape), None, None) + zeros
        if kind == "var":
            return ((X, one, None) if f[1] == "x" else (Y, None, one)) + zeros
        if kind == "neg":
            return tuple(neg(a) for a in walk(f[1]))
        sign = sign_of(f)
        if sign is not None:
            v = walk(sign[0])[0]
            z = _contains_zero(v)
            val = (np.where(z | (v[0] < 0), -1.0, 1.0), np.where(z | (v[1] > 0), 1.0, -1.0))
            jump = (np.where(z, -INF, 0.0), np.where(z, INF, 0.0))
            s = (val,) + (jump,) * (size - 1)
            return s if sign[1] is None else _times(walk(sign[1]), s)
        step = step_of(f)
        if step is not None:                         # a where u < 0, b where u > 0
            v = walk(step[0])[0]
            z = _contains_zero(v)
            a, b = step[1], step[2]
            below = v[1] < 0
            val = _widen(np.where(z, min(a, b), np.where(below, a, b)),
                         np.where(z, max(a, b), np.where(below, a, b)))
            jump = (np.where(z, -INF, 0.0), np.where(z, INF, 0.0))
            return (val,) + (jump,) * (size - 1)
        if kind == "direction":                      # a polar angle mod π (principal_forms)
            return _direction(walk(f[1]), walk(f[2]), order)
        if kind == "call":
            name = f[1]
            u = walk(f[2])
            values, products = shared.setdefault(id(u), ({}, {}))   # u is kept in `seen`
            if name not in values:
                values[name] = VALUES[name](u[0])
            v = values[name]
            return _compose(v, _slopes(name, u[0], v, order, values), u, products)
        if kind == "**" and f[2][0] == "num":
            u = walk(f[1])
            p = f[2][1]
            if p == 0:
                return (one, None, None) + zeros
            whole = p == round(p) and abs(p) <= 64

            def power(k: int) -> Zeroable:           # p (p − 1) … (p − k + 1) u^(p − k)
                c = math.prod(p - i for i in range(k))
                if c == 0:                           # (u²)''' = 0: an exact 0, even at u = 0
                    return None
                uk = whole_power(u[0], int(p) - k) if whole else real_power(u[0], p - k)
                return uk if k == 0 else mul(_const(c, shape), uk)

            return _compose(power(0), [power(k) for k in range(1, order + 1)], u,
                            shared.setdefault(id(u), ({}, {}))[1])
        if kind == "**":       # b ** e = exp(e · log b)
            return walk(("call", "exp", ("*", f[2], ("call", "log", f[1]))))
        a, b = walk(f[1]), walk(f[2])
        if kind == "+":
            return tuple(add(p, q) for p, q in zip(a, b))
        if kind == "-":
            return tuple(sub(p, q) for p, q in zip(a, b))
        if kind == "*":
            return _times(a, b)
        if kind == "/":
            return _over(a, b)
        raise ValueError(f"not a checked form: {kind!r}")

    filled = _const(0.0, shape)
    with np.errstate(all="ignore"):        # once: the operations above assume it
        return [tuple(filled if v is None else v for v in walk(f)) for f in forms]


def principal_forms(k1: tuple, k2: tuple, angle_deg: tuple) -> list[tuple]:
    """The checked forms of q11, q12, q22 of R diag(k1, k2) Rᵀ, R the rotation by angle_deg
    degrees, through the double angle: m ± d cos 2t and d sin 2t, m = (k1 + k2)/2,
    d = (k1 − k2)/2, t the angle in radians (k1 cos²t + k2 sin²t = m + d cos 2t, (k1 − k2) cos t
    sin t = d sin 2t: the function `TensorField.principal` evaluates, written with one cosine and
    one sine, whose enclosures do not multiply cos t and sin t as if they were independent — on
    the spiral of benchmarks/bench_fields.py its pieces' bounds about 15% lower, and fewer
    operations).

    Q depends on the angle modulo 180° only, so an arctangent of a quotient that the angle holds
    as a term of a whole number of half turns (`180/pi*atan(u/v)`, a polar angle as a direction)
    is enclosed without its jump across v = 0 (`_direction`)."""
    twice = ("*", ("num", math.pi / 90.0), _directions(angle_deg, math.pi / 180.0))
    c, s = ("call", "cos", twice), ("call", "sin", twice)
    m, d = ("*", ("num", 0.5), ("+", k1, k2)), ("*", ("num", 0.5), ("-", k1, k2))
    return [("+", m, ("*", d, c)), ("*", d, s), ("-", m, ("*", d, c))]


def _directions(f: tuple, turns: float) -> tuple:
    """`f` (checked: its numbers folded, `expression.check`) with each arctangent of a quotient
    u/v it holds as a term of `turns` · f worth a whole, non-zero number of half turns marked
    ("direction", u, v): atan(u/v) and sgn(u)·π/2 − atan(v/u) differ by a multiple of π, so
    either may stand for it in a quantity of period π (`_direction` picks one on each box)."""
    kind = f[0]
    if kind in ("+", "-"):
        return (kind, _directions(f[1], turns), _directions(f[2], turns))
    if kind == "neg":
        return ("neg", _directions(f[1], -turns))
    if kind == "*":
        for i, j in ((1, 2), (2, 1)):
            c = f[i][1] if f[i][0] == "num" else None
            if c is not None and c != 0:
                parts = [f[1], f[2]]
                parts[j - 1] = _directions(f[j], turns * c)
                return ("*", parts[0], parts[1])
        return f
    if kind == "/":
        c = f[2][1] if f[2][0] == "num" else None
        return f if c is None or c == 0 else ("/", _directions(f[1], turns / c), f[2])
    if kind == "call" and f[1] in ("atan", "arctan") and f[2][0] == "/":
        k = round(turns)                     # a jump of π in atan(u/v) moves turns · f by k·π
        if k != 0 and abs(turns - k) <= 1e-12 * abs(k):
            return ("direction", f[2][1], f[2][2])
    return f


def _direction(u: Node, v: Node, order: int = ORDER) -> Node:
    """atan(u/v) to the nodes' order, or sgn(u)·π/2 − atan(v/u) on the boxes where u keeps its sign
    and stays farther from 0 than v does (v changing sign among them): equal modulo π, and the
    quotient by the one farther from 0 has the narrower enclosures, its derivatives (those of
    atan(u/v), continuous across v = 0) included."""
    flip = ~_contains_zero(u[0]) & (_contains_zero(v[0]) | (_least(u[0]) > _least(v[0])))
    if not flip.any():
        return _atan_of(_over(u, v), order)
    shape = u[0][0].shape
    if flip.all():
        turned_at, straight_at = slice(None), np.zeros(0, np.intp)
    else:                                    # each branch on its own boxes only
        turned_at, straight_at = np.flatnonzero(flip), np.flatnonzero(~flip)
    ut, vt = _take(u, turned_at), _take(v, turned_at)
    half = np.where(ut[0][0] > 0, 0.5 * math.pi, -0.5 * math.pi)
    turned = _atan_of(_over(vt, ut), order)
    turned = (sub(_widen(half, half), turned[0]),) + tuple(neg(d) for d in turned[1:])
    if isinstance(turned_at, slice):
        return turned
    straight = _atan_of(_over(_take(u, straight_at), _take(v, straight_at)), order)
    out = []
    for a, b in zip(straight, turned):
        if a is None and b is None:
            out.append(None)
            continue
        lo, hi = np.zeros(shape), np.zeros(shape)
        for at, part in ((straight_at, a), (turned_at, b)):
            if part is not None:
                lo[at], hi[at] = part
        out.append((lo, hi))
    return tuple(out)


def _take(node: Node, at: NDArray[np.intp] | slice) -> Node:
    """The node on the boxes `at` (a point stays a point: `mul` tells it by its ends' identity)."""
    if isinstance(at, slice):
        return node
    out = []
    for e in node:
        if e is None:
            out.append(None)
        elif e[0] is e[1]:
            p = e[0][at]
            out.append((p, p))
        else:
            out.append((e[0][at], e[1][at]))
    return tuple(out)


def _least(a: Interval) -> Array:
    """min |t| over each interval (0 where it holds 0)."""
    return np.where(_contains_zero(a), 0.0, np.minimum(np.abs(a[0]), np.abs(a[1])))


def _atan_of(q: Node, order: int = ORDER) -> Node:
    """atan(q) to the node's order."""
    value = VALUES["atan"](q[0])
    return _compose(value, _slopes("atan", q[0], value, order), q)
