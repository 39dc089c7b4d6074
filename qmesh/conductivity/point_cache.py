"""A field's values kept by point, so that a user's callable is asked for each point once.

FIELDS.md §2. The mesher and its repair ask for Q at the same points again and again: the rule
points of a triangle whose means are compared roughly and then computed in full, tightened, or
asked for again after a move was refused. `PointCache` keeps the checked values of the points it
evaluated, keyed by the exact bits of (x, y) (−0.0 and 0.0 are two keys: a callable may tell
them apart), and passes on only the points it has not kept, each once, in the order they were
first asked for. A callable whose value at a point depends on that point alone gives the same
bits either way: the cache never changes a bit of a mesh.

The keys sit in an open-addressing hash table (linear probing, at most a quarter full), looked up
and filled a probe round at a time over all the points of a call. Memory is bounded: two
generations of at most `capacity` points each; when the newer is full the older is dropped
(a repeated point is most often asked for again soon after: the repair's rough and full means
of one move, a triangle's means and their tightening).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]
Bits = NDArray[np.uint64]

CAPACITY = 1 << 17
"""Points per generation (40 bytes each and at most 32 of table: 9 MB a generation). Meshing
the islands callable of benchmarks/bench_fields.py at 2 000 vertices asks for 1 835 368 points,
1 746 595 of them distinct: at this capacity it is given 1 748 175."""
_MIX = (np.uint64(0x9E3779B97F4A7C15), np.uint64(0xBF58476D1CE4E5B9))


@dataclass(frozen=True)
class Evaluations:
    """How often a field was evaluated: `calls` of its function, the `points` it was given, and
    the points `asked` for (the kept ones included)."""

    calls: int = 0
    points: int = 0
    asked: int = 0


def point_bits(X: Array, Y: Array) -> tuple[Bits, Bits, Bits]:
    """The bits of each x and y as unsigned integers, and a 64-bit hash of the pair."""
    bx = np.ascontiguousarray(X, dtype=np.float64).view(np.uint64)
    by = np.ascontiguousarray(Y, dtype=np.float64).view(np.uint64)
    return bx, by, hashed(bx, by)


def hashed(bx: Bits, by: Bits) -> Bits:
    """A 64-bit hash of each pair of bits (multiply, xor and shift: its low bits mix all 128)."""
    h = (bx * _MIX[0]) ^ by
    h ^= h >> np.uint64(31)
    h *= _MIX[1]
    h ^= h >> np.uint64(29)
    return h


def distinct(bx: Bits, by: Bits, h: Bits) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """The first occurrence of each distinct point (ascending) and each point's index among
    them, grouped by the hash and checked on the bits (distinct points of one hash: grouped by
    the bits themselves)."""
    _, first, inverse = np.unique(h, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    if np.any((bx[first][inverse] != bx) | (by[first][inverse] != by)):     # a hash collision
        _, first, inverse = np.unique(np.column_stack([bx, by]), axis=0, return_index=True,
                                      return_inverse=True)
        inverse = inverse.ravel()
    lead = np.zeros(len(h), bool)
    lead[first] = True
    rank = np.cumsum(lead) - 1                  # the first occurrences in the order asked
    return np.flatnonzero(lead), rank[first][inverse]


class _Table:
    """Up to `capacity` points and their values (rows in the order kept), found by hash in a
    table at most a quarter full (a point not kept is mostly told by its first slot)."""

    def __init__(self, capacity: int, width: int):
        self.capacity, self.n = capacity, 0
        self.slots = np.full(64, -1, np.intp)           # the row in each slot, −1 empty
        self.bx, self.by = np.empty(0, np.uint64), np.empty(0, np.uint64)
        self.values = np.empty((0, width))

    def clear(self) -> None:
        self.slots[:] = -1
        self.n = 0

    def find(self, bx: Bits, by: Bits, h: Bits) -> NDArray[np.intp]:
        """The row of each point, −1 where it is not kept."""
        row = np.full(len(h), -1, np.intp)
        if not self.n:
            return row
        mask = len(self.slots) - 1
        todo, slot = np.arange(len(h)), (h & np.uint64(mask)).astype(np.intp)
        while len(todo):
            r = self.slots[slot]
            full = np.flatnonzero(r >= 0)                 # the others are not kept
            todo, slot, r = todo[full], slot[full], r[full]
            hit = (self.bx[r] == bx[todo]) & (self.by[r] == by[todo])
            row[todo[hit]] = r[hit]
            todo, slot = todo[~hit], (slot[~hit] + 1) & mask      # probe the next slot
        return row

    def keep(self, bx: Bits, by: Bits, h: Bits, values: Array) -> None:
        """Keep points absent from the table and distinct (at most capacity − n of them)."""
        k = len(h)
        if 4 * (self.n + k) > len(self.slots):
            self._grow(self.n + k)
        if self.n + k > len(self.values):
            size = min(self.capacity, max(2 * len(self.values), self.n + k))
            self.bx, self.by = np.resize(self.bx, size), np.resize(self.by, size)
            self.values = np.resize(self.values, (size, self.values.shape[1]))
        rows = self.n + np.arange(k)
        self.bx[rows], self.by[rows], self.values[rows] = bx, by, values
        self.n += k
        self._place(rows, h)

    def _place(self, rows: NDArray[np.intp], h: Bits) -> None:
        """Put each row in the first free slot from its hash on (the rows after one free slot:
        one of them takes it, the others probe on)."""
        mask = len(self.slots) - 1
        slot = (h & np.uint64(mask)).astype(np.intp)
        while len(rows):
            free = self.slots[slot] < 0
            self.slots[slot[free]] = rows[free]
            placed = free & (self.slots[slot] == rows)
            rows, slot = rows[~placed], (slot[~placed] + 1) & mask

    def _grow(self, n: int) -> None:
        size = len(self.slots)
        while 4 * n > size:
            size *= 2
        self.slots = np.full(size, -1, np.intp)
        self._place(np.arange(self.n), hashed(self.bx[:self.n], self.by[:self.n]))


class PointCache:
    """`f(X, Y)` (1-D points → values (n, width)) with each point's values kept: `__call__`
    evaluates `f` only at the points not kept, each once; at most `capacity` points a generation
    (None: CAPACITY; 0 keeps nothing and only counts). `evaluations` counts the calls of `f`,
    the points it was given and those asked for."""

    def __init__(self, f: Callable[[Array, Array], Array], width: int = 3,
                 capacity: int | None = None):
        self.f, self.width = f, width
        self.capacity = CAPACITY if capacity is None else int(capacity)
        self.calls = self.points = self.asked = 0
        self._new, self._old = _Table(self.capacity, width), _Table(self.capacity, width)

    @property
    def evaluations(self) -> Evaluations:
        return Evaluations(self.calls, self.points, self.asked)

    def _evaluate(self, X: Array, Y: Array) -> Array:
        self.calls += 1
        self.points += len(X)
        return self.f(X, Y)

    def __call__(self, X: Array, Y: Array) -> Array:
        self.asked += len(X)
        if not self.capacity or not len(X):
            return self._evaluate(X, Y)
        bx, by, h = point_bits(X, Y)
        row = self._new.find(bx, by, h)
        out = np.empty((len(X), self.width))
        new = row >= 0
        out[new] = self._new.values[row[new]]
        miss = np.flatnonzero(~new)
        if len(miss):
            old = self._old.find(bx[miss], by[miss], h[miss])
            out[miss[old >= 0]] = self._old.values[old[old >= 0]]
            miss = miss[old < 0]
        if len(miss):
            first, which = distinct(bx[miss], by[miss], h[miss])
            ask = miss[first]
            values = self._evaluate(X[ask], Y[ask])
            out[miss] = values[which]
            self._keep(bx[ask], by[ask], h[ask], values)
        return out

    def _keep(self, bx: Bits, by: Bits, h: Bits, values: Array) -> None:
        """Keep new points, the latest `capacity` of them; the older generation is dropped when
        the newer is full."""
        c = self.capacity
        bx, by, h, values = bx[-c:], by[-c:], h[-c:], values[-c:]
        if self._new.n + len(h) > c:
            self._old, self._new = self._new, self._old
            self._new.clear()
        self._new.keep(bx, by, h, values)
