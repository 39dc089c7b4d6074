"""The element means the repair asks for, each triangle's computed once (FIELDS.md §2–3).

The repair (certify.py) asks for the means of the same triangles again and again: the flips of a
failing edge every round until one is taken, the candidates of a split and then the triangles it
made, a star before and after a move. `ElementMeans` keeps every mean it computed, keyed by the
triangle's three corners (in any order: Q̄_T and its bound depend on the triangle only), and
computes only the ones it has not seen.

For a formula or a callable the means are the adaptive quadrature's (`means.adaptive_means`)
at the tolerance RTOL, looser than the field's own: the certificate holds as long as every edge
passes by more than the bound the means carry (FIELDS.md §3), and an edge that fails only by its
bound has the means of its triangles computed again at the field's tolerance (`tighten`). Split
candidates and the polish's tries are ranked on `rough` means (the degree-5 rule alone, 7 points
a triangle, never kept): the split taken and the try kept are then computed in full. Rasters and
constant fields keep their own exact means; their tries' means are computed without a look-up
(a try's triangles are new) and only the tries taken are kept (`keep`): most tries are refused,
and keeping them all made the cache hold several times the mesh's triangles.

For a text formula those bounds are the rule's estimates, which a jump or a bump between its
samples fools; `prove` replaces them by proven ones (`TensorField.enclosure_errors`: one enclosure
of each triangle), and `refine` proves triangles whose edges need a tighter bound by the adaptive
refinement of the enclosures (`means.adaptive_means` with a bound). A proven row stays proven:
`tighten` leaves it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from qmesh.conductivity import means as _m

RTOL = 1e-6
"""The repair's quadrature tolerance: an error bound of at most about this share of ‖Q̄_T‖ (FIELDS.md
§3); an edge that fails only by its bound is computed again at `means.RTOL`. At 1e-7 the plasma and
FVCA5 cases took 65 and 61 field evaluations a triangle, at 1e-6 42 and 47 (35 is the rule and its
four children alone), and the repair the same rounds, splits and vertex count."""
MIX = np.uint64(0x9E3779B97F4A7C15)   # odd multiplier of the corners' hash (Fibonacci hashing)


def _canonical(X: NDArray[np.float64]) -> NDArray[np.float64]:
    """Corners (k, 3, 2) in lexicographic order (x, then y): one key per triangle (three
    compare-and-swaps of the corners, a sorting network)."""
    a, b, c = X[:, 0], X[:, 1], X[:, 2]
    for i, j in ((0, 1), (1, 2), (0, 1)):
        p, q = (a, b) if i == 0 else (b, c)
        swap = (q[:, 0] < p[:, 0]) | ((q[:, 0] == p[:, 0]) & (q[:, 1] < p[:, 1]))
        lo, hi = np.where(swap[:, None], q, p), np.where(swap[:, None], p, q)
        if i == 0:
            a, b = lo, hi
        else:
            b, c = lo, hi
    return np.concatenate([a, b, c], axis=1)


def _hash(C: NDArray[np.float64]) -> NDArray[np.uint64]:
    """A 64-bit hash of the six coordinates of each row (the keys are checked in full after)."""
    bits = np.ascontiguousarray(C + 0.0).view(np.uint64)      # + 0.0: −0.0 hashes as 0.0
    h = np.zeros(len(C), np.uint64)
    for c in range(6):
        h = (h ^ bits[:, c]) * MIX
        h ^= h >> np.uint64(29)
    return h


def _member(keys, K):
    """Which of `keys` are in the sorted array K."""
    if not len(K):
        return np.zeros(len(keys), bool)
    return K[np.minimum(np.searchsorted(K, keys), len(K) - 1)] == keys


class ElementMeans:
    """Means Q̄_T (M, 2, 2) and their error bounds (M,) of a field, cached by triangle.

    `means_with_error(P, T)` as the field's own (at RTOL for formulas); `tighten(P, T)` the same
    triangles at the field's own tolerance, kept in place of the looser ones; `rough(P, T)` the
    candidates' means, not kept."""

    def __init__(self, field, rtol: float = RTOL):
        self.field = field
        self.rtol = rtol
        self._keys = np.empty(0, np.uint64)          # sorted
        self._rows = np.empty(0, np.int64)           # the row of each key
        self._new_keys = np.empty(0, np.uint64)      # recent, sorted, merged when large
        self._new_rows = np.empty(0, np.int64)
        self._n = 0
        self._corners = np.empty((1024, 6))
        self._q = np.empty((1024, 2, 2))
        self._err = np.empty(1024)
        self._proven = np.empty(1024, bool)
        self.computed = 0                            # triangles whose means were computed
        self.provable = bool(getattr(field, "means_bounded", False)) and not field.means_exact
        """A text: its rows are estimates until proven (`prove`, `refine`)."""
        self.rough_exact = bool(getattr(field, "means_exact", False))
        """`rough` gives the kept means themselves (a raster, a constant): a verdict on them
        needs no second judgement."""

    def _compute(self, P, T, rtol, depth=_m.MAX_DEPTH, bound_rtol=None):
        self.computed += len(T)
        Q, e = self.field.means_with_error(P, T, rtol=rtol, max_depth=depth, bound_rtol=bound_rtol)
        return np.asarray(Q, dtype=float), np.asarray(e, dtype=float)

    def _find(self, keys, C):
        """The row of each key whose corners are C, −1 where none."""
        row = np.full(len(keys), -1, np.int64)
        for K, R in ((self._keys, self._rows), (self._new_keys, self._new_rows)):
            if not len(K):
                continue
            at = np.minimum(np.searchsorted(K, keys), len(K) - 1)
            hit = (K[at] == keys) & (row < 0)
            cand = R[at[hit]]
            same = np.all(self._corners[cand] == C[hit], axis=1)
            row[np.flatnonzero(hit)[same]] = cand[same]
        return row

    def _store(self, keys, C, Q, e):
        keys, first = np.unique(keys, return_index=True)
        fresh = ~_member(keys, self._keys) & ~_member(keys, self._new_keys)   # one row a key
        keys, first = keys[fresh], first[fresh]
        k = len(keys)
        if self._n + k > len(self._err):
            size = max(len(self._err) + len(self._err) // 2, self._n + k)   # 1.5×: less spare
            self._corners = np.resize(self._corners, (size, 6))
            self._q = np.resize(self._q, (size, 2, 2))
            self._err = np.resize(self._err, size)
            self._proven = np.resize(self._proven, size)
        rows = self._n + np.arange(k)
        self._corners[rows], self._q[rows], self._err[rows] = C[first], Q[first], e[first]
        self._proven[rows] = not self.provable
        self._n += k
        at = np.searchsorted(self._new_keys, keys)                      # keys sorted by unique
        self._new_keys = np.insert(self._new_keys, at, keys)
        self._new_rows = np.insert(self._new_rows, at, rows)
        if len(self._new_keys) > max(4096, len(self._keys) // 4):      # amortised merge
            K = np.concatenate([self._keys, self._new_keys])
            R = np.concatenate([self._rows, self._new_rows])
            order = np.argsort(K, kind="stable")
            self._keys, self._rows = K[order], R[order]
            self._new_keys, self._new_rows = self._new_keys[:0], self._new_rows[:0]

    def means_with_error(self, P, T):
        """The means and error bounds of the triangles T over P, computed where not seen yet."""
        P, T = np.asarray(P, dtype=float), np.asarray(T, dtype=np.int64).reshape(-1, 3)
        C = _canonical(P[T])
        keys = _hash(C)
        row = self._find(keys, C)
        Q, e = np.empty((len(T), 2, 2)), np.empty(len(T))
        have = row >= 0
        Q[have], e[have] = self._q[row[have]], self._err[row[have]]
        miss = np.flatnonzero(~have)
        if len(miss):
            Q[miss], e[miss] = self._compute(P, T[miss], self.rtol)
            self._store(keys[miss], C[miss], Q[miss], e[miss])
        return Q, e

    def _rows_of(self, P, T):
        """The rows of the triangles T (computed where not seen yet)."""
        self.means_with_error(P, T)
        C = _canonical(P[T])
        return self._find(_hash(C), C)

    def tighten(self, P, T):
        """The means of the triangles T at the field's own tolerance (`means.RTOL`), kept in
        place of the ones at RTOL (a proven row is kept as it is)."""
        P, T = np.asarray(P, dtype=float), np.asarray(T, dtype=np.int64).reshape(-1, 3)
        if self.field.means_exact or self.rtol <= _m.RTOL:
            return self.means_with_error(P, T)
        row = self._rows_of(P, T)
        todo = np.flatnonzero(~self._proven[row])
        if len(todo):
            self._q[row[todo]], self._err[row[todo]] = self._compute(P, T[todo], _m.RTOL)
        return self._q[row], self._err[row]

    def proven(self, P, T):
        """Which of the triangles T have a proven bound (all of them but a text's estimates)."""
        P, T = np.asarray(P, dtype=float), np.asarray(T, dtype=np.int64).reshape(-1, 3)
        return self._proven[self._rows_of(P, T)]

    def prove(self, P, T):
        """The means of the triangles T with proven bounds: a text's estimates bounded by one
        enclosure of each triangle (`TensorField.enclosure_errors`), kept."""
        P, T = np.asarray(P, dtype=float), np.asarray(T, dtype=np.int64).reshape(-1, 3)
        row = self._rows_of(P, T)
        todo = np.flatnonzero(~self._proven[row])
        if len(todo):
            self._err[row[todo]] = self.field.enclosure_errors(P, T[todo])
            self._proven[row[todo]] = True
        return self._q[row], self._err[row]

    def refine(self, P, T, bound_rtol):
        """The means of the triangles T computed again with their bound proven to `bound_rtol`
        (one per triangle) of ‖Q̄_T‖ by the adaptive refinement of the enclosures, kept where
        their bound is lower than the one kept."""
        P, T = np.asarray(P, dtype=float), np.asarray(T, dtype=np.int64).reshape(-1, 3)
        row = self._rows_of(P, T)
        if not self.provable or not len(T):
            return self._q[row], self._err[row]
        self.computed += len(T)
        Q, e = self.field.means_with_error(P, T, rtol=self.rtol, bound_rtol=bound_rtol)
        better = ~self._proven[row] | (e < self._err[row])
        self._q[row[better]], self._err[row[better]] = Q[better], e[better]
        self._proven[row] = True
        return self._q[row], self._err[row]

    def keep(self, P, T, Q, e):
        """Keep the means Q and bounds e of the triangles T over P, computed by `rough` for
        tries (exact fields): the tries taken are looked up when the mesh takes them, with the
        bits they were judged on; a triangle kept already keeps its row."""
        P, T = np.asarray(P, dtype=float), np.asarray(T, dtype=np.int64).reshape(-1, 3)
        if len(T):
            C = _canonical(P[T])
            self._store(_hash(C), C, np.asarray(Q, dtype=float), np.asarray(e, dtype=float))

    def rough(self, P, T):
        """Means good enough to rank candidates, not kept: the degree-5 rule alone, 7 points a
        triangle (`TensorField.rule_means`), error 0 (exact for rasters and constants). Nothing is
        kept or certified on them: a move that passes on them is judged again on the adaptive
        means, and a split's triangles have those computed and judged in the next round. On
        the formula, callable and medium cases of benchmarks/bench_fields.py at 2 000 and
        20 000 vertices, the meshes that ranking and screening on these rather than on the rule
        against its four children (35 points) changed kept their N, their certificate and
        their minimum quality."""
        P, T = np.asarray(P, dtype=float), np.asarray(T, dtype=np.int64).reshape(-1, 3)
        if self.field.means_exact:                   # the exact means, neither looked up nor
            return self._compute(P, T, self.rtol)    # kept: `keep` keeps the tries taken
        rule = getattr(self.field, "rule_means", None)
        if rule is None:                             # a field without the rule alone
            return self._compute(P, T, np.inf, depth=0)
        self.computed += len(T)
        return np.asarray(rule(P, T), dtype=float), np.zeros(len(T))
