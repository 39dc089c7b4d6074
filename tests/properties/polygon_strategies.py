"""Random simple polygons with sharp corners, as users draw them: 5–30 vertices.

Two kinds, both from a NumPy generator seeded by the draw (hypothesis' own floats favour
repeated and round values, which make degenerate polygons rather than random ones):
"spiky" star-shaped polygons (radii 0.02…1 at angles whose gaps stay under 0.9π, so the ring is
simple and star-shaped about the origin; a long radius between two short ones is a spike of a
degree or less), and "untangled" polygons (random points joined in a random order, then 2-opt
moves reverse a stretch wherever two edges cross until none does: the ring is simple, with
corners of any angle). Scaled 1e-6…1e6 and moved up to 1e6; a constant Q or a field.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import strategies as st

import field_strategies
from strategies import Case, ConductivitySpec, offsets, options, polygon_spec, sizes


def spiky_ring(n: int, rng: np.random.Generator) -> np.ndarray:
    """n points at increasing angles (gaps in the ratio 0.3…1: every gap < 0.9π for n ≥ 5),
    radii log-uniform in 0.02…1."""
    gaps = rng.uniform(0.3, 1.0, n)
    t = rng.uniform(0, 2 * np.pi) + 2 * np.pi * np.concatenate([[0.0], np.cumsum(gaps)[:-1]]) / gaps.sum()
    r = 10.0 ** rng.uniform(np.log10(0.02), 0.0, n)
    return np.column_stack([r * np.cos(t), r * np.sin(t)])


def _crossing(P: np.ndarray) -> tuple[int, int] | None:
    """The first pair of non-adjacent edges (i, i+1), (j, j+1) that properly cross, or None."""
    n = len(P)
    A, B = P, np.roll(P, -1, axis=0)
    i, j = np.triu_indices(n, 2)
    keep = ~((i == 0) & (j == n - 1))
    i, j = i[keep], j[keep]

    def side(a, b, c):
        return np.sign((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))

    cross = ((side(A[i], B[i], A[j]) * side(A[i], B[i], B[j]) < 0)
             & (side(A[j], B[j], A[i]) * side(A[j], B[j], B[i]) < 0))
    k = np.flatnonzero(cross)
    return None if len(k) == 0 else (int(i[k[0]]), int(j[k[0]]))


def untangled_ring(n: int, rng: np.random.Generator) -> np.ndarray:
    """n random points in the unit square, untangled by 2-opt: a simple polygon (each move
    shortens the ring, so the moves end)."""
    P = rng.uniform(-1, 1, (n, 2))
    for _ in range(50 * n * n):
        found = _crossing(P)
        if found is None:
            return P
        i, j = found
        P[i + 1:j + 1] = P[i + 1:j + 1][::-1].copy()
    raise RuntimeError("2-opt did not untangle the ring")     # cannot happen: each move shortens it


def far_enough(P: np.ndarray, share: float = 1e-3) -> bool:
    """No point within `share` of the ring's size of a segment it is not an end of."""
    n = len(P)
    A, B = P, np.roll(P, -1, axis=0)
    AB = B - A
    X = P[:, None, :] - A[None]
    t = np.clip(np.einsum("nsi,si->ns", X, AB) / np.einsum("si,si->s", AB, AB), 0, 1)
    d = np.hypot(*(X - t[..., None] * AB[None]).transpose(2, 0, 1))
    k = np.arange(n)
    own = (k[:, None] == k[None]) | (k[:, None] == (k[None] + 1) % n)      # a segment's own ends
    return bool(d[~own].min() > share * np.ptp(P, axis=0).max())


@st.composite
def random_polygons(draw):
    """A spiky or untangled simple polygon of 5–30 vertices, scaled and moved."""
    kind = draw(st.sampled_from(["spiky", "untangled"]))
    n = draw(st.integers(5, 30))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    for _ in range(20):
        P = spiky_ring(n, rng) if kind == "spiky" else untangled_ring(n, rng)
        if far_enough(P):
            break
    size, shift = draw(sizes()), np.asarray(draw(offsets()))
    spec = polygon_spec("star", shift + size * P, (), shift, size)
    return type(spec)(f"polygon-{kind}", spec.code, spec.build, spec.n_points, spec.rings,
                      spec.center, spec.size)


@st.composite
def polygon_cases(draw, max_target: int = 2000, field_share: float = 0.3):
    """A random polygon, a constant Q (anisotropy up to 1e3) or a field, and options with a
    target of 200 or more."""
    spec = draw(random_polygons())
    if draw(st.floats(0, 1)) < field_share:
        cond = field_strategies.field_spec(draw(field_strategies.fields(spec)))
    else:
        code, build, Q = field_strategies.constant_tensor(draw)
        cond = ConductivitySpec(code, build, Q)
    opts = draw(options(spec.n_points, None, max_target))
    # a target the boundary can meet: a refusal for too few vertices says nothing of the corners
    high = math.log10(max(max_target, 200))
    opts["target_vertices"] = int(round(10.0 ** draw(st.floats(math.log10(200), high))))
    return Case(spec, cond, opts)
