"""The repair's one state: the mesh it changes, the means and shares it judges by, what it refused.

FIELDS.md §4. Certify (certify.py) and its steps — the flips (flips.py), the splits (splits.py)
and the vertex moves (moves.py) — read and update one `RepairState` instead of handing each
other the mesh arrays, the twins, the means, their errors and the shares: a step changes the
mesh (P, T, twin and cut, fixed, out, reg), and `refresh` then brings the means and shares of
the triangles it changed up to date.
"""

from __future__ import annotations

from dataclasses import dataclass, field as _field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from qmesh.conductivity.anisotropy import shape_metric
from qmesh.fields.moves import Judged
from qmesh.fields.shares import ROUND, cut_interfaces, failing, means_of, shares
from qmesh.geometry import topology
from qmesh.geometry.triangles import metric_quality

Array = NDArray[np.float64]
Index = NDArray[np.int64]


@dataclass
class RepairState:
    """A mesh under repair and what its steps judge by.

    The mesh: vertices `P` (n, 2), triangles `T` (M, 3), the `twin` of each half-edge 3t + j
    (corner j → j + 1; −1 on the boundary), `cut` (the twins less a medium's interfaces, which
    are judged side by side and never flipped: `twin` itself without regions), the `fixed`
    vertices, the tag of the boundary edge leaving each vertex `out` (−1 none), each triangle's
    region tag `reg` (a medium; else None). The means: `field` gives them (`cache.ElementMeans`,
    `piecewise.RegionMeans` with tags, or anything with `means_with_error`), `Qbar` (M, 2, 2)
    and their error bounds `err` (M,), `tight` where they are at the field's own tolerance; each
    half-edge's share `s` of its edge's q_ij and its bound `b` (3M,) (shares.py). The failing
    edges `h` (a half-edge each) and their q_ij `q` as `fail` last found them; what was judged
    and refused, `seen` (moves.Judged); the `flips` made.

    What a round changes is a few triangles, so the state keeps what whole-mesh passes would
    find again: `fails`, the half-edge (the lower of the two) of each failing edge, brought up to
    date by `fail` on the half-edges `refresh` and `flip` changed (`dirty`) and the twins across
    them (`examined` counts the half-edges it judged), and once `track_quality` is called each
    triangle's metric quality (2.94) in its own means, `quality`, updated by `refresh`. `tried`
    holds the last tries of moves judged on a raster's means (moves.py), until the ones taken
    are kept."""

    P: Array
    T: Index
    twin: Index
    cut: Index
    fixed: NDArray[np.bool_]
    out: Index
    reg: Index | None
    field: Any
    Qbar: Array
    err: Array
    s: Array
    b: Array
    tight: NDArray[np.bool_]
    seen: Judged
    h: Index
    q: Array
    flips: int = 0
    quality: Array | None = None
    fails: NDArray[np.bool_] | None = None
    dirty: list[Index] = _field(default_factory=list)
    examined: int = 0
    tried: Any = None

    @classmethod
    def of(cls, P, T, field, *, fixed=None, out=None, reg=None) -> "RepairState":
        """The state of the mesh P, T: its twins, the means of `field` and their shares
        computed, nothing judged yet (`fixed` none and `out` −1 unless given)."""
        P, T = np.array(P), np.array(T)
        twin = topology.twins(T)
        cut = cut_interfaces(twin, reg)
        Qbar, err = means_of(field, "means_with_error", P, T, reg)
        Qbar, err = np.array(Qbar, dtype=float), np.array(err, dtype=float)
        s, b = shares(P, T, Qbar, err)
        h, q, _ = failing(s, b, cut)
        fails = np.zeros(len(s), bool)
        fails[h] = True
        return cls(P, T, twin, cut,
                   np.zeros(len(P), bool) if fixed is None else np.array(fixed),
                   np.full(len(P), -1, np.int64) if out is None else np.array(out),
                   reg, field, Qbar, err, s, b, np.zeros(len(T), bool), Judged(len(P), len(T)),
                   h, q, fails=fails, examined=len(s))

    def means(self, how: str, P, T, tags=None):
        """`field`'s means and error bounds of triangles T over P (`shares.means_of`)."""
        return means_of(self.field, how, P, T, tags)

    def fail(self) -> None:
        """The failing edges `h` and their `q` from the shares as they are: the edges of the
        half-edges changed since the last call and of their twins judged again (all of them
        after `stale`), the same edges in the same order as `shares.failing` finds."""
        s, b, cut = self.s, self.b, self.cut
        if self.fails is None:
            self.h, self.q, _ = failing(s, b, cut)
            self.fails = np.zeros(len(s), bool)
            self.fails[self.h] = True
            self.examined += len(s)
        else:
            if len(self.fails) < len(s):
                self.fails = np.concatenate([self.fails, np.zeros(len(s) - len(self.fails), bool)])
            if self.dirty:
                d = topology.sorted_unique(np.concatenate(self.dirty))
                g = cut[d]
                d = topology.sorted_unique(np.concatenate([d, g[g >= 0]]))
                self.fails[d] = False              # a flip or split leaves no stale edge behind
                g = cut[d]
                h = topology.sorted_unique(np.where((g >= 0) & (g < d), g, d))   # each edge once
                self.fails[h] = _fails(s, b, cut, h)
                self.examined += len(d)
            h = np.flatnonzero(self.fails)
            g = cut[h]
            inner = g >= 0
            self.h, self.q = h, s[h] + np.where(inner, s[np.where(inner, g, 0)], 0.0)
        self.dirty = []

    def renumber(self, half: Index) -> None:
        """The half-edges renumbered, the new k the old half[k] (a merge removed triangles): the
        failing edges and what changed since the last `fail` follow; the removed half-edges'
        twins are the merged triangles' sides, which the merge brings up to date."""
        size = max([int(x.max()) + 1 for x in (half, *self.dirty) if len(x)], default=0)
        if self.fails is not None:
            if len(self.fails) < size:
                self.fails = np.concatenate([self.fails, np.zeros(size - len(self.fails), bool)])
            self.fails = self.fails[half]
        where = np.full(size, -1, np.int64)
        where[half] = np.arange(len(half))
        moved = [where[d] for d in self.dirty]
        self.dirty = [d[d >= 0] for d in moved]

    def stale(self) -> None:
        """The shares changed everywhere (the proof's bounds): the next `fail` judges every
        edge."""
        self.fails = None
        self.dirty = []

    def track_quality(self) -> None:
        """Keep each triangle's metric quality (2.94) in its own means in `quality` from now on
        (`refresh` updates the triangles it brings up to date)."""
        self.quality = metric_quality(self.P, self.T, shape_metric(self.Qbar))

    def flip(self, done: Index) -> Index:
        """Flip the interior half-edges `done` (no two in one triangle); the triangles changed."""
        t = done[:0]
        if len(done):
            t = np.concatenate([done // 3, self.twin[done] // 3])
            self.T, self.twin = topology.flip(self.T, self.twin, done, copy=False)   # its own
            self.cut = cut_interfaces(self.twin, self.reg)
            self.flips += len(done)
            self.dirty.append((3 * t[:, None] + np.arange(3)).ravel())
        return t

    def refresh(self, t, tighten: bool = False) -> None:
        """The means of the triangles `t` (changed rows, and rows past the old end) computed
        again (`tighten`: at the field's own tolerance, `ElementMeans.tighten`), their shares
        (each round assembles only what changed), and what was judged on them forgotten."""
        M = len(self.T)
        if len(self.Qbar) < M:
            self.Qbar = np.concatenate([self.Qbar, np.zeros((M - len(self.Qbar), 2, 2))])
            self.err = np.concatenate([self.err, np.zeros(M - len(self.err))])
            self.s = np.concatenate([self.s, np.zeros(3 * M - len(self.s))])
            self.b = np.concatenate([self.b, np.zeros(3 * M - len(self.b))])
            self.tight = np.concatenate([self.tight, np.zeros(M - len(self.tight), bool)])
        u = np.unique(t)
        Qn, en = self.means("tighten" if tighten else "means_with_error", self.P, self.T[u],
                           None if self.reg is None else self.reg[u])
        self.Qbar[u], self.err[u] = Qn, en
        st, bt = shares(self.P, self.T[u], self.Qbar[u], self.err[u])
        rows = (3 * u[:, None] + np.arange(3)).ravel()
        self.s[rows], self.b[rows] = st, bt
        self.dirty.append(rows)
        self.tight[u] = tighten
        if self.quality is not None:
            if len(self.quality) < M:
                self.quality = np.concatenate([self.quality, np.zeros(M - len(self.quality))])
            if len(u):
                self.quality[u] = metric_quality(self.P, self.T[u],
                                                 shape_metric(self.Qbar[u]))
        self.seen.forget(self.T, self.twin, t)


def _fails(s, b, cut, h):
    """Which edges of the half-edges h (one each) fail, judged as `shares.failing` judges them:
    an edge both of whose shares pass their own bounds passes; the others by their sum."""
    g = cut[h]
    inner = g >= 0
    gg = np.where(inner, g, 0)
    maybe = ~(s[h] >= b[h]) | (inner & ~(s[gg] >= b[gg]))
    q = s[h] + np.where(inner, s[gg], 0.0)
    bound = b[h] + np.where(inner, b[gg], 0.0)
    scale = np.abs(s[h]) + np.where(inner, np.abs(s[gg]), 0.0)
    return maybe & ~(q - bound >= -ROUND * scale)
