"""Hypothesis strategies for conductivity fields (`qmesh.TensorField`) on any domain.

Four kinds, each placed in the frame of the domain it is drawn for, u = (x − c)/L with c and L
the domain's centre and size (so a field turns across the domain, not across a millionth of it):
`principal` texts (k1, k2 and an angle in degrees that turns at most a few times), three
`from_expressions` texts (SPD by construction), a smooth callable, and a small raster covering
the domain. Anisotropy up to ~1e3.

Each draws a `FieldSpec`: a runnable `code`, `build` (the TensorField) and `Q_at`, the same
field computed here with NumPy (the evaluator's own Q at a point: a corner's metric angle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from hypothesis import strategies as st

import qmesh
from strategies import Case, ConductivitySpec, DomainSpec, _rotation, options

MAX_ANISOTROPY = 1e3


@dataclass(frozen=True)
class FieldSpec:
    """A TensorField: `build()` makes it, `Q_at(P)` is Q at points P (n, 2) → (n, 2, 2)."""

    kind: str
    code: str
    build: Callable = field(repr=False, compare=False)
    Q_at: Callable = field(repr=False, compare=False)


def principal_tensors(k1, k2, angle_deg) -> np.ndarray:
    """R diag(k1, k2) Rᵀ for arrays of principal values and angles (degrees): (n, 2, 2)."""
    t = np.radians(np.asarray(angle_deg, dtype=float))
    c, s = np.cos(t), np.sin(t)
    k1, k2 = np.broadcast_arrays(np.asarray(k1, dtype=float), np.asarray(k2, dtype=float))
    q11, q12, q22 = k1 * c * c + k2 * s * s, (k1 - k2) * c * s, k1 * s * s + k2 * c * c
    return np.stack([np.stack([q11, q12], -1), np.stack([q12, q22], -1)], -2)


def frame(domain: DomainSpec) -> tuple[tuple[float, float], float]:
    """The domain's centre (Python floats: their repr is a number in a text) and size."""
    return (float(domain.center[0]), float(domain.center[1])), float(domain.size)


def _uv_text(c, L) -> tuple[str, str]:
    return f"((x - ({c[0]!r}))/{L!r})", f"((y - ({c[1]!r}))/{L!r})"


def _uv(P, c, L):
    P = np.asarray(P, dtype=float)
    return (P[:, 0] - c[0]) / L, (P[:, 1] - c[1]) / L


def bounds(domain: DomainSpec) -> tuple[np.ndarray, np.ndarray]:
    """The domain's bounding box (lo, hi): a raster must cover it."""
    rings = domain.rings if domain.rings is not None else domain.build().rings
    P = np.concatenate([np.asarray(R, dtype=float) for R in rings])
    return P.min(axis=0), P.max(axis=0)


def _ratio(draw) -> float:
    return 10.0 ** draw(st.floats(0, math.log10(MAX_ANISOTROPY)))


# --------------------------------------------------------------------------- the four kinds

@st.composite
def principal_fields(draw, domain: DomainSpec):
    """principal(k1, k2, angle) texts: k1 = K(1 + A sin(w u + p)), k2 = k1/ratio · exp(B v),
    angle = t0 + T·u or t0 + T·sin(w v) with T up to a turn or so across the domain."""
    c, L = frame(domain)
    U, V = _uv_text(c, L)
    K = 10.0 ** draw(st.floats(-3, 3))
    A, w, p = draw(st.floats(0, 0.9)), draw(st.floats(0, 4)), draw(st.floats(0, 6.3))
    ratio, B = _ratio(draw), draw(st.floats(-1, 1))
    t0, T, w2 = draw(st.floats(0, 180)), draw(st.floats(-360, 360)), draw(st.floats(0.5, 3))
    linear = draw(st.booleans())
    k1 = f"{K!r}*(1 + {A!r}*sin({w!r}*{U} + {p!r}))"
    k2 = f"{K / ratio!r}*exp({B!r}*{V})"
    angle = f"{t0!r} + {T!r}*{U}" if linear else f"{t0!r} + {T!r}*sin({w2!r}*{V})"

    def Q_at(P):
        u, v = _uv(P, c, L)
        a = K * (1 + A * np.sin(w * u + p))
        return principal_tensors(a, K / ratio * np.exp(B * v),
                                 t0 + T * u if linear else t0 + T * np.sin(w2 * v))

    code = f"qmesh.TensorField.principal({k1!r}, {k2!r}, {angle!r})"
    return FieldSpec("principal", code, lambda: qmesh.TensorField.principal(k1, k2, angle), Q_at)


@st.composite
def expression_fields(draw, domain: DomainSpec):
    """from_expressions(q11, q12, q22): a(1 + b u²), e·tanh(u v), c(1 + d v²) with |e| < 0.9√(ac),
    so |q12| < 0.9√(q11 q22): SPD everywhere, anisotropy up to ~1e3 (a/c) and more where the
    off-diagonal is near its bound."""
    c0, L = frame(domain)
    U, V = _uv_text(c0, L)
    a = 10.0 ** draw(st.floats(-3, 3))
    c = a / _ratio(draw) if draw(st.booleans()) else a * _ratio(draw)
    b, d = draw(st.floats(0, 3)), draw(st.floats(0, 3))
    e = draw(st.floats(-0.9, 0.9)) * math.sqrt(a * c)
    q11, q12, q22 = f"{a!r}*(1 + {b!r}*{U}**2)", f"{e!r}*tanh({U}*{V})", f"{c!r}*(1 + {d!r}*{V}**2)"

    def Q_at(P):
        u, v = _uv(P, c0, L)
        x11, x12, x22 = a * (1 + b * u * u), e * np.tanh(u * v), c * (1 + d * v * v)
        return np.stack([np.stack([x11, x12], -1), np.stack([x12, x22], -1)], -2)

    code = f"qmesh.TensorField.from_expressions({q11!r}, {q12!r}, {q22!r})"
    return FieldSpec("expressions", code, lambda: qmesh.TensorField.from_expressions(q11, q12, q22), Q_at)


def swirl(center, L: float, k: float, ratio: float, t0: float, turn: float, w: float, phase: float):
    """Q(x, y) = principal(k, k/ratio, t0 + turn·sin(w·u + phase)) degrees, u = (x − cx)/L:
    a smooth callable whose axis swings by up to ±turn across the domain."""
    c = np.asarray(center, dtype=float)

    def f(x, y):
        u = (np.asarray(x, dtype=float) - c[0]) / L
        return principal_tensors(k, k / ratio, t0 + turn * np.sin(w * u + phase))

    return f


@st.composite
def callable_fields(draw, domain: DomainSpec):
    """TensorField(swirl(...)), with or without `resolution` (a tenth to a hundredth of L)."""
    c, L = frame(domain)
    args = (tuple(map(float, c)), L, 10.0 ** draw(st.floats(-3, 3)), _ratio(draw),
            draw(st.floats(0, 180)), draw(st.floats(0, 180)), draw(st.floats(0.5, 4)),
            draw(st.floats(0, 6.3)))
    resolution = None if draw(st.booleans()) else L * 10.0 ** draw(st.floats(-2, -1))
    f = swirl(*args)

    def Q_at(P):
        P = np.asarray(P, dtype=float)
        return f(P[:, 0], P[:, 1])

    code = f"qmesh.TensorField(field_strategies.swirl{args!r}, resolution={resolution!r})"
    return FieldSpec("callable", code, lambda: qmesh.TensorField(swirl(*args), resolution=resolution), Q_at)


def raster(lo, hi, nx: int, ny: int, k: float, ratio: float, spread: float, smooth: bool, rng_seed: int):
    """Cell edges covering [lo, hi] (1% margin) and cells k1 = k·10^(±spread), k2 = k1/ratio,
    angles either a smooth ramp across the raster or random per cell: (x, y, k1, k2, angle)."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    pad = 0.01 * (hi - lo) + 1e-12 * np.abs(np.concatenate([lo, hi])).max()
    x = np.linspace(lo[0] - pad[0], hi[0] + pad[0], nx + 1)
    y = np.linspace(lo[1] - pad[1], hi[1] + pad[1], ny + 1)
    x[0], x[-1] = min(x[0], lo[0]), max(x[-1], hi[0])
    y[0], y[-1] = min(y[0], lo[1]), max(y[-1], hi[1])
    rng = np.random.default_rng(rng_seed)
    k1 = k * 10.0 ** rng.uniform(-spread, spread, (ny, nx))
    k2 = k1 / ratio
    if smooth:
        j, i = np.mgrid[0:ny, 0:nx]
        angle = rng.uniform(0, 180) + 90 * (i / max(nx - 1, 1) + j / max(ny - 1, 1))
    else:
        angle = rng.uniform(0, 180, (ny, nx))
    return x, y, k1, k2, angle


@st.composite
def raster_fields(draw, domain: DomainSpec):
    """from_raster on 1…10 × 1…10 cells covering the domain's bounding box."""
    lo, hi = bounds(domain)
    args = (tuple(map(float, lo)), tuple(map(float, hi)), draw(st.integers(1, 10)),
            draw(st.integers(1, 10)), 10.0 ** draw(st.floats(-3, 3)), _ratio(draw),
            draw(st.floats(0, 1)), draw(st.booleans()), draw(st.integers(0, 2**31 - 1)))
    x, y, k1, k2, angle = raster(*args)

    def Q_at(P):
        P = np.asarray(P, dtype=float)
        i = np.clip(np.searchsorted(x, P[:, 0], side="right") - 1, 0, len(x) - 2)
        j = np.clip(np.searchsorted(y, P[:, 1], side="right") - 1, 0, len(y) - 2)
        return principal_tensors(k1[j, i], k2[j, i], angle[j, i])

    code = f"qmesh.TensorField.from_raster(*field_strategies.raster{args!r})"
    return FieldSpec("raster", code, lambda: qmesh.TensorField.from_raster(*raster(*args)), Q_at)


FIELD_KINDS = {"principal": principal_fields, "expressions": expression_fields,
               "callable": callable_fields, "raster": raster_fields}


def fields(domain: DomainSpec, kinds=tuple(FIELD_KINDS)):
    """Any of the field kinds, for this domain."""
    return st.one_of(*[FIELD_KINDS[k](domain) for k in kinds])


def constant_tensor(draw) -> tuple[str, Callable, np.ndarray]:
    """A random constant SPD Q (anisotropy up to 1e3, any angle): its code, builder and matrix."""
    k1 = 10.0 ** draw(st.floats(-3, 3))
    k2 = k1 / _ratio(draw)
    angle = draw(st.floats(0, 180))
    R = _rotation(math.radians(angle))
    return (f"qmesh.Anisotropy.principal({k1!r}, {k2!r}, {angle!r})",
            lambda: qmesh.Anisotropy.principal(k1, k2, angle), R @ np.diag([k1, k2]) @ R.T)


def field_spec(f: FieldSpec) -> ConductivitySpec:
    """The field as a case's conductivity (region 0's Q_at)."""
    return ConductivitySpec(f.code, f.build, None, {0: f.Q_at})


@st.composite
def field_cases(draw, domains, kinds=tuple(FIELD_KINDS), max_target: int = 2000):
    """A domain, a field drawn for it, and the mesher's options."""
    spec = draw(domains)
    f = draw(fields(spec, kinds))
    return Case(spec, field_spec(f), draw(options(spec.n_points, None, max_target)))
