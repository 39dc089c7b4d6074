"""Refuse, before anything is built, a formula or callable field no mesh of the asked size can
follow, whose element means cannot be resolved, or which is not integrable on Ω.

A field has no s whose Hessian could be checked (seeding_varying._check_followable does that for
s), so the check reads samples of Q itself, at random points of Ω (uniform by area: a field's
metric has det H = 1, so the vertices are spread by area) and pairs of points about δ apart in
two random perpendicular directions, on a ladder of scales δ = ℓ·2^(−j/2) (ℓ the element's side
at the target):

- turning: the shape S = Q / √det Q changes by more than TURN (relative, Frobenius: a rotation
  of about 45° of a strongly anisotropic Q) across one element over more than SHARE of Ω — the
  mesh cannot follow its directions (an angle in the wrong unit, "1e6*x" degrees);
- unresolved: Q changes by more than UNRESOLVED (relative) across the smallest piece the means'
  quadrature reaches (ℓ·2^−MAX_DEPTH) over more than SHARE of Ω — no element mean can be
  computed to a bound (an oscillation far below the element scale, "2 + sin(1e6*x)");
- not integrable: ‖Q‖·d (‖Q‖ = max |Q_ij|) does not decay as d → 0 along the inward normal at
  points of ∂Ω (‖Q‖ ~ d^−α with α ≥ 1): the means of the elements on that side do not exist
  ("1 + 1/x" on the unit square), for any N.

The first scale of the ladder where each share falls to SHARE gives the vertices that would
follow the field, named in the refusal. Rasters (exact means at any resolution) and constant
fields are not checked. Some 10⁴ evaluations of Q for a field that passes.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from qmesh.conductivity.means import MAX_DEPTH, frobenius
from qmesh.errors import QmeshError
from qmesh.mesher import seeding, sizing

TURN = 1.0          # relative change of Q's shape across one element (≈ 45° at 100 : 1) ...
UNRESOLVED = 0.1    # relative change of Q across the quadrature's smallest piece ...
SHARE = 0.08        # ... over at most this share of Ω's area (seeding_varying.UNFOLLOWED)
SAMPLES = 1024      # random points of Ω
PROBES = 256        # points of ∂Ω whose inward normal is walked towards the boundary
HALVINGS = 40       # the walk's steps: from ℓ/8 to ℓ/8·2^−40
GROWTH = 0.99       # ‖Q‖·d keeps at least this share of itself at each halving: not integrable
SINGULAR = 1e6      # ... and ‖Q‖ has grown this much along the walk

Array = NDArray[np.float64]


def check(domain, field, width: float, target: int | None) -> None:
    """QmeshError naming why and what N would follow, when `field` (a formula or callable
    TensorField) cannot be meshed at element side `width` (`metric.smoothing_width`) on
    `domain`; nothing for rasters and constant fields."""
    if field.means_exact:              # a raster or a constant: exact means at any resolution
        return
    _check_integrable(domain, field, width)
    n = target if target is not None else max(int(2 * domain.area / (np.sqrt(3) * width ** 2)), 1)
    rng = np.random.default_rng(0)
    X = seeding.random_interior(domain, SAMPLES, rng)
    V = _offsets(rng, SAMPLES)
    turn = _first_scale(lambda d: _share(domain, field, X, V, d, shape=True, limit=TURN), n,
                        width)
    if turn:
        _refuse(field, n, turn, target,
                f"its directions turn (its shape Q/√det Q changes by more than {TURN:g}, relative) "
                "across one element")
    finest = width * 0.5 ** MAX_DEPTH
    unresolved = _first_scale(lambda d: _share(domain, field, X, V, d * finest / width,
                                               shape=False, limit=UNRESOLVED), n, width)
    if unresolved:
        _refuse(field, n, unresolved, target,
                f"it changes by more than {100 * UNRESOLVED:g}% across {finest:.2g}, the smallest "
                "piece the element means' quadrature reaches, so no element mean can be computed "
                "to a bound")


def _first_scale(share, n: int, width: float) -> tuple[float, int] | None:
    """None when share(width) ≤ SHARE or share(width/√2) ≤ SHARE (twice the vertices: the repair
    copes); else (the share at width, the vertices of the first scale width·2^(−j/2) where it
    falls to SHARE, or 0 when none below MAX_VERTICES does)."""
    first = share(width)
    if first <= SHARE or share(width / np.sqrt(2)) <= SHARE:
        return None
    j = 2
    while n * 2.0 ** j <= sizing.MAX_VERTICES:
        if share(width * 2.0 ** (-j / 2)) <= SHARE:
            return first, int(n * 2.0 ** j)
        j += 1
    return first, 0


def _share(domain, field, X: Array, V: Array, delta: float, shape: bool, limit: float) -> float:
    """The share of the points X whose Q (or Q's shape) changes by more than `limit`, relative in
    the Frobenius norm, between x ∓ δ/2·v for either of its two offsets v (V (2, n, 2), pairs
    leaving Ω not counted)."""
    worst = np.zeros(len(X))
    for v in 0.5 * delta * V:
        a, b = X - v, X + v
        inside = domain.contains(a, tol=0.0) & domain.contains(b, tol=0.0)
        if not inside.any():
            continue
        Qa, Qb = _components(field, a[inside]), _components(field, b[inside])
        if shape:                      # scaled to about 1 first: det Q may over- or underflow
            Qa, Qb = (q / _size(q)[:, None] for q in (Qa, Qb))
            Qa, Qb = (q / np.sqrt(q[:, 0] * q[:, 2] - q[:, 1] ** 2)[:, None] for q in (Qa, Qb))
        else:                          # both by the same number: their relative change kept
            scale = np.maximum(_size(Qa), _size(Qb))[:, None]
            Qa, Qb = Qa / scale, Qb / scale
        change = frobenius(Qa - Qb) / (0.5 * (frobenius(Qa) + frobenius(Qb)))
        worst[inside] = np.maximum(worst[inside], change)
    return float(np.mean(worst > limit))


def _offsets(rng, n: int) -> Array:
    """Two perpendicular offsets (2, n, 2) per point, of a random direction and a length drawn in
    [½, 1]: a field periodic along a line is not sampled at one phase (a linear angle's change over
    a fixed δ is the same everywhere, a multiple of 180° at some δ)."""
    phi = rng.random(n) * np.pi
    u = 0.5 + 0.5 * rng.random(n)
    return np.stack([u[:, None] * np.column_stack([np.cos(phi), np.sin(phi)]),
                     u[:, None] * np.column_stack([-np.sin(phi), np.cos(phi)])])


def _refuse(field, n: int, found: tuple[float, int], target: int | None, why: str) -> None:
    share, follow = found
    asked = (f"a mesh of {n} vertices" if target is not None
             else f"a mesh of this size (about {n} vertices)")
    advice = (f"about {follow:.2g} vertices would follow it" if follow
              else "no mesh of a usable size would follow it: check its units and scale")
    raise QmeshError(f"the field {field.label} varies faster than {asked} can follow: over "
                     f"{100 * share:.0f}% of the domain {why}; {advice}")


def _check_integrable(domain, field, width: float) -> None:
    """QmeshError when ‖Q‖·d does not decay along the inward normal towards ∂Ω: ∫ ‖Q‖ diverges
    at that side, and no element mean exists there."""
    A, B = domain.segment_ends
    length = np.hypot(*(B - A).T)
    # PROBES points spread by length over ∂Ω, off the segments' ends (corners)
    s = (np.arange(PROBES) + 0.5) / PROBES * length.sum()
    k = np.minimum(np.searchsorted(np.cumsum(length), s, side="right"), len(length) - 1)
    t = np.clip((s - (np.cumsum(length) - length)[k]) / length[k], 0.05, 0.95)[:, None]
    P = A[k] + t * (B[k] - A[k])
    normal = np.column_stack([-(B - A)[k, 1], (B - A)[k, 0]]) / length[k, None]
    d = width / 8 * 0.5 ** np.arange(HALVINGS + 1)
    extent = float(np.max(np.abs(np.concatenate([A, B]))))
    d = d[d > 64 * np.finfo(float).eps * extent]           # points still apart from ∂Ω
    if len(d) < 10:
        return
    side = np.where(domain.contains(P + d[-1] * normal, tol=0.0), 1.0, -1.0)[:, None]
    ladder = P[:, None, :] + side[:, :, None] * d[None, :, None] * normal[:, None, :]
    inside = domain.contains(ladder.reshape(-1, 2), tol=0.0).reshape(len(P), len(d)).all(axis=1)
    if not inside.any():
        return
    walk = ladder[inside]
    size = _size(_components(field, walk.reshape(-1, 2))).reshape(len(walk), len(d))
    mass = size * d                                          # ‖Q‖·d at each step
    tail = mass[:, -10:]
    diverging = (np.all(tail[:, 1:] >= GROWTH * tail[:, :-1], axis=1)
                 & (size[:, -1] >= SINGULAR * size[:, 0]))
    if diverging.any():
        i = int(np.flatnonzero(diverging)[0])
        p = P[inside][i]
        raise QmeshError(f"the field {field.label} is not integrable on the domain: towards the "
                         f"boundary at ({p[0]:.6g}, {p[1]:.6g}) max |Q_ij| grows like 1/distance "
                         f"or faster ({size[i, 0]:.3g} at {d[0]:.3g}, {size[i, -1]:.3g} at "
                         f"{d[-1]:.3g}), so "
                         "the element means beside it do not exist for any number of vertices")


def _components(field, P: Array) -> Array:
    """(q11, q12, q22) of the checked field at points P (n, 2)."""
    Q = np.asarray(field(P), dtype=float)
    return np.column_stack([Q[:, 0, 0], Q[:, 0, 1], Q[:, 1, 1]])


def _size(q: Array) -> Array:
    """max |q_ij|: a norm that overflows for no finite Q (1e200 is a valid conductivity)."""
    return np.abs(q).max(axis=1)
