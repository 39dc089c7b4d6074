"""Hypothesis strategies for heterogeneous media: `qmesh.Domain(..., regions=...)` with 1–3
regions, each region (and the rest, region 0) a constant Q or a field.

Two outlines: a rectangle (half-height a ≤ 1 against half-width 1) cut into one to three slots
along x, each holding a strip across it (two corners on each long side), an inclusion, or a
triangle standing on its lower side (its base on the outline); or a star-shaped outline
(`strategies.star_rings`, every edge 0.25 or more from its centre) with one to three
inclusions inside radius 0.23. Both rotated, scaled 1e-6…1e6 and moved up to 1e6.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import strategies as st

import field_strategies
import qmesh
from strategies import (Case, ConductivitySpec, DomainSpec, _fmt, _rotation, offsets, options,
                        sizes, star_rings)


def _inclusion(draw, center, radius) -> np.ndarray:
    """A regular or star-shaped ring of `radius` about `center`."""
    if draw(st.booleans()):
        m = draw(st.integers(3, 12))
        t = draw(st.floats(0, 2 * np.pi)) + 2 * np.pi * np.arange(m) / m
        shape = np.column_stack([np.cos(t), np.sin(t)])
    else:
        shape = draw(star_rings(n_min=5, n_max=10, r_min=0.4))
    return np.asarray(center) + radius * shape


@st.composite
def _rectangle_layout(draw):
    """(outline, regions) in the unit frame of a rectangle [-1, 1] × [-a, a]."""
    a = draw(st.floats(0.25, 1.0))
    outline = np.array([[-1.0, -a], [1.0, -a], [1.0, a], [-1.0, a]])
    k = draw(st.integers(1, 3))
    width = 2.0 / k
    regions = []
    for j in range(k):
        x0 = -1.0 + j * width
        what = draw(st.sampled_from(["strip", "inclusion", "standing"]))
        if what == "strip":
            f0 = draw(st.floats(0.05, 0.6))
            f1 = draw(st.floats(f0 + 0.1, 0.95))
            l, r = x0 + f0 * width, x0 + f1 * width
            if k == 1 and draw(st.booleans()):        # a strip that is a side of the rectangle
                l = -1.0
            ring = np.array([[l, -a], [r, -a], [r, a], [l, a]])
        elif what == "inclusion":
            radius = 0.4 * min(width / 2, a) * draw(st.floats(0.2, 1.0))
            ring = _inclusion(draw, (x0 + width / 2, draw(st.floats(-0.3, 0.3)) * a), radius)
        else:
            f0 = draw(st.floats(0.05, 0.45))
            f1 = draw(st.floats(0.55, 0.95))
            apex = (x0 + draw(st.floats(0.0, 1.0)) * width, -a + draw(st.floats(0.1, 1.6)) * a)
            ring = np.array([[x0 + f0 * width, -a], [x0 + f1 * width, -a], apex])
        regions.append(ring)
    return outline, regions


@st.composite
def _star_layout(draw):
    """(outline, regions): a star-shaped outline with 1–3 inclusions inside radius 0.23."""
    outline = draw(star_rings())
    k = draw(st.integers(1, 3))
    phase = draw(st.floats(0, 2 * np.pi))
    regions = []
    for j in range(k):
        c = 0.0 if k == 1 else 0.13
        center = c * np.array([math.cos(phase + 2 * np.pi * j / k), math.sin(phase + 2 * np.pi * j / k)])
        regions.append(_inclusion(draw, center, draw(st.floats(0.02, 0.1 if k > 1 else 0.22))))
    return outline, regions


@st.composite
def media_domains(draw):
    """A DomainSpec with `regions`: a rectangle's or a star's layout, rotated, scaled, moved."""
    kind = draw(st.sampled_from(["rectangle", "star"]))
    outline, regions = draw(_rectangle_layout() if kind == "rectangle" else _star_layout())
    R = _rotation(draw(st.floats(0, 2 * np.pi)))
    size, shift = draw(sizes()), np.asarray(draw(offsets()))
    place = (lambda P: shift + size * (np.asarray(P) @ R.T))
    outline, regions = place(outline), tuple(place(r) for r in regions)
    code = (f"qmesh.Domain({_fmt(outline)}, [], regions=[{', '.join(_fmt(r) for r in regions)}])")
    build = (lambda: qmesh.Domain(outline, [], regions=list(regions)))
    return DomainSpec(f"media-{kind}", code, build, len(outline) + sum(map(len, regions)),
                      (outline,), tuple(map(float, shift)), float(size), regions)


@st.composite
def region_conductivity(draw, domain: DomainSpec, field_share: float = 0.5):
    """{tag: Anisotropy | TensorField} for regions 0…k: each a constant or a field."""
    codes, builds, Q_of = [], {}, {}
    for tag in range(len(domain.regions) + 1):
        if draw(st.floats(0, 1)) < field_share:
            f = draw(field_strategies.fields(domain))
            codes.append(f"{tag}: {f.code}")
            builds[tag], Q_of[tag] = f.build, f.Q_at
        else:
            code, build, Q = field_strategies.constant_tensor(draw)
            codes.append(f"{tag}: {code}")
            builds[tag] = build
            Q_of[tag] = (lambda P, Q=Q: np.broadcast_to(Q, (len(P), 2, 2)))
    return ConductivitySpec("{" + ", ".join(codes) + "}",
                            lambda: {t: b() for t, b in builds.items()}, None, Q_of)


@st.composite
def media_cases(draw, max_target: int = 2000):
    """A medium, a conductivity per region, and the mesher's options."""
    spec = draw(media_domains())
    cond = draw(region_conductivity(spec))
    opts = draw(options(spec.n_points, True, max_target))
    return Case(spec, cond, opts)
