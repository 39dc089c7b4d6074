"""The element means of a medium whose regions hold fields: each triangle's from its own region.

MEDIA.md §2 with FIELDS.md §2: in a medium Q is piecewise, a constant `Anisotropy` or a
`TensorField` per region, and no triangle crosses an interface, so a triangle's mean Q̄_T is its
region's: the constant itself (exact, error 0), or that field's mean over T. The repair
(certify.py) asks for the means of triangles not yet in the mesh (the candidates of a flip, a
split, a move); each is asked for with the tag of the triangle it replaces, so the means are
dispatched by tag, never by locating a point (a sliver beside an interface would land on the
wrong side by round-off). Each field region keeps its own `cache.ElementMeans`: its triangles'
means computed once, at the field's tolerances.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.conductivity.field import TensorField
from qmesh.fields.cache import ElementMeans


def as_field(conductivity: Any) -> Any:
    """A region's conductivity as what its means come from: a constant Q (2, 2) for a constant
    Anisotropy, the field itself for a TensorField, and Q = adj ∇²s as a field for an Anisotropy
    whose s varies (its means by the fields' quadrature)."""
    if isinstance(conductivity, TensorField):
        return conductivity
    if conductivity.is_constant:
        return np.array(conductivity.matrix, dtype=float)
    a: Anisotropy = conductivity

    def Q(x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        X = np.column_stack([np.ravel(x), np.ravel(y)])
        return np.asarray(a.Q(X), dtype=float).reshape(np.shape(x) + (2, 2))
    return TensorField(Q, a.label or "Q = adj ∇²s")


class RegionMeans:
    """Means Q̄_T (M, 2, 2) and their error bounds (M,) of triangles of given region tags:
    `means_with_error`, `tighten`, `rough`, `proven`, `prove` and `refine` as
    `cache.ElementMeans`'s, each with the tags."""

    def __init__(self, conductivity: Mapping[int, Any]):
        self._cached: dict[int, ElementMeans] = {}
        self._table = np.full((max(int(t) for t in conductivity) + 1, 2, 2), np.nan)
        for tag, c in conductivity.items():
            f = as_field(c)
            if isinstance(f, np.ndarray):
                self._table[int(tag)] = f           # the constants: one look-up for all
            else:
                self._cached[int(tag)] = ElementMeans(f)

    @property
    def provable(self) -> bool:
        """Some field region is a text, whose means' bounds are estimates until proven."""
        return any(c.provable for c in self._cached.values())

    @property
    def rough_exact(self) -> bool:
        """Every field region's `rough` means are its kept ones (`ElementMeans.rough_exact`)."""
        return all(c.rough_exact for c in self._cached.values())

    @property
    def computed(self) -> int:
        """Triangles whose means a field region computed (constants cost nothing)."""
        return sum(c.computed for c in self._cached.values())

    def _each(self, how: str, P: Any, T: Any, tags: Any,
              *per: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        T = np.asarray(T, dtype=np.int64).reshape(-1, 3)
        tags = np.asarray(tags, dtype=np.int64)
        Q, e = self._table[tags], np.zeros(len(T))
        for r in self._cached:                            # a pass per field region
            at = np.flatnonzero(tags == r)
            if len(at):
                Q[at], e[at] = getattr(self._cached[r], how)(P, T[at], *(v[at] for v in per))
        return Q, e

    def proven(self, P: Any, T: Any, tags: Any) -> NDArray[np.bool_]:
        T = np.asarray(T, dtype=np.int64).reshape(-1, 3)
        tags = np.asarray(tags, dtype=np.int64)
        out = np.ones(len(T), bool)
        for r in self._cached:
            at = np.flatnonzero(tags == r)
            if len(at):
                out[at] = self._cached[r].proven(P, T[at])
        return out

    def prove(self, P: Any, T: Any, tags: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self._each("prove", P, T, tags)

    def refine(self, P: Any, T: Any, tags: Any,
               bound_rtol: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self._each("refine", P, T, tags, np.asarray(bound_rtol, dtype=float))

    def means_with_error(self, P: Any, T: Any, tags: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self._each("means_with_error", P, T, tags)

    def tighten(self, P: Any, T: Any, tags: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self._each("tighten", P, T, tags)

    def rough(self, P: Any, T: Any, tags: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self._each("rough", P, T, tags)

    def keep(self, P: Any, T: Any, Q: Any, e: Any, tags: Any) -> None:
        T = np.asarray(T, dtype=np.int64).reshape(-1, 3)
        tags = np.asarray(tags, dtype=np.int64)
        for r in self._cached:
            at = np.flatnonzero(tags == r)
            if len(at):
                self._cached[r].keep(P, T[at], np.asarray(Q)[at], np.asarray(e)[at])
