"""Hypothesis strategies for the property suite: domains, conductivities and mesher options.

The kinds of input: regular, random convex and very thin convex polygons at scales
1e-6…1e6 placed up to 1e6 from the origin; random SPD Q with anisotropy up to 1e4 at any angle
and smooth varying s; boundary refinement on and off, targets from just above the seed count to a
few thousand, random α and thresholds. Non-convex outlines with holes are drawn when
`qmesh.Domain` exists.

Each strategy draws a plain description (numbers and arrays) with a `code` string that rebuilds
it, so a failure is reported as a runnable reproducer; the qmesh objects are built inside the
test (`Case.build_domain`), because a valid polygon that qmesh refuses is itself a defect.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from hypothesis import settings
from hypothesis import strategies as st

import qmesh

HAS_DOMAIN = hasattr(qmesh, "Domain")
MAX_TARGET = 3000


def examples(share: float) -> settings:
    """The active profile (HYPOTHESIS_PROFILE, default "ci"; registered in conftest.py) with
    `share` of its max_examples for this test."""
    parent = settings.get_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
    return settings(parent, max_examples=max(1, math.ceil(parent.max_examples * share)))


# --------------------------------------------------------------------------- descriptions

@dataclass(frozen=True)
class DomainSpec:
    """A domain as the user gives it: rings (outline first, then holes) in any orientation.

    `build` makes the qmesh object; `rings` is None when the corners are qmesh's own (a Disk),
    then they are read from the built domain. `center` and `size` place it (for a varying s).
    """

    kind: str
    code: str
    build: Callable = field(repr=False, compare=False)
    n_points: int = 0
    rings: tuple | None = field(default=None, repr=False, compare=False)
    center: tuple = (0.0, 0.0)
    size: float = 1.0
    regions: tuple = field(default=(), repr=False, compare=False)
    """A medium's region rings (region k + 1 is regions[k]; the rest of Ω is region 0)."""

    @property
    def n_holes(self) -> int:
        return 0 if self.rings is None else len(self.rings) - 1


@dataclass(frozen=True)
class ConductivitySpec:
    """An anisotropy: `build` makes it; `Q` is the constant conductivity, None for a varying s.

    `Q_of`, for a field or a medium: region tag → Q_at(P) (n, 2) → (n, 2, 2), the conductivity
    computed by the strategy itself (tag 0 alone for a field on a plain domain)."""

    code: str
    build: Callable = field(repr=False, compare=False)
    Q: np.ndarray | None = field(default=None, repr=False, compare=False)
    Q_of: dict | None = field(default=None, repr=False, compare=False)


@dataclass(frozen=True)
class Case:
    domain: DomainSpec
    conductivity: ConductivitySpec
    options: dict

    def reproducer(self) -> str:
        opts = ", ".join(f"{k}={v!r}" for k, v in self.options.items())
        return f"qmesh.mesh({self.domain.code}, {self.conductivity.code}, {opts})"

    def __repr__(self):
        return self.reproducer()

    def _repr_pretty_(self, p, cycle):      # how hypothesis prints a failing example
        p.text(self.reproducer())


def _fmt(P: np.ndarray) -> str:
    return repr(np.asarray(P).tolist())


def polygon_spec(kind: str, outline: np.ndarray, holes=(), center=(0.0, 0.0), size=1.0) -> DomainSpec:
    """A Polygon (no holes, convex: it works on today's core) or a Domain (holes or non-convex)."""
    outline = np.asarray(outline, dtype=float)
    holes = tuple(np.asarray(h, dtype=float) for h in holes)
    if holes or kind in ("star", "holed", "named"):
        code = f"qmesh.Domain({_fmt(outline)}, [{', '.join(_fmt(h) for h in holes)}])"
        build = (lambda: qmesh.Domain(outline, list(holes)))
    else:
        code = f"qmesh.Polygon({_fmt(outline)})"
        build = (lambda: qmesh.Polygon(outline))
    return DomainSpec(kind, code, build, len(outline) + sum(map(len, holes)), (outline,) + holes,
                      tuple(map(float, center)), float(size))


def moved(spec: DomainSpec, shift, scale: float) -> DomainSpec:
    """The same domain given as rings scaled by `scale` about the origin then shifted."""
    rings = spec.rings if spec.rings is not None else (np.asarray(spec.build().points),)
    new = [np.asarray(R) * scale + np.asarray(shift, dtype=float) for R in rings]
    center = np.asarray(spec.center) * scale + np.asarray(shift, dtype=float)
    kind = spec.kind if spec.kind != "regular" else "convex"
    return polygon_spec(kind, new[0], new[1:], center, spec.size * scale)


# --------------------------------------------------------------------------- placement

def sizes():
    """Domain sizes 1e-6…1e6, log-uniform."""
    return st.floats(-6, 6).map(lambda e: 10.0 ** e)


@st.composite
def offsets(draw):
    """The domain's centre: the origin, or up to 1e6 away in any direction."""
    if draw(st.booleans()):
        return (0.0, 0.0)
    d = 10.0 ** draw(st.floats(-6, 6))
    t = draw(st.floats(0, 2 * np.pi))
    return (d * math.cos(t), d * math.sin(t))


def _rotation(t: float) -> np.ndarray:
    return np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])


@st.composite
def _angles(draw, n: int, min_gap: float = 0.2) -> np.ndarray:
    """n increasing angles in [t0, t0 + 2π) whose gaps are in the ratio min_gap…1 to each other."""
    gaps = np.array(draw(st.lists(st.floats(min_gap, 1.0), min_size=n, max_size=n)))
    t0 = draw(st.floats(0, 2 * np.pi))
    return t0 + 2 * np.pi * np.concatenate([[0.0], np.cumsum(gaps)[:-1]]) / gaps.sum()


# --------------------------------------------------------------------------- domains

@st.composite
def regular_domains(draw, max_vb: int = 64):
    """qmesh.Disk(vb, radius, center): the chapter's regular polygons, anywhere, any size."""
    vb = draw(st.integers(3, max_vb))
    radius = draw(sizes())
    center = draw(offsets())
    code = f"qmesh.Disk({vb}, radius={radius!r}, center={center!r})"
    return DomainSpec("regular", code, lambda: qmesh.Disk(vb, radius=radius, center=center),
                      vb, None, center, radius)


@st.composite
def convex_domains(draw, max_points: int = 24, max_aspect: float = 10.0, kind: str = "convex"):
    """Random convex polygons: points on an ellipse of aspect up to `max_aspect`, rotated,
    scaled and moved; given counter-clockwise or clockwise."""
    n = draw(st.integers(3, max_points))
    t = draw(_angles(n))
    aspect = 10.0 ** draw(st.floats(0, math.log10(max_aspect)))
    unit = np.column_stack([np.cos(t), np.sin(t) / aspect]) @ _rotation(draw(st.floats(0, np.pi))).T
    size, center = draw(sizes()), draw(offsets())
    P = np.asarray(center) + size * unit
    if draw(st.booleans()) and HAS_DOMAIN:
        P = P[::-1]
    return polygon_spec(kind, P, (), center, size)


def thin_domains():
    """Very thin convex polygons: 3 to 8 points on an ellipse of aspect up to 1000."""
    return convex_domains(max_points=8, max_aspect=1e3, kind="thin")


@st.composite
def star_rings(draw, n_min: int = 5, n_max: int = 24, r_min: float = 0.5):
    """A simple polygon star-shaped about the origin: radii in [r_min, 1] at increasing angles.

    With n ≥ 5 and gaps in the ratio ½…1 no gap exceeds 2π/3, so every edge stays at least
    r_min·cos(π/3) = r_min/2 from the origin."""
    n = draw(st.integers(max(n_min, 5), n_max))
    t = draw(_angles(n, min_gap=0.5))
    r = np.array(draw(st.lists(st.floats(r_min, 1.0), min_size=n, max_size=n)))
    return np.column_stack([r * np.cos(t), r * np.sin(t)])


@st.composite
def holed_domains(draw, max_holes: int = 3):
    """Non-convex outlines (star-shaped, radii 0.5…1, so every edge is 0.25 or more from the
    origin) with up to three disjoint holes (regular or star-shaped) inside radius 0.23, scaled
    and moved. Needs qmesh.Domain."""
    outline = draw(star_rings())
    k = draw(st.integers(0, max_holes))
    holes = []
    phase = draw(st.floats(0, 2 * np.pi))
    for j in range(k):
        c = 0.0 if k == 1 else 0.13     # centres 0.26 (k = 2) or 0.225 (k = 3) apart
        center = c * np.array([math.cos(phase + 2 * np.pi * j / k), math.sin(phase + 2 * np.pi * j / k)])
        radius = draw(st.floats(0.02, 0.1 if k > 1 else 0.22))
        if draw(st.booleans()):
            m = draw(st.integers(3, 16))
            shape = np.column_stack([np.cos(2 * np.pi * np.arange(m) / m), np.sin(2 * np.pi * np.arange(m) / m)])
        else:
            shape = draw(star_rings(n_min=5, n_max=12, r_min=0.5))
        hole = center + radius * shape
        holes.append(hole[::-1] if draw(st.booleans()) else hole)
    size, shift = draw(sizes()), draw(offsets())
    return polygon_spec("holed", shift + size * outline, [shift + size * h for h in holes], shift, size)


@st.composite
def named_domains(draw):
    """qmesh.domains.NAMED (L-shape, notched square, plate with holes…) rotated, scaled, moved."""
    name = draw(st.sampled_from(sorted(qmesh.domains.NAMED)))
    rings = [np.asarray(R) for R in qmesh.domains.NAMED[name]().rings]
    R = _rotation(draw(st.floats(0, 2 * np.pi)))
    size, shift = draw(sizes()), draw(offsets())
    moved_rings = [shift + size * (P @ R.T) for P in rings]
    return polygon_spec("named", moved_rings[0], moved_rings[1:], shift, size)


def any_domain():
    """Every kind of domain this core can take."""
    kinds = [regular_domains(), convex_domains(), thin_domains()]
    if HAS_DOMAIN:
        kinds += [holed_domains(), named_domains()]
    return st.one_of(*kinds)


# --------------------------------------------------------------------------- conductivities

def principal_q(k1: float, k2: float, angle_deg: float) -> np.ndarray:
    """R diag(k1, k2) Rᵀ, computed here independently of qmesh."""
    R = _rotation(math.radians(angle_deg))
    return R @ np.diag([k1, k2]) @ R.T


@st.composite
def constant_q(draw, max_anisotropy: float = 1e4):
    """Random SPD Q: principal values k1 = 10^(−3…3), k2 = k1·10^(±log10 max_anisotropy), any angle."""
    k1 = 10.0 ** draw(st.floats(-3, 3))
    k2 = k1 * 10.0 ** draw(st.floats(-math.log10(max_anisotropy), math.log10(max_anisotropy)))
    angle = draw(st.floats(0, 180))
    code = f"qmesh.Anisotropy.principal({k1!r}, {k2!r}, {angle!r})"
    return ConductivitySpec(code, lambda: qmesh.Anisotropy.principal(k1, k2, angle), principal_q(k1, k2, angle))


def smooth_s(center, L: float, h1: float, h2: float, angle: float, beta: float, a, gamma: float):
    """A smooth strictly convex s in the frame of the domain, u = (x − center)/L:

        s = L² (½ uᵀH₀u + β log cosh(a·u) + γ|u|⁴/4),   H₀ = R diag(h1, h2) Rᵀ,
        ∇²s = H₀ + β sech²(a·u) a aᵀ + γ(|u|² I + 2 u uᵀ)   (SPD: H₀ is).
    """
    c = np.asarray(center, dtype=float)
    H0 = principal_q(h1, h2, angle)
    a = np.asarray(a, dtype=float)

    def u_of(P):
        return (np.asarray(P, dtype=float) - c) / L

    def s(P):
        u = u_of(P)
        z = u @ a
        r2 = np.einsum("ni,ni->n", u, u)
        return L * L * (0.5 * np.einsum("ni,ij,nj->n", u, H0, u)
                        + beta * (np.logaddexp(z, -z) - math.log(2.0)) + gamma * r2 * r2 / 4)

    def grad(P):
        u = u_of(P)
        r2 = np.einsum("ni,ni->n", u, u)
        return L * (u @ H0 + beta * np.tanh(u @ a)[:, None] * a + gamma * r2[:, None] * u)

    def hessian(P):
        u = u_of(P)
        r2 = np.einsum("ni,ni->n", u, u)
        sech2 = 1.0 / np.cosh(np.clip(u @ a, -300, 300)) ** 2
        return (H0 + beta * sech2[:, None, None] * np.outer(a, a)
                + gamma * (r2[:, None, None] * np.eye(2) + 2 * u[:, :, None] * u[:, None, :]))

    return qmesh.Anisotropy.from_s(s, grad, hessian, label="smooth_s")


@st.composite
def varying_s(draw, domain: DomainSpec):
    """A smooth convex s (`smooth_s`) that varies over the domain, anisotropy up to ~100."""
    h1 = 10.0 ** draw(st.floats(-1, 1))
    h2 = h1 * 10.0 ** draw(st.floats(-2, 2))
    angle = draw(st.floats(0, 180))
    beta = draw(st.floats(0, 5))
    a = (draw(st.floats(-3, 3)), draw(st.floats(-3, 3)))
    gamma = draw(st.floats(0, 2))
    args = (domain.center, domain.size, h1, h2, angle, beta, a, gamma)
    code = f"strategies.smooth_s{args!r}"
    return ConductivitySpec(code, lambda: smooth_s(*args), None)


# --------------------------------------------------------------------------- options

@st.composite
def options(draw, n_seeds: int, boundary_refinement=None, max_target: int = MAX_TARGET):
    """Mesher options: a target just above the seed count (a third of the draws) or log-uniform
    up to `max_target`; α, the quality threshold and the seed at random."""
    low = n_seeds + 1
    if draw(st.integers(0, 2)) == 0:
        target = low + draw(st.integers(0, 8))
    else:
        hi = max(low, max_target)
        target = int(round(10.0 ** draw(st.floats(math.log10(low), math.log10(hi)))))
    br = draw(st.booleans()) if boundary_refinement is None else boundary_refinement
    return {
        "target_vertices": max(low, target),
        "alpha": draw(st.sampled_from([0.5]) | st.floats(0.1, 1.0)),
        "quality_threshold": draw(st.sampled_from([0.5]) | st.floats(0.0, 0.9)),
        "seed": draw(st.integers(0, 2**31 - 1)),
        "boundary_refinement": br,
    }


@st.composite
def cases(draw, domains=None, conductivity: str = "constant", boundary_refinement=None,
          max_target: int = MAX_TARGET):
    """A whole case: a domain, a conductivity ("constant", "varying" or "any") and options."""
    spec = draw(domains if domains is not None else any_domain())
    kind = conductivity if conductivity != "any" else draw(st.sampled_from(["constant", "varying"]))
    cond = draw(constant_q() if kind == "constant" else varying_s(spec))
    opts = draw(options(spec.n_points, boundary_refinement, max_target))
    return Case(spec, cond, opts)
