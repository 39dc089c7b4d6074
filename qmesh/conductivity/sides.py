"""A text's jump across one straight line, integrated side by side.

The enclosures take a jump they recognise (`intervals.sign_of`: c·abs(u)/u; `step_of`: a step
(α·abs(u) + β·u)/(m·u)) as the hull of its two sides with unbounded derivatives on every piece
the line u = 0 crosses: the refinement keeps about 2^-L of the jump in the bound at level L,
whatever the triangle's size, so the pieces along a strong step are never proven tight. Where u
is affine in x, y (a x + b y + c, read off the parsed form) the line is known exactly: a
triangle whose box it meets is cut along it into its two sides (the corner on one side, a
triangle; the rest a quadrilateral, two triangles), and on each side the jump is that side's
value, so its forms are smooth and the rule and the enclosures there are a smooth field's. The
triangle's mean is the sides' area-weighted sum, its bound the weighted sum of theirs plus what
the cut's round-off may have put on the wrong side (`Pieces.stray`, at most both sides'
largest value over that area). One line per field: a text with jumps across two different
lines keeps the enclosure of the hull.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Callable
import numpy as np
from numpy.typing import NDArray

from qmesh.conductivity import means as _m
from qmesh.conductivity.expression import form_values
from qmesh.conductivity.intervals import sign_of, step_of

Array = NDArray[np.float64]
Line = tuple[float, float, float]

EPS = np.finfo(float).eps
ROUND_U = 1e-14
"""Relative bound of u's round-off at a point: a x + b y + c in floats (three roundings), or as
the text spells it (a coefficient folded from a product), errs by a few ulps of |a x| + |b y| + |c|."""


def affine(f: tuple) -> Line | None:
    """(a, b, c) when the checked form f is a x + b y + c (sums, differences, negations and
    products or quotients by numbers of x, y and numbers), else None."""
    kind = f[0]
    if kind == "num":
        return 0.0, 0.0, f[1]
    if kind == "var":
        return (1.0, 0.0, 0.0) if f[1] == "x" else (0.0, 1.0, 0.0)
    if kind == "neg":
        inner = affine(f[1])
        return None if inner is None else (-inner[0], -inner[1], -inner[2])
    if kind in ("+", "-"):
        p, q = affine(f[1]), affine(f[2])
        if p is None or q is None:
            return None
        k = 1.0 if kind == "+" else -1.0
        return p[0] + k * q[0], p[1] + k * q[1], p[2] + k * q[2]
    if kind == "*":
        p, q = affine(f[1]), affine(f[2])
        if p is None or q is None:
            return None
        if p[0] == p[1] == 0.0:
            return p[2] * q[0], p[2] * q[1], p[2] * q[2]
        if q[0] == q[1] == 0.0:
            return q[2] * p[0], q[2] * p[1], q[2] * p[2]
        return None
    if kind == "/" and f[2][0] == "num" and f[2][1] != 0:
        p = affine(f[1])
        return None if p is None else (p[0] / f[2][1], p[1] / f[2][1], p[2] / f[2][1])
    return None


def _jump_argument(f: tuple) -> tuple | None:
    """u when f is a jump the enclosures recognise (as `intervals.evaluate_all` tries them)."""
    sign = sign_of(f)
    if sign is not None:
        return sign[0]
    step = step_of(f)
    return None if step is None else step[0]


def _jump_lines(f: tuple, out: set) -> None:
    """The line of each jump in f whose argument is affine into `out` (None for another jump)."""
    u = _jump_argument(f) if f[0] not in ("num", "var") else None
    if u is not None:
        line = affine(u)
        out.add(None if line is None or line[0] == line[1] == 0.0 else line)
    for part in f[1:]:
        if isinstance(part, tuple):
            _jump_lines(part, out)


def _side(f: tuple, line: Line, above: bool) -> tuple:
    """f on one side of the line (u > 0 `above`, else u < 0): each jump across it its side's
    value, each abs(u) ±u."""
    kind = f[0]
    if kind in ("num", "var"):
        return f
    sign = sign_of(f)
    if sign is not None and affine(sign[0]) == line:
        v = ("num", 1.0 if above else -1.0)
        return v if sign[1] is None else ("*", _side(sign[1], line, above), v)
    step = step_of(f)
    if step is not None and affine(step[0]) == line:
        return ("num", step[2] if above else step[1])
    if kind == "call" and f[1] == "abs" and affine(f[2]) == line:
        inner = _side(f[2], line, above)
        return inner if above else ("neg", inner)
    return (kind,) + tuple(_side(p, line, above) if isinstance(p, tuple) else p for p in f[1:])


@dataclass(frozen=True)
class StepLine:
    """The jumps of a text's forms across the one line a x + b y + c = 0: the forms below it
    (u < 0) and above it (u > 0), each smooth where the text was smooth."""

    line: Line
    below: tuple[tuple, ...]
    above: tuple[tuple, ...]
    check: Callable[[Array, Array, Array], Array] | None = None
    """The field's check of components at points (X, Y, q (n, 3)) → q, refusing a point where Q
    is not finite or not positive definite (as its own evaluation does)."""

    @functools.cached_property
    def values(self) -> tuple[_m.Evaluate, _m.Evaluate]:
        """Each side's components at points (n, 2) → (n, 3), checked."""
        def checked(forms: tuple[tuple, ...]) -> _m.Evaluate:
            raw = form_values(list(forms))
            if self.check is None:
                return raw
            return lambda P: self.check(P[:, 0], P[:, 1], raw(P))
        return checked(self.below), checked(self.above)

    @functools.cached_property
    def bounds(self) -> tuple[_m.Bound, _m.Bound]:
        """Each side's `means.enclosure_bound`."""
        return _m.enclosure_bound(list(self.below)), _m.enclosure_bound(list(self.above))

    def u(self, X: Array) -> Array:
        a, b, c = self.line
        return a * X[:, 0] + b * X[:, 1] + c

    def _slop(self, far: Array) -> Array:
        """A bound of u's round-off at points whose coordinates are at most `far` (k, 2)."""
        a, b, c = self.line
        return ROUND_U * (abs(a) * far[:, 0] + abs(b) * far[:, 1] + abs(c)) + 1e-300

    def near(self, A: Array, B: Array, C: Array) -> NDArray[np.bool_]:
        """The triangles whose box the line meets (within u's round-off): the ones whose
        enclosures would take the hull of the two sides."""
        a, b, c = self.line
        lo, hi = np.minimum(np.minimum(A, B), C), np.maximum(np.maximum(A, B), C)
        ends = (a * lo[:, 0], a * hi[:, 0], b * lo[:, 1], b * hi[:, 1])
        least = np.minimum(ends[0], ends[1]) + np.minimum(ends[2], ends[3]) + c
        most = np.maximum(ends[0], ends[1]) + np.maximum(ends[2], ends[3]) + c
        slop = 2.0 * self._slop(np.maximum(np.abs(lo), np.abs(hi)))
        return (least <= slop) & (most >= -slop)

    def pieces(self, A: Array, B: Array, C: Array) -> "Pieces":
        """Each triangle (k, 2) on one side, or cut along the line into its two sides."""
        k = len(A)
        V = np.stack([A, B, C], axis=1)                              # (k, 3, 2)
        U = np.stack([self.u(A), self.u(B), self.u(C)], axis=1)
        far = np.max(np.abs(V), axis=1)
        slop = self._slop(far)
        whole = np.abs(_area(A, B, C))
        crossed = (U.min(axis=1) < 0) & (U.max(axis=1) > 0) & (whole > 0)   # a flat one: whole
        pos = U > 0
        lone = np.where(pos.sum(axis=1) == 1, np.argmax(pos, axis=1), np.argmin(pos, axis=1))
        r = np.arange(k)[:, None]
        turn = (lone[:, None] + np.arange(3)) % 3                    # lone corner first, same turn
        L, Pp, Qq = (V[r[:, 0], turn[:, i]] for i in range(3))
        uL, uP, uQ = (U[r[:, 0], turn[:, i]] for i in range(3))
        lo, hi = V.min(axis=1), V.max(axis=1)
        with np.errstate(all="ignore"):
            t1 = np.clip(uL / (uL - uP), 0.0, 1.0)[:, None]
            t2 = np.clip(uL / (uL - uQ), 0.0, 1.0)[:, None]
        X1 = np.clip(L + t1 * (Pp - L), lo, hi)
        X2 = np.clip(L + t2 * (Qq - L), lo, hi)
        c = np.flatnonzero(crossed)
        w = np.flatnonzero(~crossed)
        side_lone = (uL[c] > 0).astype(np.intp)
        SA = np.concatenate([V[w, 0], L[c], X1[c], X1[c]])
        SB = np.concatenate([V[w, 1], X1[c], Pp[c], Qq[c]])
        SC = np.concatenate([V[w, 2], X2[c], Qq[c], X2[c]])
        owner = np.concatenate([w, c, c, c])
        side = np.concatenate([(U[w].max(axis=1) > 0).astype(np.intp), side_lone,
                               1 - side_lone, 1 - side_lone])
        area = np.abs(_area(SA, SB, SC))
        keep = area > 0
        keep[:len(w)] = True                                         # a whole triangle stays
        SA, SB, SC, owner, side, area = (v[keep] for v in (SA, SB, SC, owner, side, area))
        total = np.bincount(owner, area, minlength=k)
        weight = np.where(total[owner] > 0, area / np.where(total[owner] > 0, total[owner], 1.0),
                          1.0)
        # what may lie on the wrong side: points of T with |u| ≤ η (a corner whose computed sign
        # is wrong has |u| ≤ slop; a cut point, |u| there), a strip 2η/|∇u| wide across T, and
        # the slivers between the cut points and T's edges (each within a few ulps of its edge)
        eta = np.where(np.abs(U).min(axis=1) <= slop, 2.0 * slop, 0.0)
        on_cut = np.maximum(np.abs(self.u(X1)), np.abs(self.u(X2))) + 2.0 * slop
        eta = np.where(crossed, on_cut, eta)
        edges = np.stack([np.hypot(*(B - A).T), np.hypot(*(C - B).T), np.hypot(*(A - C).T)], 1)
        gradient = float(np.hypot(self.line[0], self.line[1])) * (1.0 - 1e-15)
        strip = 2.0 * eta / gradient * edges.max(axis=1)
        sliver = np.where(crossed, 16.0 * EPS * far.max(axis=1) * edges.sum(axis=1), 0.0)
        with np.errstate(all="ignore"):      # a flat triangle weighs nothing in the stiffness
            share = np.where((strip + sliver > 0) & (whole > 0),
                             (strip + sliver) / (whole * (1.0 - 1e-14)) * (1.0 + 1e-10), 0.0)
        return Pieces(SA, SB, SC, owner, side, weight, share)

    def stray(self, A: Array, B: Array, C: Array, share: Array) -> Array:
        """What the triangles' means may err by for a `share` of their area put on the wrong
        side: share · (‖f_below‖ + ‖f_above‖) over the triangle's box, each side's largest value
        enclosed (`intervals.evaluate_all`); 0 where share is 0."""
        from qmesh.conductivity import intervals

        out = np.zeros(len(A))
        at = np.flatnonzero(share > 0)
        if not len(at):
            return out
        lo = np.minimum(np.minimum(A[at], B[at]), C[at])
        hi = np.maximum(np.maximum(A[at], B[at]), C[at])
        X, Y = (lo[:, 0], hi[:, 0]), (lo[:, 1], hi[:, 1])
        most = np.zeros(len(at))
        with np.errstate(all="ignore"):
            for forms in (self.below, self.above):
                e = np.stack([np.maximum(np.abs(n[0][0]), np.abs(n[0][1]))
                              for n in intervals.evaluate_all(list(forms), X, Y, order=2)], 1)
                most += _m.frobenius(e)
            v = share[at] * most * (1.0 + _m.SUM_ROUND)
        out[at] = np.where(np.isfinite(v), v, np.inf)
        return out


@dataclass(frozen=True)
class Pieces:
    """Triangles on one side of the line each: corners (n, 2), the triangle each is of, its side
    (0 below, 1 above), its share of that triangle's area, and per triangle (k,) the share of
    its area the cut's round-off may have put on the wrong side."""

    A: Array
    B: Array
    C: Array
    owner: NDArray[np.intp]
    side: NDArray[np.intp]
    weight: Array
    share: Array

    def each_side(self) -> list[tuple[int, NDArray[np.intp]]]:
        return [(s, np.flatnonzero(self.side == s)) for s in (0, 1)]

    def combined(self, q: Array, e: Array, k: int) -> tuple[Array, Array]:
        """The triangles' means Σ w q_p (k, 3) and bounds Σ w e_p (k,) from the pieces'."""
        w = self.weight
        with np.errstate(all="ignore"):
            err = np.bincount(self.owner, w * e, minlength=k) * (1.0 + _m.SUM_ROUND)
        return _m._sum_by(self.owner, w[:, None] * q, k), np.where(np.isnan(err), np.inf, err)


def _area(A: Array, B: Array, C: Array) -> Array:
    return 0.5 * ((B[:, 0] - A[:, 0]) * (C[:, 1] - A[:, 1]) - (B[:, 1] - A[:, 1]) * (C[:, 0] - A[:, 0]))


def step_line(forms: list[tuple] | None,
              check: Callable[[Array, Array, Array], Array] | None = None) -> StepLine | None:
    """The forms' `StepLine` when their recognised jumps all lie across one affine line, else
    None (no jump, a curved jump line, or two lines); `check` its values (`StepLine.check`)."""
    if not forms:
        return None
    lines: set = set()
    for f in forms:
        _jump_lines(f, lines)
    if len(lines) != 1 or None in lines:
        return None
    line = lines.pop()
    return StepLine(line, tuple(_side(f, line, False) for f in forms),
                    tuple(_side(f, line, True) for f in forms), check)


def side_means(line: StepLine, A: Array, B: Array, C: Array, *, rtol: float, max_depth: int,
               bound_rtol: float | Array | None) -> tuple[Array, Array]:
    """`means.adaptive_means` of the triangles (k, 2) side by side: each piece's own (the side's
    values and, with `bound_rtol`, its enclosures; within bound_rtol/√3 of each piece, so that
    their weighted sum is within bound_rtol of the triangle's SPD mean), combined, with the
    cut's `stray` → components (k, 3), bounds (k,)."""
    p = line.pieces(A, B, C)
    q, e = np.empty((len(p.A), 3)), np.empty(len(p.A))
    for s, at in p.each_side():
        if not len(at):
            continue
        btol: float | Array = 1.0
        if bound_rtol is not None:
            btol = np.broadcast_to(np.asarray(bound_rtol, dtype=float), (len(A),))[p.owner[at]]
            btol = btol / np.sqrt(3.0)
        q[at], e[at] = _m.adaptive_means(line.values[s], p.A[at], p.B[at], p.C[at], rtol=rtol,
                                         max_depth=max_depth,
                                         bound=None if bound_rtol is None else line.bounds[s],
                                         bound_rtol=btol)
    Q, err = p.combined(q, e, len(A))
    return Q, err + line.stray(A, B, C, p.share)


def side_errors(line: StepLine, A: Array, B: Array, C: Array) -> Array:
    """The proven bound (k,) of `side_means`' means, whatever their tolerances: each piece's
    mean is the rule on its 4 children at least, so within the mean of their enclosures'
    bounds (`means.children_bound`, as `TensorField.enclosure_errors`)."""
    p = line.pieces(A, B, C)
    e = np.empty(len(p.A))
    for s, at in p.each_side():
        if len(at):
            e[at] = _m.children_bound(line.bounds[s], *_m._children(p.A[at], p.B[at], p.C[at]))
    return p.combined(np.zeros((len(p.A), 3)), e, len(A))[1] + line.stray(A, B, C, p.share)


def side_rule(line: StepLine, A: Array, B: Array, C: Array) -> Array:
    """The degree-5 rule's average side by side (k, 3): `means.rule_averages` on each piece."""
    p = line.pieces(A, B, C)
    q = np.empty((len(p.A), 3))
    for s, at in p.each_side():
        if len(at):
            q[at] = _m.rule_averages(line.values[s], p.A[at], p.B[at], p.C[at])
    return p.combined(q, np.zeros(len(p.A)), len(A))[0]
