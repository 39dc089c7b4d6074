"""Text fields a sampled rule can fool, each with what an exact mean needs to know of it.

Jumps written with abs(u)/u (a sign; a Heaviside step is (1 + sign)/2) along lines at any
position and angle — principal fields whose angle jumps by 90°, on constant or turning pieces,
two crossing jumps, a step between two tensors — narrow ramps written with abs (min and max: a
kink at each side), Gaussian bumps (two a field) and ridges 0.003–0.03 wide; anisotropy
10–1e3. Each `Case` holds the text field qmesh meshes and, written again with NumPy, Q between
its jump lines with the lines themselves, and its bumps and ridges as Q = Q_base + Σ g_k M_k:
`exact_means` needs nothing of qmesh to compute its element means (`means`). The parser has no
sign, Heaviside, min, max or floor: abs spells them all but floor."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

import numpy as np

import qmesh
from tests.fields import exact_means as em
from tests.fields.reference import principal

KINDS = ("angle jump", "turning angle jump", "crossing jumps", "tensor step", "narrow ramp",
         "bumps", "ridge")
WIDTHS = (0.003, 0.03)          # of bumps, ridges and ramps
ANISOTROPY = (10.0, 1e3)


@dataclass
class Case:
    """A text field (`field()`), and Q written with NumPy: `base(x, y)` → (n, 2, 2) smooth between
    the `lines` (a, b, c): a x + b y = c, plus g_k M_k for each bump (centre, width, M) and ridge
    (normal, u0, width, M), g = exp(−r²/width²)."""

    name: str
    kind: str
    make: Callable[[], qmesh.TensorField]
    base: Callable[[np.ndarray, np.ndarray], np.ndarray]
    lines: list = dataclasses.field(default_factory=list)
    bumps: list = dataclasses.field(default_factory=list)
    ridges: list = dataclasses.field(default_factory=list)

    def field(self) -> qmesh.TensorField:
        return self.make()

    def Q(self, x, y):
        """Q at points, from the NumPy form (to compare with the text's values)."""
        x, y = np.asarray(x, float), np.asarray(y, float)
        q = self.base(x, y).copy()
        for c, w, M in self.bumps:
            q += np.exp(-((x - c[0]) ** 2 + (y - c[1]) ** 2) / w ** 2)[:, None, None] * M
        for n, u0, w, M in self.ridges:
            q += np.exp(-(n[0] * x + n[1] * y - u0) ** 2 / w ** 2)[:, None, None] * M
        return q

    def means(self, P, T):
        """The exact element means (M, 2, 2) over the triangles T (M, 3) of P, and an estimate
        of their own error (M,): clipping along the lines, bumps and ridges by `exact_means`."""
        P, T = np.asarray(P, float), np.asarray(T)
        Q, err = em.clipped_means(self.base, P, T, self.lines)
        for c, w, M in self.bumps:
            g, e = em.bump_means(P, T, c, w)
            Q = Q + g[:, None, None] * M
            err = err + e * np.linalg.norm(M)
        for n, u0, w, M in self.ridges:
            Q = Q + em.ridge_means(P, T, n, u0, w)[:, None, None] * M
        return Q, err


def _num(v: float) -> float:
    """v to 6 significant digits: the number the text and the NumPy form both use."""
    return float(f"{v:.6g}")


def _line(rng):
    """A line through a point of [0.2, 0.8]² at any angle: (a, b, c) for a x + b y = c, the larger
    of |a|, |b| 1, and u = a x + b y − c as text (few syntax nodes: the parser allows 80)."""
    phi = rng.uniform(0, np.pi)
    p = rng.uniform(0.2, 0.8, 2)
    a, b = np.cos(phi), np.sin(phi)
    a, b = (1.0, _num(b / a)) if abs(a) >= abs(b) else (_num(a / b), 1.0)
    c = _num(a * p[0] + b * p[1])

    def term(v, name):
        return name if v == 1.0 else f"{abs(v)!r}*{name}"
    first = term(a, "x") if a > 0 else f"-{term(a, 'x')}"
    return (a, b, c), (f"({first} {'+' if b > 0 else '-'} {term(b, 'y')} "
                       f"{'-' if c >= 0 else '+'} {abs(c)!r})")


def _sign(u: str) -> str:
    return f"abs{u}/{u}"


def _u(line, x, y):
    a, b, c = line
    return a * x + b * y - c


def _K(rng) -> float:
    return _num(10 ** rng.uniform(*np.log10(ANISOTROPY)))


def _width(rng) -> float:
    return _num(10 ** rng.uniform(*np.log10(WIDTHS)))


def draw(kind: str, rng: np.random.Generator, name: str | None = None) -> Case:
    """A case of `kind` (one of KINDS) with its parameters drawn from `rng`."""
    K, theta = _K(rng), _num(rng.uniform(0, 180))
    name = name or kind
    if kind == "angle jump":            # the angle theta on one side, theta + 90 on the other
        line, u = _line(rng)
        text = f"{theta!r} + 45 - 45*{_sign(u)}"
        return Case(name, kind, lambda: qmesh.TensorField.principal(K, 1, text),
                    lambda x, y: principal(K, 1.0, theta + np.where(_u(line, x, y) > 0, 0.0, 90.0)),
                    [line])
    if kind == "turning angle jump":    # the same, on pieces whose angle turns
        line, u = _line(rng)
        r = _num(rng.uniform(-60, 60))
        text = f"{theta!r} + {r!r}*x*y + 45 - 45*{_sign(u)}"
        return Case(name, kind, lambda: qmesh.TensorField.principal(K, 1, text),
                    lambda x, y: principal(K, 1.0, theta + r * x * y
                                           + np.where(_u(line, x, y) > 0, 0.0, 90.0)), [line])
    if kind == "crossing jumps":        # four quadrants, 90° apart across each line: sign(u1 u2)
        (l1, u1), (l2, u2) = _line(rng), _line(rng)
        text = f"{theta!r} + 45 - 45*{_sign(f'({u1}*{u2})')}"
        return Case(name, kind, lambda: qmesh.TensorField.principal(K, 1, text),
                    lambda x, y: principal(K, 1.0, theta + np.where(
                        (_u(l1, x, y) > 0) == (_u(l2, x, y) > 0), 0.0, 90.0)), [l1, l2])
    if kind == "tensor step":           # Q1 where u < 0, Q2 where u > 0: (1 + sign)/2
        line, u = _line(rng)
        K2, theta2 = _K(rng), _num(rng.uniform(0, 180))
        Q1, Q2 = principal(K, 1.0, theta), principal(K2, 1.0, theta2)
        q1 = [_num(v) for v in (Q1[0, 0], Q1[0, 1], Q1[1, 1])]
        half = [_num(0.5 * (b - a)) for a, b in zip(q1, (Q2[0, 0], Q2[0, 1], Q2[1, 1]))]
        if q1[0] * q1[2] - q1[1] ** 2 <= 0 or all(h == 0 for h in half):
            return draw(kind, rng, name)        # rounded into not positive definite, or no step
        texts = [f"{a!r} + {h!r}*(1 + {_sign(u)})" for a, h in zip(q1, half)]

        def step(x, y):
            H = np.where(_u(line, x, y) > 0, 2.0, 0.0)
            q = [a + h * H for a, h in zip(q1, half)]
            return np.stack([np.stack([q[0], q[1]], -1), np.stack([q[1], q[2]], -1)], -2)
        return Case(name, kind, lambda: qmesh.TensorField.from_expressions(*texts), step, [line])
    if kind == "narrow ramp":           # k2 from K to 1 across a band w wide: kinks at its sides
        line, u = _line(rng)
        w = _width(rng)
        ramp = f"(abs{u} - abs({u} - {w!r}) + {w!r})/(2*{w!r})"     # 0, then u/w, then 1
        a, b, c = line

        def k2(x, y):
            v = _u(line, x, y)
            return K - _num(K - 1) * (np.abs(v) - np.abs(v - w) + w) / (2 * w)
        text = f"{K!r} - {_num(K - 1)!r}*{ramp}"
        return Case(name, kind, lambda: qmesh.TensorField.principal(K, text, theta),
                    lambda x, y: principal(K, k2(x, y), theta), [line, (a, b, c + w)])
    base = (lambda x, y: np.broadcast_to(principal(K, 1.0, theta), (len(x), 2, 2)))
    across = _num(K - 1) * principal(0.0, 1.0, theta)       # k2's direction: what a bump adds
    if kind == "bumps":                 # two, k2 from 1 to K at each centre (three: 119 nodes)
        bumps = [(np.array([_num(v) for v in rng.uniform(0.05, 0.95, 2)]), _width(rng))
                 for _ in range(2)]
        g = " + ".join(f"exp(-((x - {float(c[0])!r})**2 + (y - {float(c[1])!r})**2)/{_num(w * w)!r})"
                      for c, w in bumps)
        text = f"1 + {_num(K - 1)!r}*({g})"
        return Case(name, kind, lambda: qmesh.TensorField.principal(K, text, theta),
                    base, bumps=[(c, np.sqrt(_num(w * w)), across) for c, w in bumps])
    if kind == "ridge":                 # k2 from 1 to K along a line
        (a, b, c), u = _line(rng)
        w = _width(rng)
        text = f"1 + {_num(K - 1)!r}*exp(-{u}**2/{_num(w * w)!r})"
        return Case(name, kind, lambda: qmesh.TensorField.principal(K, text, theta),
                    base, ridges=[(np.array([a, b]), c, np.sqrt(_num(w * w)), across)])
    raise ValueError(kind)


def drawn(rng: np.random.Generator, draws: int = 2) -> list[Case]:
    """`draws` cases of each kind, named "<kind> 1", "<kind> 2", …, drawn in KINDS' order (the
    cases of benchmarks/cert_truth.py for a seed's `rng`)."""
    return [draw(kind, rng, f"{kind} {d + 1}") for kind in KINDS for d in range(draws)]


def fooled_jump() -> Case:
    """The jump a sampled rule certified falsely: 0° above x + 0.3 y = 0.537, 90° below."""
    line = (1.0, 0.3, 0.537)
    text = "45 - 45*abs(x + 0.3*y - 0.537)/(x + 0.3*y - 0.537)"
    return Case("0° | 90° across x + 0.3y = 0.537", "angle jump",
                lambda: qmesh.TensorField.principal(100, 1, text),
                lambda x, y: principal(100.0, 1.0, np.where(_u(line, x, y) > 0, 0.0, 90.0)), [line])


def diagonal_jump() -> Case:
    """0° above the unit square's diagonal x + y = 1, 90° below: the mesher's points are
    symmetric about it, so samples fall on the line (where abs(u)/u is 0/0)."""
    text = "45 - 45*abs(x + y - 1)/(x + y - 1)"
    return Case("0° | 90° across x + y = 1", "angle jump",
                lambda: qmesh.TensorField.principal(100, 1, text),
                lambda x, y: principal(100.0, 1.0, np.where(x + y > 1, 0.0, 90.0)), [(1.0, 1.0, 1.0)])
