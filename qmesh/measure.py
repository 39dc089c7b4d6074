"""Measurements of a mesh against its anisotropy: the numbers of the chapter's Tables 2.2 and 2.3.

Chapter Section 2.3 (MATH.md "Stiffness matrix", "Interpolation error", "Quality",
"Vertex adjustment"): the P1 stiffness matrix for Q = adj ∇²s and its edge weights
q_ij = −K_ij (≥ 0 on every interior edge exactly when the mesh is Q-Delaunay, Glickenstein 2007),
the spectral condition number κ2 of the Dirichlet-reduced matrix, the interpolation errors
(2.96) ‖s_h − s‖_L2 and (2.97) |s_h − s|_h1, the metric quality (2.94) and the energy
E = ‖s_h − s‖_L1 (2.77) that the vertex step (2.90)–(2.93) minimises.

Every sum over triangles is vectorised; sparse matrices come from scipy.sparse.

Heterogeneous media (MEDIA.md §2, §4): wherever a function takes `anisotropy` it also takes a
mapping {region tag: Anisotropy}; each triangle then uses its own region's Q and metric
(`mesh.region_tags`), and the report gives the share of q_ij ≥ 0 on interface edges (two
triangles of different regions) apart from the interior and boundary ones.

Per-triangle conductivity (FIELDS.md §2–3): only the element means Q̄_T = (1/|T|)∫_T Q enter the
P1 stiffness matrix, K_ij = Σ_T |T| ∇φ_iᵀ Q̄_T ∇φ_j, so q_ij = ½ Σ_T √det Q̄_T cot θ_k^T with θ
measured in H_T = adj Q̄_T. Every function that takes a conductivity also takes an array
(M, 2, 2) of one Q per triangle, or a `TensorField` (whose means are computed), and when the
argument is None and the mesh carries its means (`mesh.conductivity`) it measures with those. The
energy and the interpolation errors need an s and are not defined for such a conductivity.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING, Any, Literal, NamedTuple, Union

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray
import scipy.sparse as sp
import scipy.sparse.csgraph as csgraph
import scipy.sparse.linalg as spla

from qmesh import checks, monotonicity as _monotone, multigrid_eigen
from qmesh.conductivity.anisotropy import shape_metric
from qmesh.geometry import quadrature
from qmesh.errors import QmeshError
from qmesh.geometry.topology import edge_keys
from qmesh.geometry.triangles import Frame, chunks, corners, metric_hessians, metric_quality, signed_areas
from qmesh.triangle_mesh import Mesh

if TYPE_CHECKING:
    from qmesh.conductivity.anisotropy import Anisotropy, Conductivity
    from qmesh.conductivity.field import TensorField

PerTriangle = Union[float, NDArray[np.float64]]
"""A value per triangle (M,), or one float for all of them (a constant Q)."""
Report = dict[str, Union[int, float, str, None]]
"""`report`'s measurements by name: ints, floats, None where a figure is undefined, and the
text `kappa2_undefined` saying why when κ2 is None."""
Given = Union["Conductivity", "TensorField", "Mapping[int, Union[Anisotropy, TensorField]]",
              ArrayLike, None]
"""What a measurement takes as the conductivity: an Anisotropy, a TensorField, a mapping
{region tag: either}, one Q per triangle (M, 2, 2), or None (the mesh's element means when it
carries them, else the Laplacian Q = I where that is allowed)."""
Resolved = Union["Conductivity", NDArray[np.float64], None]
"""A conductivity as the assembly uses it: an Anisotropy or {tag: Anisotropy}, a per-triangle
array (M, 2, 2), or None for Q = I."""

Q_RTOL = 1e-9
"""The shares count q_ij ≥ −Q_RTOL·max|q| as q_ij ≥ 0: rounding in the assembly leaves an edge
that is exactly 0 in exact arithmetic (a right angle in the metric) at about −1e-15 of the
largest |q|."""

DENSE_LIMIT = 300
"""Up to this many unknowns condition_number uses a dense eigvalsh; above it, the Lanczos path.

The sparse path agrees with the dense one to 1e-13 (constant Q, disk meshes) and is faster from
a few hundred unknowns on, where eigvalsh's O(n³) cost takes over; hence the low limit."""

_EDGE_CORNERS = ((0, 1), (1, 2), (2, 0))
_EDGE_PAIRS = (np.array([0, 1, 2]), np.array([1, 2, 0]))        # _EDGE_CORNERS as index arrays


# --------------------------------------------------------------------------- energy

def triangle_energy(P: ArrayLike, T: ArrayLike, anisotropy: Anisotropy) -> NDArray[np.float64]:
    """∫_T (s_h − s) for every triangle, shape (M,); its sum is E = ‖s_h − s‖_L1 (2.77).

    Signed with the triangle's orientation, so E stays the smooth function of the vertex
    positions that the vertex step differentiates. Constant H: the closed form
    ∫_T (s_h − s) = |T|/24 · Σ_edges eᵀHe (from s_h − s = ½ Σ_{i<j} λ_iλ_j e_ijᵀHe_ij and
    ∫_T λ_iλ_j = |T|/12); varying s: the degree-4 rule of `qmesh.quadrature`.
    """
    checks.anisotropy(anisotropy)
    P = np.asarray(P, dtype=float)
    T = np.asarray(T)
    if P.ndim != 2 or P.shape[1:] != (2,) or T.ndim != 2 or T.shape[1:] != (3,):
        raise QmeshError(f"P and T must have shapes (N, 2) and (M, 3), got {P.shape} and {T.shape}")
    x, y = corners(P, T)
    x0, x1, x2 = x.T
    y0, y1, y2 = y.T
    ax, ay, bx, by, cx, cy = x1 - x0, y1 - y0, x2 - x1, y2 - y1, x0 - x2, y0 - y2
    area = 0.5 * (ay * cx - ax * cy)
    if anisotropy.H is None:                          # s varies: no constant Hessian
        err = _interpolation_error_at_points(P, T, x, y, anisotropy)
        return area * (err @ quadrature.DUNAVANT4_WEIGHTS)   # (2.77)
    (h00, h01), (_, h11) = anisotropy.H
    edges2 = (h00 * (ax * ax + bx * bx + cx * cx) + 2.0 * h01 * (ax * ay + bx * by + cx * cy)
              + h11 * (ay * ay + by * by + cy * cy))
    return area * edges2 / 24.0                       # (2.77), closed form


def energy(mesh: Mesh, anisotropy: Given) -> float:
    """E = ∫_Ω (s_h − s) = ‖s_h − s‖_L1 (2.77) (MATH.md "Vertex adjustment"); with one s per
    region, the sum of each region's own. QmeshError without an s (a per-triangle Q)."""
    A = _resolve(mesh, anisotropy, allow_none=False)
    return float(sum(triangle_energy(mesh.points, mesh.triangles[sel], a).sum()
                     for sel, a in _by_region(mesh, A, "the energy (2.77)")))


# --------------------------------------------------------------------------- regions

def _check(anisotropy: Conductivity | None, mesh: Mesh | None = None,
           allow_none: bool = False) -> Conductivity | None:
    """An Anisotropy (or None when allowed), or a mapping {tag: Anisotropy} that covers every
    region of `mesh`."""
    if not isinstance(anisotropy, Mapping):
        return checks.anisotropy_or_none(anisotropy) if allow_none else checks.anisotropy(anisotropy)
    _check_tags(anisotropy, mesh)
    for k, v in anisotropy.items():
        checks.anisotropy(v, f"the conductivity of region {k}")
    return anisotropy


def _check_tags(mapping: Mapping[Any, Any], mesh: Mesh | None) -> None:
    """Integer keys that cover every region of `mesh`, or QmeshError."""
    for k in mapping:
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise QmeshError(f"conductivity keys must be region tags (integers), got {k!r}")
    if mesh is not None:
        missing = sorted(set(np.unique(mesh.region_tags).tolist()) - {int(k) for k in mapping})
        if missing:
            raise QmeshError(f"no conductivity for region {missing[0]} of the mesh "
                             f"(the mapping has {sorted(int(k) for k in mapping)})")


def _is_field(value: object) -> bool:
    return type(value).__name__ == "TensorField" and type(value).__module__ == "qmesh.conductivity.field"


def _resolve(mesh: Mesh, given: Given, name: str = "anisotropy", allow_none: bool = True) -> Resolved:
    """The conductivity to measure `mesh` with (see `Given`).

    None: the mesh's element means when it carries them, else Q = I (`allow_none`) or
    QmeshError. A TensorField, or a mapping holding one, becomes its element means per
    triangle (FIELDS.md §2; an Anisotropy's regions in such a mapping: Q at the centroid). An
    explicit argument is what is measured, also for a mesh that carries means.
    """
    checks.mesh(mesh)
    if given is None:
        if mesh.conductivity is not None:
            return np.asarray(mesh.conductivity)
        if allow_none:
            return None
        raise QmeshError(f"{name} must be a qmesh.Anisotropy (or {{region tag: Anisotropy}}, a "
                         "TensorField, or one Q per triangle): the mesh carries no element means "
                         "(mesh.conductivity is None)")
    if _is_field(given):
        return np.asarray(given.means(mesh.points, mesh.triangles), dtype=float)  # type: ignore[union-attr]
    if isinstance(given, Mapping):
        if not any(_is_field(v) for v in given.values()):
            return _check(given, mesh)           # type: ignore[arg-type]
        _check_tags(given, mesh)
        out = np.empty((mesh.n_triangles, 2, 2))
        P, T, tags = mesh.points, mesh.triangles, mesh.region_tags
        for r in np.unique(tags).tolist():
            sel = tags == r
            v = given[r]
            if _is_field(v):
                out[sel] = v.means(P, T[sel])                # type: ignore[union-attr]
            else:
                x, y = corners(P, T[sel])
                q11, q12, q22 = _conductivity(x, y, checks.anisotropy(v, f"the conductivity of region {r}"))
                out[sel, 0, 0], out[sel, 0, 1], out[sel, 1, 0], out[sel, 1, 1] = q11, q12, q12, q22
        return out
    if isinstance(given, (np.ndarray, list, tuple)):
        shape = np.shape(given)
        if len(shape) != 3:
            checks.anisotropy(given, name)       # the hint: Anisotropy.constant for one matrix
        Q = checks.real_array(given, f"{name} (one Q per triangle)", (mesh.n_triangles, 2, 2))
        return 0.5 * (Q + Q.transpose(0, 2, 1))  # the symmetric part: what the assembly uses
    return _check(given, mesh, allow_none)      # type: ignore[arg-type]


def _by_region(mesh: Mesh, anisotropy: Resolved, what: str = "this measure"
               ) -> list[tuple[slice | NDArray[np.bool_], Anisotropy]]:
    """[(triangle selector, Anisotropy)]: everything for one Anisotropy, one pair per region
    present in the mesh for a mapping. A per-triangle Q has no s: QmeshError naming `what`."""
    if anisotropy is None or isinstance(anisotropy, np.ndarray):
        raise QmeshError(f"{what} needs s(x, y) (an Anisotropy); a conductivity given per "
                         "triangle (element means) has none")
    _check(anisotropy, mesh)
    if not isinstance(anisotropy, Mapping):
        return [(slice(None), anisotropy)]
    tags = mesh.region_tags
    return [(tags == r, anisotropy[r]) for r in np.unique(tags).tolist()]


def _has_s(anisotropy: Resolved) -> bool:
    """True when every part of the conductivity comes from an s (energy, errors defined)."""
    if anisotropy is None or isinstance(anisotropy, np.ndarray):
        return False
    parts = anisotropy.values() if isinstance(anisotropy, Mapping) else [anisotropy]
    return all(getattr(a, "potential", True) for a in parts)


# --------------------------------------------------------------------------- quality

def quality(mesh: Mesh, anisotropy: Given = None) -> NDArray[np.float64]:
    """Metric quality (2.94) of every triangle: 1 = equilateral in metric space, ≤ 0 = degenerate/inverted.

    Each triangle in its own metric: ∇²s at its centroid, or for a per-triangle Q (element
    means) H_T = adj Q̄_T / √det Q̄_T (the quality does not depend on the metric's scale; NaN
    where Q̄_T is not positive definite).
    """
    A = _resolve(mesh, anisotropy, allow_none=False)
    P, T = mesh.points, mesh.triangles
    if isinstance(A, np.ndarray):
        return metric_quality(P, T, _metric_of(A))                       # (2.94), own H_T
    if isinstance(A, Mapping):
        H = np.empty((len(T), 2, 2))
        for sel, a in _by_region(mesh, A):
            H[sel] = metric_hessians(a, P, T[sel])
        return metric_quality(P, T, H)                                  # (2.94), own metric
    assert A is not None
    return metric_quality(P, T, metric_hessians(A, P, T))   # (2.94)


def _metric_of(Q: NDArray[np.float64]) -> NDArray[np.float64]:
    """H_T = adj Q̄_T / √det Q̄_T for every triangle (FIELDS.md §3), NaN where det ≤ 0."""
    return shape_metric(Q)


# --------------------------------------------------------------------------- stiffness

def _conductivity(x: NDArray[np.float64], y: NDArray[np.float64], anisotropy: Resolved,
                  regions: NDArray[np.int64] | None = None) -> tuple[PerTriangle, PerTriangle, PerTriangle]:
    """Q11, Q12, Q22 per triangle (scalars when Q is constant; None → Q = I; an array (M, 2, 2):
    its entries, one Q per triangle of x, y; an Anisotropy: Q at the centroid; a mapping: each
    triangle its region's, by `regions`)."""
    if isinstance(anisotropy, np.ndarray):
        return anisotropy[:, 0, 0], 0.5 * (anisotropy[:, 0, 1] + anisotropy[:, 1, 0]), anisotropy[:, 1, 1]
    if isinstance(anisotropy, Mapping):
        assert regions is not None, "a conductivity per region needs the triangles' regions"
        out = np.empty((3, len(x)))
        for r in np.unique(regions).tolist():
            sel = regions == r
            out[:, sel] = np.asarray([np.broadcast_to(q, (int(sel.sum()),)) for q in
                                      _conductivity(x[sel], y[sel], anisotropy[r])])
        return out[0], out[1], out[2]
    if anisotropy is None:
        return 1.0, 0.0, 1.0
    if anisotropy.H is not None:                            # a constant Q
        (h00, h01), (_, h11) = anisotropy.H
        return h11, -h01, h00                                  # Q = adj H
    Q = np.asarray(anisotropy.Q(np.stack([x.mean(axis=1), y.mean(axis=1)], axis=1)), dtype=float)
    return Q[:, 0, 0], 0.5 * (Q[:, 0, 1] + Q[:, 1, 0]), Q[:, 1, 1]


def _rows(anisotropy: Resolved, c: slice) -> Resolved:
    """The conductivity of the triangles `c` (a per-triangle array is sliced)."""
    return anisotropy[c] if isinstance(anisotropy, np.ndarray) else anisotropy


def _element_entries(P: NDArray[np.float64], T: NDArray[np.int64], anisotropy: Resolved,
                     regions: NDArray[np.int64] | None, a: NDArray[np.intp],
                     b: NDArray[np.intp]) -> tuple[NDArray[np.float64], int]:
    """K_T[a_k, b_k] = |T| ∇φ_aᵀ Q_T ∇φ_b for every triangle and corner pair k: (M, len(a)),
    and how many of the triangles have zero area (their entries are not finite).

    ∇φ_a = ∇_{x_a}|T| / |T| (signed area), so K_T[a, b] = G_aᵀ Q_T G_b / | |T| | with
    G_a = ∇_{x_a}|T| (2.69); Q_T is the triangle's element mean Q̄_T when the conductivity is
    given per triangle (FIELDS.md §2), else Q at its centroid. `anisotropy=None` is Q = I.
    """
    F = Frame(P, T)
    x, y, gx, gy, area = F.x, F.y, F.gx, F.gy, F.A
    q11, q12, q22 = (np.reshape(q, (-1, 1)) if np.ndim(q) else q
                     for q in _conductivity(x, y, anisotropy, regions))
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = (1.0 / np.abs(area))[:, None]
        gxa, gya, gxb, gyb = gx[:, a], gy[:, a], gx[:, b], gy[:, b]
        K = ((q11 * gxa + q12 * gya) * gxb + (q12 * gxa + q22 * gya) * gyb) * inv   # (2.69)
    return K, int(np.count_nonzero(area == 0.0))


def _refuse_zero_areas(zero: int) -> None:
    if zero:
        raise QmeshError(f"mesh has {zero} degenerate (zero-area) triangles; "
                         "its stiffness matrix is undefined")


_UPPER_PAIRS = (np.array([0, 1, 2, 0, 1, 0]), np.array([0, 1, 2, 1, 2, 2]))   # diagonal, then a < b


def _assemble(mesh: Mesh, anisotropy: Resolved, index: NDArray[np.int64], n: int) -> sp.csr_matrix:
    """Sum the element matrices into an n×n csr matrix; vertex v goes to row index[v] (< 0: dropped).

    Each K_T's diagonal and upper entries are computed once and the lower ones mirrored, so the
    matrix is exactly symmetric (its csr arrays are also its csc ones)."""
    T = mesh.triangles
    Ke, zero = _element_entries(mesh.points, T, anisotropy, mesh.region_tags, *_UPPER_PAIRS)
    _refuse_zero_areas(zero)
    it = index[T].astype(np.int32) if n < 2**31 - 1 else index[T]
    a, b = _UPPER_PAIRS
    rows = np.concatenate([it[:, a], it[:, b[3:]]], axis=1).ravel()
    cols = np.concatenate([it[:, b], it[:, a[3:]]], axis=1).ravel()
    data = np.concatenate([Ke, Ke[:, 3:]], axis=1).ravel()
    keep = (rows >= 0) & (cols >= 0)
    if not keep.all():
        rows, cols, data = rows[keep], cols[keep], data[keep]
    return sp.coo_matrix((data, (rows, cols)), shape=(n, n)).tocsr()


def stiffness(mesh: Mesh, anisotropy: Given) -> sp.csr_matrix:
    """The N×N P1 stiffness matrix K_ij = Σ_T |T| ∇φ_iᵀ Q_T ∇φ_j (Neumann: all vertices), Q_T
    each triangle's element mean when the conductivity is given per triangle (or None and the
    mesh carries its means), else Q at the centroid (None without means: Q = I)."""
    A = _resolve(mesh, anisotropy)
    n = mesh.n_vertices
    return _assemble(mesh, A, np.arange(n), n)


def free_vertices(mesh: Mesh) -> NDArray[np.int64]:
    """Indices of the Dirichlet unknowns: vertices of some triangle that are not on the boundary."""
    checks.mesh(mesh)
    used = np.zeros(mesh.n_vertices, bool)
    used[mesh.triangles.ravel()] = True
    return np.flatnonzero(used & ~mesh.boundary)


def stiffness_interior(mesh: Mesh, anisotropy: Given) -> sp.csr_matrix:
    """The stiffness matrix restricted to `free_vertices(mesh)`, in that order (homogeneous Dirichlet)."""
    return _stiffness_interior(mesh, _resolve(mesh, anisotropy))


def _stiffness_interior(mesh: Mesh, anisotropy: Resolved) -> sp.csr_matrix:
    idx = free_vertices(mesh)
    index = np.full(mesh.n_vertices, -1, dtype=np.int64)
    index[idx] = np.arange(len(idx))
    return _assemble(mesh, anisotropy, index, len(idx))


def edge_weights(mesh: Mesh, anisotropy: Given
                 ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.bool_]]:
    """Every edge (k, 2) (i < j), its weight q_ij = −K_ij (k,), and whether it is interior (k,).

    q_ij = ½ Σ_T √det Q_T cot θ_k^T, θ_k^T the angle opposite the edge in T measured in
    adj Q_T (MATH.md, Glickenstein 2007; FIELDS.md §3). Summed per edge from the element
    matrices, so no sparse look-up is needed; on a boundary edge (one triangle) q_ij is the
    off-diagonal entry of that triangle's element matrix. The conductivity as in `stiffness`.
    """
    return _edge_weights(mesh, _resolve(mesh, anisotropy))


def _edge_weights(mesh: Mesh, anisotropy: Resolved
                  ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.bool_]]:
    """As `edge_weights`."""
    pattern, q, interior = _q_per_edge(mesh, anisotropy)
    return _edges_of(pattern), q, interior


def _q_per_edge(mesh: Mesh, anisotropy: Resolved
                ) -> tuple[sp.csr_matrix, NDArray[np.float64], NDArray[np.bool_]]:
    """q_ij and whether the edge is interior, in the order of sorted (i, j), and the sparse
    pattern that holds that order (`_edges_of`: the edges themselves, which the shares of
    q_ij ≥ 0 do without)."""
    T = mesh.triangles
    # −K_T[a, b] for the three corner pairs only, CHUNK triangles at a time (the (M, 3, 3)
    # element matrices of a whole mesh would be the largest array of `qmesh mesh`'s summary at 1e6)
    q_part: NDArray[np.float64] = np.empty((len(_EDGE_CORNERS), len(T)))
    regions = mesh.region_tags
    zero = 0                                                   # counted over all blocks
    for c in chunks(len(T)):
        K, z = _element_entries(mesh.points, T[c], _rows(anisotropy, c),
                                None if regions is None else regions[c], *_EDGE_PAIRS)
        q_part[:, c], zero = -K.T, zero + z
    _refuse_zero_areas(zero)
    q_part = q_part.ravel()
    pairs = _edge_pairs(T, mesh.n_vertices)
    # summed per (i, j) by a sparse matrix (a counting sort), in the order of sorted (i, j)
    summed_q, count = _per_edge(pairs, mesh.n_vertices, q_part, np.ones(len(q_part), np.int8))
    return summed_q, summed_q.data, count.data == 2                   # q_ij = −K_ij (2.67)


EdgeKind = Literal["interior", "interface", "boundary"]


def edge_q(mesh: Mesh, conductivity: Given = None
           ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.str_]]:
    """Every edge (E, 2) (i < j, sorted), its q_ij = −K_ij (E,), and its kind (E,): "interior"
    (two triangles of one region), "interface" (two triangles of different regions) or
    "boundary" (one triangle) — what a caller needs to certify a mesh: the Dirichlet matrix is
    an M-matrix when q_ij ≥ 0 on every interior and interface edge, the Neumann one when also on
    the boundary edges.

    q_ij = ½ Σ_T √det Q̄_T cot θ_k^T (θ_k^T opposite the edge in T, measured in H_T = adj Q̄_T),
    equivalently −K_ij with K_ij = Σ_T |T| ∇φ_iᵀ Q̄_T ∇φ_j (FIELDS.md §3). `conductivity`: one Q
    per triangle (M, 2, 2), a TensorField (its element means), an Anisotropy or {tag: ...}; None
    takes the mesh's element means, or Q = I when it carries none.
    """
    A = _resolve(mesh, conductivity, "conductivity")
    edges, q, interior = _edge_weights(mesh, A)
    kind = np.full(len(q), "boundary", dtype="<U9")
    kind[interior] = "interior"
    tags = mesh.region_tags
    if len(tags) and tags.min() != tags.max():
        kind[interface_edges(mesh)[1]] = "interface"
    return edges, q, kind


def _edge_pairs(T: NDArray[np.int64], n: int) -> NDArray[np.signedinteger]:
    """(3M, 2) sorted vertex pairs of every triangle's edges, corner pair by corner pair
    (_EDGE_CORNERS); int32 where the indices fit (half the memory at 1e6 vertices)."""
    T = T.astype(np.int32) if n < 2**31 - 1 else T
    a, b = T[:, _EDGE_PAIRS[0]].T, T[:, _EDGE_PAIRS[1]].T                # (3, M) each
    # the smaller and the larger end, not a sort along rows: a third of the time at 1e6
    return np.stack([np.minimum(a, b).ravel(), np.maximum(a, b).ravel()], axis=1)


def _per_edge(pairs: NDArray[np.signedinteger], n: int, *values: NDArray[Any]
              ) -> list[sp.csr_matrix]:
    """Each of `values` summed over the distinct rows (i, j) of `pairs`: sparse matrices of one
    pattern, their `data` in the order of sorted (i, j)."""
    return [sp.csr_matrix((v, (pairs[:, 0], pairs[:, 1])), shape=(n, n)) for v in values]


def _edges_of(summed: sp.csr_matrix) -> NDArray[np.int64]:
    """The rows (i, j) of `_per_edge`'s pattern, sorted: its data's edges."""
    rows = np.repeat(np.arange(summed.shape[0], dtype=np.int64), np.diff(summed.indptr))
    return np.stack([rows, summed.indices.astype(np.int64)], axis=1)


def interface_edges(mesh: Mesh) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Every edge (k, 2) (i < j, as `edge_weights`) and whether its two triangles lie in
    different regions (an interface edge)."""
    T = mesh.triangles
    pairs = _edge_pairs(T, mesh.n_vertices)
    rank = np.unique(mesh.region_tags, return_inverse=True)[1].ravel().astype(float)   # 0, 1, …
    r = np.tile(rank, 3)
    # two triangles' regions a, b differ iff 2(a² + b²) > (a + b)² (exact: small integers)
    count, total, squares = _per_edge(pairs, mesh.n_vertices, np.ones(len(r)), r, r * r)
    return _edges_of(count), (count.data == 2) & (2.0 * squares.data > total.data ** 2)


def _relative_q(mesh: Mesh, anisotropy: Resolved,
                split: bool = False) -> tuple[NDArray[np.float64], ...]:
    """Interior and boundary q_ij, each divided by max |q| over all edges; with `split`, the
    interior ones apart from the interface ones: (interior, boundary, interface)."""
    _, q, interior = _q_per_edge(mesh, anisotropy)
    scale = np.abs(q).max() if len(q) else 1.0
    r = q / (scale if scale > 0 else 1.0)
    if not split:
        return r[interior], r[~interior]
    tags = mesh.region_tags
    inter = (interface_edges(mesh)[1] if len(tags) and tags.min() != tags.max()
             else np.zeros(len(q), bool))                      # one region: no interface
    return r[interior & ~inter], r[~interior], r[interior & inter]


def q_nonnegative_fractions(mesh: Mesh, anisotropy: Given,
                            rtol: float = Q_RTOL) -> dict[str, float | None]:
    """The shares of q_ij ≥ −rtol·max|q| as `report` gives them, from one assembly:
    "q_nonnegative_fraction" (interior edges; None also with no interior vertex: no Dirichlet
    matrix), "q_nonnegative_fraction_boundary", and "q_nonnegative_fraction_interface" when
    the mesh has interface edges or `anisotropy` is a mapping."""
    rtol = checks.real(rtol, "rtol", low=0.0, high=1.0)
    A = _resolve(mesh, anisotropy)
    return _shares(_relative_q(mesh, A, split=True), len(free_vertices(mesh)) > 0,
                   isinstance(anisotropy, Mapping), rtol)


def _shares(relative: tuple[NDArray[np.float64], ...], has_interior: bool, per_region: bool,
            rtol: float) -> dict[str, float | None]:
    r_in, r_b, r_if = relative
    out = {"q_nonnegative_fraction": _fraction_nonnegative(r_in, rtol) if has_interior else None,
           "q_nonnegative_fraction_boundary": _fraction_nonnegative(r_b, rtol)}
    if len(r_if) or per_region:
        out["q_nonnegative_fraction_interface"] = _fraction_nonnegative(r_if, rtol)
    return out


def q_nonnegative_fraction(mesh: Mesh, anisotropy: Given, rtol: float = Q_RTOL) -> float | None:
    """Fraction of interior edges with q_ij ≥ −rtol·max|q| (None when there is no interior edge).

    ≥ 0 on every interior edge makes the Dirichlet stiffness matrix an M-matrix.
    """
    rtol = checks.real(rtol, "rtol", low=0.0, high=1.0)
    return _fraction_nonnegative(_relative_q(mesh, _resolve(mesh, anisotropy), split=True)[0], rtol)


def q_nonnegative_fraction_interface(mesh: Mesh, anisotropy: Given,
                                     rtol: float = Q_RTOL) -> float | None:
    """Fraction of interface edges (two triangles of different regions, each with its own Q)
    with q_ij ≥ −rtol·max|q| (None when there is none). MEDIA.md §2."""
    rtol = checks.real(rtol, "rtol", low=0.0, high=1.0)
    return _fraction_nonnegative(_relative_q(mesh, _resolve(mesh, anisotropy), split=True)[2], rtol)


def q_nonnegative_fraction_boundary(mesh: Mesh, anisotropy: Given,
                                    rtol: float = Q_RTOL) -> float | None:
    """Fraction of boundary edges with q_ij ≥ −rtol·max|q| (None when there is no boundary edge).

    A boundary edge's q_ij is the off-diagonal of its one triangle's element matrix; ≥ 0 there
    as well as inside makes the Neumann stiffness matrix an M-matrix too.
    """
    rtol = checks.real(rtol, "rtol", low=0.0, high=1.0)
    return _fraction_nonnegative(_relative_q(mesh, _resolve(mesh, anisotropy))[1], rtol)


def _fraction_nonnegative(r: NDArray[np.float64], rtol: float) -> float | None:
    return float(np.mean(r >= -rtol)) if len(r) else None


# --------------------------------------------------------------------------- monotonicity

Monotonicity = _monotone.Monotonicity


def monotonicity(mesh: Mesh, conductivity: Given = None, *, rtol: float = 1e-9) -> Monotonicity:
    """Which certificate shows that the Dirichlet stiffness matrix keeps the discrete maximum
    principle with its boundary couplings (A⁻¹ ≥ 0 and −A⁻¹B ≥ 0): `str()` of the value is
    "M-matrix" (every q_ij ≥ 0 on an edge with an interior end), "monotone" (every positive
    entry is dominated by the paths through vertices without one, eliminated level by level
    until an M-matrix is left: the guide's page "Monotonicity" states and proves it) or
    "none", with the evidence (`qmesh.monotonicity.Monotonicity`: counts, the vertex pairs
    whose positive entry is left).

    `conductivity` as in `stiffness` (None: the mesh's element means, or Q = I). Entries
    within rtol · max |K_ij| of 0 count as 0. A mesh without interior vertex is an M-matrix
    (no entry to break it); Q not positive definite on some triangle, or a part of the mesh
    with no boundary vertex, gives "none" and the `reason`. QmeshError on a zero-area triangle.
    """
    rtol = checks.real(rtol, "rtol", low=0.0, high=1.0)
    A = _resolve(mesh, conductivity, "conductivity")
    return _monotonicity(mesh, A, rtol)


def _monotonicity(mesh: Mesh, anisotropy: Resolved, rtol: float = 1e-9) -> Monotonicity:
    free = free_vertices(mesh)
    if len(free) == 0:
        return _monotone.without_matrix("M-matrix", 0, "the mesh has no interior vertex: the "
                                        "Dirichlet matrix is empty")
    not_spd = _not_positive_definite(mesh, anisotropy)
    if not_spd:
        return _monotone.without_matrix("none", len(free), f"Q is not positive definite on "
                                        f"{not_spd} of the {mesh.n_triangles} triangles")
    floating = _floating(mesh, free)
    if floating:
        return _monotone.without_matrix("none", len(free), f"{floating} interior vertices lie in "
                                        "parts of the mesh with no boundary vertex")
    n = mesh.n_vertices
    K = _assemble(mesh, anisotropy, np.arange(n), n)
    used = np.zeros(n, bool)
    used[mesh.triangles.ravel()] = True
    return _monotone.certify(K, free, np.flatnonzero(used & mesh.boundary), rtol)


# --------------------------------------------------------------------------- conditioning

KAPPA_LIMIT = 1e-3 / float(np.finfo(float).eps)
"""Above this κ2 (≈ 4.5e12) the computed λ_min is mostly round-off (its relative error is about
κ2·ε times a modest factor): the matrix is reported numerically singular, with no κ2."""


class Conditioning(NamedTuple):
    """κ2 = λ_max / λ_min of the Dirichlet stiffness matrix, or why there is none.

    `kappa2` is a finite number ≥ 1 or None; when None, `reason` says why (no interior vertex,
    a part of the mesh that touches no boundary, a degenerate triangle, Q not positive definite,
    numerically singular). λ_min and λ_max are given when computed.
    """

    kappa2: float | None
    reason: str | None = None
    lambda_min: float | None = None
    lambda_max: float | None = None


def condition_number(mesh: Mesh, anisotropy: Given = None, *,
                     method: Literal["auto", "dense", "sparse", "multigrid"] = "auto", tol: float = 1e-6) -> float:
    """κ2 = λ_max / λ_min of the Dirichlet-reduced stiffness matrix (MATH.md "conditioning"),
    always a finite number ≥ 1: QmeshError saying why when the matrix has none (see
    `conditioning`, which returns the reason instead of raising)."""
    c = conditioning(mesh, anisotropy, method=method, tol=tol)
    if c.kappa2 is None:
        raise QmeshError(f"κ2 is undefined: {c.reason}")
    return c.kappa2


def conditioning(mesh: Mesh, anisotropy: Given = None, *,
                 method: Literal["auto", "dense", "sparse", "multigrid"] = "auto", tol: float = 1e-6) -> Conditioning:
    """κ2 of the Dirichlet-reduced stiffness matrix K (`stiffness_interior`), or why there is none.

    K = Σ_T K_T with K_T = G_T Q_T G_Tᵀ / |T| positive semi-definite when Q_T is, with kernel the
    constants on T (2.69); so K is positive definite exactly when every Q_T is, no triangle is
    degenerate and every connected part of the mesh has a boundary vertex (else the constants on
    that part are in its kernel). These are checked first, from the mesh alone; then
    "dense" (n ≤ DENSE_LIMIT under "auto"): eigvalsh; "sparse": λ_max by Lanczos on K
    (matrix-vector products only, on a second thread while λ_min is computed) and λ_min
    as 1 / the largest eigenvalue of K⁻¹, by Lanczos with K⁻¹ applied by ONE sparse
    factorisation (`_inverse`: LDLᵀ by qdldl, else SuperLU in symmetric mode); "multigrid"
    (n ≥ MULTIGRID_LIMIT and K near an M-matrix under "auto"): the same λ_max, and λ_min by
    LOBPCG preconditioned by algebraic multigrid (`multigrid_eigen`; the factorisation where
    that does not converge). `tol` bounds the Lanczos residual relative to the eigenvalue (so an eigenvalue
    lies that close), and LOBPCG's to √tol; the extreme eigenvalues themselves come out about
    tol² and tol relative (residual² / gap), far below the figures printed. A κ2 above
    KAPPA_LIMIT is round-off and is reported as numerically singular.

    `anisotropy` as in `stiffness` (None: the mesh's element means, or Q = I without them).
    """
    checks.choice(method, "method", ("auto", "dense", "sparse", "multigrid"))
    tol = checks.real(tol, "tol", low=0.0, high=1.0, high_open=True)
    return _conditioning(mesh, _resolve(mesh, anisotropy), method, tol)


def _conditioning(mesh: Mesh, anisotropy: Resolved, method: str = "auto", tol: float = 1e-6) -> Conditioning:
    free = free_vertices(mesh)
    n = len(free)
    if n == 0:
        return Conditioning(None, "the mesh has no interior vertex: there is no Dirichlet matrix")
    not_spd = _not_positive_definite(mesh, anisotropy)
    if not_spd:
        return Conditioning(None, f"Q is not positive definite on {not_spd} of the "
                                  f"{mesh.n_triangles} triangles: K is not a conductivity's matrix")
    floating = _floating(mesh, free)
    if floating:
        return Conditioning(None, f"{floating} of the {n} interior vertices lie in parts of the mesh "
                                  "that touch no boundary vertex (a mesh still being built?): the "
                                  "Dirichlet matrix is singular there")
    try:
        K = _stiffness_interior(mesh, anisotropy)
    except QmeshError as e:                                  # zero-area triangles
        return Conditioning(None, str(e))
    if method == "dense" or n < 3 or (method == "auto" and n <= DENSE_LIMIT):
        w = scipy.linalg.eigvalsh(K.toarray())
        return _ratio(float(w[0]), float(w[-1]))
    v0 = np.random.default_rng(0).random(n)                   # fixed start: same mesh ⇒ same κ2
    with ThreadPoolExecutor(max_workers=1) as beside:
        # λ_max's products K·v run on the other core while λ_min's factorisation (which leaves
        # Python's lock) or multigrid runs on this one: κ2 in about the time of λ_min alone
        largest = beside.submit(_largest_eigenvalue, K.dot, v0, tol, 4)
        lmin = _smallest_eigenvalue(K, v0, tol, method)
        lmax = largest.result()
    if isinstance(lmin, str):
        return Conditioning(None, lmin, None, lmax)
    return _ratio(lmin, lmax)


def _smallest_eigenvalue(K: sp.csr_matrix, v0: NDArray[np.float64], tol: float,
                         method: str) -> float | str:
    """λ_min by multigrid where K is large and near an M-matrix (`multigrid_eigen.suits`), or
    "multigrid" is asked; else as 1 / the largest eigenvalue of K⁻¹ by Lanczos through one
    factorisation; or why K has no factorisation."""
    if method == "multigrid" or (method == "auto" and len(v0) >= multigrid_eigen.MULTIGRID_LIMIT
                                 and multigrid_eigen.suits(K)):
        lmin = multigrid_eigen.smallest_eigenvalue(K, v0, tol)
        if lmin is not None:
            return lmin
    solve = _inverse(K)
    if isinstance(solve, str):
        return solve
    mu = _largest_eigenvalue(solve, v0, tol)
    return 1.0 / mu if mu > 0 else -np.inf


def _inverse(K: sp.csr_matrix) -> Callable[[NDArray[np.float64]], NDArray[np.float64]] | str:
    """x ↦ K⁻¹x through one sparse factorisation of the symmetric K, or why there is none.

    LDLᵀ by qdldl (AMD ordering; a pivot ≤ 0 means K is not numerically positive definite)
    when it is installed, else SuperLU in symmetric mode (minimum degree on Kᵀ + K, diagonal
    pivots), which computes L and U: about twice the time."""
    C = sp.csc_matrix((K.data, K.indices, K.indptr), shape=K.shape)      # K = Kᵀ (`_assemble`)
    try:
        import qdldl
    except ImportError:
        qdldl = None
    try:
        if qdldl is None:
            return spla.splu(C, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                             options={"SymmetricMode": True}).solve
        ldl = qdldl.Solver(sp.triu(C, format="csc"), upper=True)    # the half it reads
    except RuntimeError:                          # SuperLU: "exactly singular"; qdldl: D_k = 0
        return "the Dirichlet matrix is singular (a zero pivot)"
    factors = getattr(ldl, "factors", None)       # (L, D, P) from qdldl 0.1.9 on
    if factors is not None and not np.all(factors()[1] > 0.0):
        return ("the Dirichlet matrix is numerically singular (a pivot ≤ 0 in its LDLᵀ "
                "factorisation: round-off outweighs its smallest eigenvalue)")
    solve: Callable[[NDArray[np.float64]], NDArray[np.float64]] = ldl.solve
    return solve


LANCZOS_STEPS = 600
"""Lanczos steps before `_largest_eigenvalue` hands over to ARPACK (eigsh)."""


def _dot(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    # einsum's own loop, not BLAS: OpenBLAS threads a long dot product, and on a busy machine
    # its threads wait for each other (κ2 at 1e5 took several times longer that way)
    return float(np.einsum("i,i->", a, b))


def _largest_eigenvalue(apply: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                        v0: NDArray[np.float64], tol: float, every: int = 1) -> float:
    """The largest eigenvalue of a symmetric operator x ↦ apply(x), by the Lanczos recurrence
    β_{k+1} v_{k+1} = A v_k − α_k v_k − β_k v_{k−1}, stopped when the largest Ritz value θ of
    the tridiagonal T_k has the residual ‖A y − θ y‖ = β_{k+1} |s_k| ≤ tol·|θ| (s its
    eigenvector of T_k), checked at each of the first 8 steps, then at every `every`-th (a
    check costs a good part of a sparse product K·v, not of a solve). Without
    reorthogonalisation: lost orthogonality only repeats converged Ritz values, and the largest
    one converges as in exact arithmetic (Paige 1971). ARPACK's eigsh when LANCZOS_STEPS are
    not enough; NaN when `apply` gives non-finite numbers.
    """
    v = v0 / np.sqrt(_dot(v0, v0))
    v_old = np.zeros_like(v)
    tmp = np.empty_like(v)                         # scratch: no new vector a step but apply's
    # (apply may return its own buffer, the same at each call, or its argument: w is only read
    # into v_old's array, and copied first when it is v's or v_old's memory)
    alpha: list[float] = []
    beta: list[float] = []
    b = 0.0
    for k in range(LANCZOS_STEPS):
        w = np.asarray(apply(v), dtype=float)      # updated in place below: never v's memory
        if not w.flags.writeable or np.may_share_memory(w, v) or np.may_share_memory(w, v_old):
            w = w.copy()
        if b:
            w -= np.multiply(v_old, b, out=tmp)
        a = _dot(w, v)
        w -= np.multiply(v, a, out=tmp)
        b = np.sqrt(_dot(w, w))
        alpha.append(a)
        if not (np.isfinite(a) and np.isfinite(b)):
            return float("nan")
        if k < 8 or (k + 1) % every == 0 or b == 0.0:
            theta, s = scipy.linalg.eigh_tridiagonal(np.array(alpha), np.array(beta), select="i",
                                                     select_range=(k, k))
            if b * abs(s[-1, 0]) <= tol * abs(theta[0]) or b == 0.0:
                return float(theta[0])
        beta.append(b)
        np.divide(w, b, out=v_old)                 # v_{k+1} in v_{k−1}'s array: v, v_old stay ours
        v_old, v = v, v_old
    n = len(v0)
    op = spla.LinearOperator((n, n), matvec=apply, dtype=float)
    return float(spla.eigsh(op, k=1, which="LA", tol=tol, v0=v0, return_eigenvectors=False)[0])


def _ratio(lmin: float, lmax: float) -> Conditioning:
    """κ2 = λ_max / λ_min when it is a number from 1 to KAPPA_LIMIT; else why not."""
    if not (np.isfinite(lmin) and np.isfinite(lmax)) or lmin <= 0.0 or lmax <= 0.0:
        return Conditioning(None, f"the Dirichlet matrix is not positive definite (λ_min = {lmin:.3g})",
                            lmin, lmax)
    kappa = lmax / lmin
    if not kappa <= KAPPA_LIMIT:
        return Conditioning(None, f"the Dirichlet matrix is numerically singular (λ_max/λ_min ≈ "
                                  f"{kappa:.2g}, beyond what double precision resolves)", lmin, lmax)
    return Conditioning(float(max(kappa, 1.0)), None, lmin, lmax)


def _not_positive_definite(mesh: Mesh, anisotropy: Resolved) -> int:
    """How many triangles' Q_T are not symmetric positive definite (0 for Q = I and a constant Q,
    which Anisotropy.constant checked)."""
    if anisotropy is None:
        return 0
    parts = list(anisotropy.values()) if isinstance(anisotropy, Mapping) else [anisotropy]
    if all(getattr(a, "H", None) is not None for a in parts):
        return 0
    x, y = corners(mesh.points, mesh.triangles)
    q11, q12, q22 = (np.broadcast_to(q, (mesh.n_triangles,))
                     for q in _conductivity(x, y, anisotropy, mesh.region_tags))
    with np.errstate(invalid="ignore"):
        ok = (q11 > 0) & (q11 * q22 - q12 * q12 > 0)
    return int(np.count_nonzero(~ok))


def _floating(mesh: Mesh, free: NDArray[np.int64]) -> int:
    """How many of the `free` vertices lie in a connected part of the mesh (triangles sharing a
    vertex) with no boundary vertex."""
    n = mesh.n_vertices
    pairs = _edge_pairs(mesh.triangles, n)        # each edge of each triangle, one direction:
    graph = sp.csr_matrix((np.ones(len(pairs), np.int8), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    count, labels = csgraph.connected_components(graph, directed=False)   # undirected reads both
    grounded = np.zeros(count, bool)
    grounded[labels[mesh.boundary]] = True
    return int(np.count_nonzero(~grounded[labels[free]]))


# --------------------------------------------------------------------------- interpolation

def _quadrature_points(x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """The degree-4 rule's points of every triangle, flattened to (M·q, 2)."""
    bary = quadrature.DUNAVANT4_POINTS
    return np.stack([(x @ bary.T).ravel(), (y @ bary.T).ravel()], axis=1)


def _interpolation_error_at_points(P: NDArray[np.float64], T: NDArray[np.int64], x: NDArray[np.float64],
                                   y: NDArray[np.float64], anisotropy: Anisotropy,
                                   s_vertex: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """s_h − s at the degree-4 quadrature points of every triangle, shape (M, q)."""
    if s_vertex is None:
        s_vertex = np.asarray(anisotropy.s(P), dtype=float)[T]            # (M, 3)
    s_q = np.asarray(anisotropy.s(_quadrature_points(x, y)), dtype=float)
    return s_vertex @ quadrature.DUNAVANT4_POINTS.T - s_q.reshape(len(T), -1)


def interpolation_errors(mesh: Mesh, anisotropy: Given) -> tuple[float, float]:
    """(‖s_h − s‖_L2 (2.96), |s_h − s|_h1 = ‖∇s_h − ∇s‖_L2 (2.97)), exact for quadratic s.

    Both integrands are integrated with the degree-4 Dunavant rule: (s_h − s)² has degree 4 and
    |∇s_h − ∇s|² degree 2 when s is quadratic. QmeshError without an s (a per-triangle Q).
    """
    A = _resolve(mesh, anisotropy, allow_none=False)
    l2 = h1 = 0.0
    for sel, a in _by_region(mesh, A, "the interpolation errors (2.96)-(2.97)"):
        e2, g2 = _interpolation_errors2(mesh.points, mesh.triangles[sel], a)
        l2, h1 = l2 + e2, h1 + g2
    return float(np.sqrt(l2)), float(np.sqrt(h1))


def _interpolation_errors2(P: NDArray[np.float64], T: NDArray[np.int64],
                           anisotropy: Anisotropy) -> tuple[float, float]:
    """The squares of (2.96) and (2.97) over the triangles T."""
    F = Frame(P, T)
    x, y, gx, gy, area = F.x, F.y, F.gx, F.gy, F.A
    if np.any(area == 0.0):
        raise QmeshError("mesh has degenerate (zero-area) triangles; ∇s_h is undefined on them")
    w = quadrature.DUNAVANT4_WEIGHTS
    s_vertex = np.asarray(anisotropy.s(P), dtype=float)[T]
    err = _interpolation_error_at_points(P, T, x, y, anisotropy, s_vertex)
    l2 = np.abs(area) @ ((err * err) @ w)                                    # (2.96)
    grad_s = np.asarray(anisotropy.grad(_quadrature_points(x, y)), dtype=float).reshape(len(T), -1, 2)
    dx = ((s_vertex * gx).sum(axis=1) / area)[:, None] - grad_s[:, :, 0]   # ∇s_h = Σ_a s_a ∇φ_a
    dy = ((s_vertex * gy).sum(axis=1) / area)[:, None] - grad_s[:, :, 1]
    h1 = np.abs(area) @ ((dx * dx + dy * dy) @ w)                            # (2.97)
    return float(l2), float(h1)


# --------------------------------------------------------------------------- report

def _sampled_at(mesh: Mesh, given: Given) -> float | None:
    """The spacing the element means measured sample a callable field at: the mesh's own
    (`Mesh.means_sampled_at`) or the given field's (`TensorField.sampled_at`); None when every
    mean is exact or its error bound proven."""
    if given is None:
        return mesh.means_sampled_at
    fields: list[Any] = ([given] if _is_field(given) else
                         list(given.values()) if isinstance(given, Mapping) else [])
    h = [f.sampled_at(mesh.points, mesh.triangles) for f in fields if _is_field(f)]
    found = [float(v) for v in h if v is not None]
    return max(found) if found else None


def report(mesh: Mesh, anisotropy: Given = None, *, laplacian: bool = True) -> Report:
    """All measurements of one mesh as plain Python numbers and texts (JSON-serialisable).

    Entries that need a stiffness matrix or ∇s_h are None when the mesh has a zero-area
    triangle; κ2 is None when the Dirichlet matrix has none — no interior vertex, a part of the
    mesh with no boundary vertex, Q not positive definite, numerically singular — and then
    `kappa2_undefined` says why (`conditioning`); a share of q_ij ≥ 0 is None when there is no
    edge of its kind (interior, boundary), and the interior share also when there is no
    interior vertex (no Dirichlet matrix whose signs would matter).

    `anisotropy` may be a mapping {region tag: Anisotropy}: every triangle then uses its own
    region's Q. When the mesh has interface edges (or a mapping is given), the interior share
    counts edges inside one region, and `q_nonnegative_fraction_interface` /
    `min_q_ij_relative_interface` the interface edges (MEDIA.md §4). With one Q per triangle —
    None for a mesh that carries its element means, an array (M, 2, 2) or a TensorField — the
    stiffness matrix, q_ij, κ2 and the quality use those means, and the energy and the
    interpolation errors, which need an s, are None. `monotonicity` is
    `str(monotonicity(mesh, anisotropy))`: "M-matrix", "monotone" or "none" (None with a
    zero-area triangle). κ2 is computed once per matrix
    (`kappa2` with the conductivity, `kappa2_laplacian` with Q = I); `laplacian=False` leaves
    `kappa2_laplacian` out, for callers that keep only `kappa2` (it is another matrix's κ2,
    as long to compute). `means_sampled_at` is there when the element means are a callable
    field's: the spacing h of the samples they come from (the shares of q_ij ≥ 0 hold for Q as
    sampled at h; a jump or a bump narrower than h between samples can go unseen).
    """
    A = _resolve(mesh, anisotropy, allow_none=False)
    P, T = mesh.points, mesh.triangles
    area = signed_areas(P, T)
    qual = quality(mesh, A)
    n_interior = int(len(free_vertices(mesh)))
    has_s = _has_s(A)
    out: Report = {
        "n_vertices": int(mesh.n_vertices),
        "n_triangles": int(mesh.n_triangles),
        "n_boundary": int(mesh.boundary.sum()),
        "n_interior": n_interior,
        "inverted_triangles": int(np.sum(area <= 0.0)),
        "energy": energy(mesh, A) if has_s else None,
        "min_quality": float(qual.min()) if len(qual) else None,
        "mean_quality": float(qual.mean()) if len(qual) else None,
        "l2_error": None, "h1_error": None, "kappa2": None, "kappa2_laplacian": None,
        "q_nonnegative_fraction": None, "q_nonnegative_fraction_boundary": None,
        "min_q_ij_relative": None, "min_q_ij_relative_boundary": None, "monotonicity": None,
    }
    if not laplacian:
        del out["kappa2_laplacian"]
    sampled = _sampled_at(mesh, anisotropy)
    if sampled is not None:
        out["means_sampled_at"] = sampled
    if len(T) == 0 or np.any(area == 0.0):
        out["kappa2_undefined"] = ("the mesh has no triangle" if len(T) == 0 else
                                   "the mesh has degenerate (zero-area) triangles")
        return out
    with ThreadPoolExecutor(max_workers=1) as beside:
        # Q = I's κ2 (another factorisation) on the other core while the rest is measured here;
        # by the factorisation at any N: multigrid is made for the Q the mesh was stretched for,
        # and gives up on Q = I on a mesh stretched for another Q (a dozen steps lost at 1e5)
        plain = beside.submit(_conditioning, mesh, None, "sparse") if laplacian else None
        if has_s:
            out["l2_error"], out["h1_error"] = interpolation_errors(mesh, A)
        r_in, r_b, r_if = relative = _relative_q(mesh, A, split=True)
        out.update(_shares(relative, n_interior > 0, isinstance(anisotropy, Mapping), Q_RTOL))
        if len(r_if) or isinstance(anisotropy, Mapping):
            out["min_q_ij_relative_interface"] = float(r_if.min()) if len(r_if) else None
        out["min_q_ij_relative"] = float(r_in.min()) if len(r_in) else None
        out["min_q_ij_relative_boundary"] = float(r_b.min()) if len(r_b) else None
        out["monotonicity"] = str(_monotonicity(mesh, A))
        kappa = _conditioning(mesh, A)
        out["kappa2"] = kappa.kappa2
        if kappa.kappa2 is None:
            out["kappa2_undefined"] = kappa.reason
        if plain is not None:
            out["kappa2_laplacian"] = plain.result().kappa2
    return out


def sh_convex_fraction(mesh: Mesh, anisotropy: Anisotropy, rtol: float = 1e-9) -> float:
    """Share of interior edges across which s_h (the P1 interpolant of s) is convex.

    ∇²s_h is a measure on the edges, [∂s_h/∂n]·δ_e, so q_ij ≥ 0 for s_h (MATH.md) means a
    non-negative jump of the normal derivative of s_h across every interior edge ((2.74)–(2.75):
    the lifted facets meet convexly, as the Q-Delaunay connectivity guarantees after a
    triangulate stage); the jump is taken relative to the largest one. 1.0 when there is no
    interior edge.
    """
    checks.mesh(mesh)
    checks.anisotropy(anisotropy)
    checks.real(rtol, "rtol", low=0.0, high=1.0)
    P, T = mesh.points, mesh.triangles
    F = Frame(P, T)
    sv = np.asarray(anisotropy.s(P), dtype=float)[T]
    grad = np.column_stack([(sv * F.gx).sum(axis=1), (sv * F.gy).sum(axis=1)]) / F.A[:, None]  # ∇s_h per T
    pairs = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    tri = np.tile(np.arange(len(T)), 3)
    key = edge_keys(pairs[:, 0], pairs[:, 1], len(P))
    order = np.argsort(key, kind="stable")
    k = key[order]
    twin = np.flatnonzero(k[1:] == k[:-1])                 # interior edges: two half-edges
    a, b = order[twin], order[twin + 1]
    e = P[pairs[a, 1]] - P[pairs[a, 0]]                     # edge of triangle tri[a], Ω on its left
    n_out = np.column_stack([e[:, 1], -e[:, 0]])            # outward normal of tri[a] across it
    jump = np.einsum("ni,ni->n", grad[tri[b]] - grad[tri[a]], n_out) / np.hypot(e[:, 0], e[:, 1])
    if not len(jump):
        return 1.0
    scale = np.abs(jump).max()
    return float(np.mean(jump >= -rtol * (scale if scale > 0 else 1.0)))
