"""The value the mesher produces and every reader, writer and measure takes: a `Mesh`.

Its arrays are read-only so that consecutive `Step`s of a run (`qmesh.mesher.step`) can share
them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, DTypeLike, NDArray

from qmesh.checks import real_array
from qmesh.errors import QmeshError
from qmesh.geometry.topology import edge_keys


def frozen(a: ArrayLike, dtype: DTypeLike) -> NDArray[Any]:
    """`a` as a read-only array of `dtype` (no copy when it already is one)."""
    out = np.asarray(a, dtype=dtype)
    if out.flags.writeable:
        out = out.copy() if out.base is not None else out
        out.setflags(write=False)
    return out


_FILLED: Any = None
"""The default of Mesh's optional fields: `__post_init__` puts the array or dict in its place."""


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh: `points (N,2)`, counter-clockwise `triangles (M,3)`, `fixed (N,)` seed mask,
    and its boundary: `boundary_edges (k,2)` with Ω on the left of each, their integer
    `boundary_tags (k,)` (inherited from the domain's segments; 1 when not known) and
    `tag_names` (tag → name). Edges not given are found from the triangles. `region_tags (M,)`
    gives each triangle's region (0, the rest of Ω, when the domain has no regions) and
    `region_names` names them. `conductivity (M, 2, 2)`, when the mesh was made for a
    `TensorField`, holds each triangle's element mean Q̄_T = (1/|T|)∫_T Q: exactly what the P1
    stiffness matrix assembles (FIELDS.md §2); None otherwise. `means_sampled_at`, when those
    means come from a callable field, is the spacing h of the samples they were computed from
    (`TensorField.sampled_at`): a jump or a bump narrower than h between samples can go unseen,
    so the certificate holds for Q as sampled at h; None when the means are exact or their error
    bound is proven (texts, rasters, constants).
    """

    points: NDArray[np.float64] = field(repr=False)
    triangles: NDArray[np.int64] = field(repr=False)
    fixed: NDArray[np.bool_] = field(default=_FILLED, repr=False)
    boundary_edges: NDArray[np.int64] = field(default=_FILLED, repr=False)
    boundary_tags: NDArray[np.int64] = field(default=_FILLED, repr=False)
    tag_names: dict[int, str] = field(default=_FILLED, repr=False)
    region_tags: NDArray[np.int64] = field(default=_FILLED, repr=False)
    region_names: dict[int, str] = field(default=_FILLED, repr=False)
    conductivity: NDArray[np.float64] | None = field(default=None, repr=False)
    means_sampled_at: float | None = field(default=None, repr=False)

    if TYPE_CHECKING:   # what the constructor takes; the fields above are what it keeps
        def __init__(self, points: ArrayLike, triangles: ArrayLike, fixed: ArrayLike | None = None,
                     boundary_edges: ArrayLike | None = None, boundary_tags: ArrayLike | None = None,
                     tag_names: Mapping[int, str] | None = None, region_tags: ArrayLike | None = None,
                     region_names: Mapping[int, str] | None = None,
                     conductivity: ArrayLike | None = None,
                     means_sampled_at: float | None = None) -> None: ...

    def __post_init__(self) -> None:
        P = self.points if _is_float_array(self.points) else real_array(self.points, "points",
                                                                           (None, 2))
        P = frozen(P, np.float64)
        if P.ndim != 2 or P.shape[1] != 2:
            raise QmeshError(f"points must have shape (N, 2), got {P.shape}")
        T = frozen(_indices(self.triangles, "triangles", 3), np.int64)
        if T.size and (T.min() < 0 or T.max() >= len(P)):
            raise QmeshError("triangles refer to points that do not exist")
        F = np.zeros(len(P), bool) if self.fixed is None else self.fixed
        F = frozen(F, bool)
        if F.shape != (len(P),):
            raise QmeshError(f"fixed must have shape ({len(P)},), got {F.shape}")
        E = (_boundary_of(T, len(P)) if self.boundary_edges is None
             else _indices(np.reshape(self.boundary_edges, (-1, 2)), "boundary_edges", 2))
        E = frozen(E, np.int64)
        if E.size and (E.min() < 0 or E.max() >= len(P)):
            raise QmeshError("boundary_edges refer to points that do not exist")
        tags = (np.ones(len(E), np.int64) if self.boundary_tags is None
                else _indices(self.boundary_tags, "boundary_tags", None))
        tags = frozen(tags, np.int64)
        if tags.shape != (len(E),):
            raise QmeshError(f"boundary_tags must have shape ({len(E)},), got {tags.shape}")
        names = {} if self.tag_names is None else {int(k): str(v) for k, v in dict(self.tag_names).items()}
        regions = (np.zeros(len(T), np.int64) if self.region_tags is None
                   else _indices(self.region_tags, "region_tags", None))
        regions = frozen(regions, np.int64)
        if regions.shape != (len(T),):
            raise QmeshError(f"region_tags must have shape ({len(T)},), got {regions.shape}")
        region_names = ({} if self.region_names is None
                        else {int(k): str(v) for k, v in dict(self.region_names).items()})
        Q = None
        if self.conductivity is not None:
            Q = frozen(real_array(self.conductivity, "conductivity", (None, 2, 2)), np.float64)
            if Q.shape != (len(T), 2, 2):
                raise QmeshError(f"conductivity must have shape ({len(T)}, 2, 2), got {Q.shape}")
        h = self.means_sampled_at
        if h is not None:
            if isinstance(h, bool) or not isinstance(h, (int, float, np.floating, np.integer)) \
                    or not (np.isfinite(float(h)) and float(h) > 0):
                raise QmeshError(f"means_sampled_at must be a finite length > 0 or None, got {h!r:.80}")
            object.__setattr__(self, "means_sampled_at", float(h))
        for name, value in (("points", P), ("triangles", T), ("fixed", F), ("boundary_edges", E),
                            ("boundary_tags", tags), ("tag_names", names), ("region_tags", regions),
                            ("region_names", region_names), ("conductivity", Q)):
            object.__setattr__(self, name, value)

    def __repr__(self) -> str:
        return f"Mesh(N={self.n_vertices}, triangles={self.n_triangles}, fixed={int(self.fixed.sum())})"

    @property
    def n_vertices(self) -> int:
        """N, the number of points."""
        return len(self.points)

    @property
    def n_triangles(self) -> int:
        """M, the number of triangles."""
        return len(self.triangles)

    @cached_property
    def boundary(self) -> NDArray[np.bool_]:
        """Boolean mask of vertices on the mesh boundary."""
        m = np.zeros(self.n_vertices, bool)
        m[self.boundary_edges.ravel()] = True
        return m


def _is_float_array(a: object) -> bool:
    """A finite, read-only float64 array (the mesher's own, shared between Steps: not copied)."""
    return (isinstance(a, np.ndarray) and a.dtype == np.float64 and not a.flags.writeable
            and bool(np.isfinite(a).all()))


def _indices(value: ArrayLike, name: str, width: int | None) -> NDArray[np.int64]:
    """An integer array of shape (k, width) (or (k,)), or QmeshError naming the argument."""
    if isinstance(value, np.ndarray) and value.dtype.kind in "iu":
        a = value
    else:
        try:
            a = np.asarray(value)
        except (TypeError, ValueError) as e:
            raise QmeshError(f"{name} must be an array of integers: {e}") from None
        if (a.dtype.kind == "f" and a.size and np.all(np.isfinite(a)) and np.all(a == np.round(a))
                and np.all(np.abs(a) < 2.0**63)):
            a = a.astype(np.int64)
        if a.dtype.kind not in "iu" and not (a.size == 0 and a.dtype.kind == "f"):
            raise QmeshError(f"{name} must be an array of integers (indices), got dtype {a.dtype}")
    if a.dtype.kind == "u" and a.size and a.max() > np.iinfo(np.int64).max:    # would wrap negative
        raise QmeshError(f"{name} must be integers below 2**63, got {int(a.max())}")
    want = (None, width) if width else (None,)
    if a.size == 0:
        a = a.reshape((0, width) if width else (0,))
    if a.ndim != len(want) or (width and a.shape[1] != width):
        shape = f"(k, {width})" if width else "(k,)"
        raise QmeshError(f"{name} must have shape {shape}, got {a.shape}")
    return a.astype(np.int64, copy=False)


def _boundary_of(T: NDArray[np.int64], n: int) -> NDArray[np.int64]:
    """Half-edges a→b (in triangle order, so Ω is on their left) whose edge has one triangle."""
    a, b = T.ravel(), T[:, [1, 2, 0]].ravel()
    key = edge_keys(a, b, n)
    _, inverse, count = np.unique(key, return_inverse=True, return_counts=True)
    one = count[inverse] == 1
    return np.column_stack([a[one], b[one]])
