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
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Literal, Union

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from qmesh import checks
from qmesh.geometry import quadrature
from qmesh.errors import QmeshError
from qmesh.geometry.topology import edge_keys
from qmesh.geometry.triangles import Frame, chunks, corners, metric_hessians, metric_quality, signed_areas
from qmesh.triangle_mesh import Mesh

if TYPE_CHECKING:
    from qmesh.conductivity.anisotropy import Anisotropy, Conductivity

PerTriangle = Union[float, NDArray[np.float64]]
"""A value per triangle (M,), or one float for all of them (a constant Q)."""
Report = dict[str, Union[int, float, None]]
"""`report`'s measurements by name: ints, floats, and None where a figure is undefined."""

DENSE_LIMIT = 300
"""Up to this many unknowns condition_number uses a dense eigvalsh; above it, sparse eigsh.

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


def energy(mesh: Mesh, anisotropy: Conductivity) -> float:
    """E = ∫_Ω (s_h − s) = ‖s_h − s‖_L1 (2.77) (MATH.md "Vertex adjustment"); with one s per
    region, the sum of each region's own."""
    checks.mesh(mesh)
    return float(sum(triangle_energy(mesh.points, mesh.triangles[sel], A).sum()
                     for sel, A in _by_region(mesh, anisotropy)))


# --------------------------------------------------------------------------- regions

def _check(anisotropy: Conductivity | None, mesh: Mesh | None = None,
           allow_none: bool = False) -> Conductivity | None:
    """An Anisotropy (or None when allowed), or a mapping {tag: Anisotropy} that covers every
    region of `mesh`."""
    if not isinstance(anisotropy, Mapping):
        return checks.anisotropy_or_none(anisotropy) if allow_none else checks.anisotropy(anisotropy)
    for k, v in anisotropy.items():
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise QmeshError(f"conductivity keys must be region tags (integers), got {k!r}")
        checks.anisotropy(v, f"the conductivity of region {k}")
    if mesh is not None:
        missing = sorted(set(np.unique(mesh.region_tags).tolist()) - {int(k) for k in anisotropy})
        if missing:
            raise QmeshError(f"no conductivity for region {missing[0]} of the mesh "
                             f"(the mapping has {sorted(int(k) for k in anisotropy)})")
    return anisotropy


def _by_region(mesh: Mesh, anisotropy: Conductivity) -> list[tuple[slice | NDArray[np.bool_], Anisotropy]]:
    """[(triangle selector, Anisotropy)]: everything for one Anisotropy, one pair per region
    present in the mesh for a mapping."""
    _check(anisotropy, mesh)
    if not isinstance(anisotropy, Mapping):
        return [(slice(None), anisotropy)]
    tags = mesh.region_tags
    return [(tags == r, anisotropy[r]) for r in np.unique(tags).tolist()]


# --------------------------------------------------------------------------- quality

def quality(mesh: Mesh, anisotropy: Conductivity) -> NDArray[np.float64]:
    """Metric quality (2.94) of every triangle: 1 = equilateral in metric space, ≤ 0 = degenerate/inverted."""
    checks.mesh(mesh)
    P, T = mesh.points, mesh.triangles
    if isinstance(anisotropy, Mapping):
        H = np.empty((len(T), 2, 2))
        for sel, A in _by_region(mesh, anisotropy):
            H[sel] = metric_hessians(A, P, T[sel])
        return metric_quality(P, T, H)                                  # (2.94), own metric
    checks.anisotropy(anisotropy)
    return metric_quality(P, T, metric_hessians(anisotropy, P, T))   # (2.94)


# --------------------------------------------------------------------------- stiffness

def _conductivity(x: NDArray[np.float64], y: NDArray[np.float64], anisotropy: Conductivity | None,
                  regions: NDArray[np.int64] | None = None) -> tuple[PerTriangle, PerTriangle, PerTriangle]:
    """Q11, Q12, Q22 per triangle at its centroid (scalars when Q is constant; None → Q = I;
    a mapping: each triangle its region's, by `regions`)."""
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


def _element_entries(P: NDArray[np.float64], T: NDArray[np.int64], anisotropy: Conductivity | None,
                     regions: NDArray[np.int64] | None, a: NDArray[np.intp],
                     b: NDArray[np.intp]) -> tuple[NDArray[np.float64], int]:
    """K_T[a_k, b_k] = |T| ∇φ_aᵀ Q(x_T) ∇φ_b for every triangle and corner pair k: (M, len(a)),
    and how many of the triangles have zero area (their entries are not finite).

    ∇φ_a = ∇_{x_a}|T| / |T| (signed area), so K_T[a, b] = G_aᵀ Q G_b / | |T| | with
    G_a = ∇_{x_a}|T| (2.69). `anisotropy=None` is the Laplacian Q = I.
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


_ALL_PAIRS = (np.repeat(np.arange(3), 3), np.tile(np.arange(3), 3))


def _element_matrices(P: NDArray[np.float64], T: NDArray[np.int64], anisotropy: Conductivity | None,
                      regions: NDArray[np.int64] | None = None) -> NDArray[np.float64]:
    """The element matrices K_T, shape (M, 3, 3) (`_element_entries` for all nine pairs)."""
    K, zero = _element_entries(P, T, anisotropy, regions, *_ALL_PAIRS)
    _refuse_zero_areas(zero)
    return K.reshape(-1, 3, 3)


def _assemble(mesh: Mesh, anisotropy: Conductivity | None, index: NDArray[np.int64], n: int) -> sp.csr_matrix:
    """Sum the element matrices into an n×n csr matrix; vertex v goes to row index[v] (< 0: dropped)."""
    T = mesh.triangles
    Ke = _element_matrices(mesh.points, T, anisotropy, mesh.region_tags)
    it = index[T]
    rows = np.broadcast_to(it[:, :, None], Ke.shape).ravel()
    cols = np.broadcast_to(it[:, None, :], Ke.shape).ravel()
    data = Ke.ravel()
    keep = (rows >= 0) & (cols >= 0)
    if not keep.all():
        rows, cols, data = rows[keep], cols[keep], data[keep]
    return sp.coo_matrix((data, (rows, cols)), shape=(n, n)).tocsr()


def stiffness(mesh: Mesh, anisotropy: Conductivity | None) -> sp.csr_matrix:
    """The N×N P1 stiffness matrix for Q (Neumann: all vertices), Q at each triangle's centroid."""
    checks.mesh(mesh)
    _check(anisotropy, mesh, allow_none=True)
    n = mesh.n_vertices
    return _assemble(mesh, anisotropy, np.arange(n), n)


def free_vertices(mesh: Mesh) -> NDArray[np.int64]:
    """Indices of the Dirichlet unknowns: vertices of some triangle that are not on the boundary."""
    checks.mesh(mesh)
    used = np.zeros(mesh.n_vertices, bool)
    used[mesh.triangles.ravel()] = True
    return np.flatnonzero(used & ~mesh.boundary)


def stiffness_interior(mesh: Mesh, anisotropy: Conductivity | None) -> sp.csr_matrix:
    """The stiffness matrix restricted to `free_vertices(mesh)`, in that order (homogeneous Dirichlet)."""
    _check(anisotropy, mesh, allow_none=True)
    idx = free_vertices(mesh)
    index = np.full(mesh.n_vertices, -1, dtype=np.int64)
    index[idx] = np.arange(len(idx))
    return _assemble(mesh, anisotropy, index, len(idx))


def edge_weights(mesh: Mesh, anisotropy: Conductivity | None
                 ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.bool_]]:
    """Every edge (k, 2) (i < j), its weight q_ij = −K_ij (k,), and whether it is interior (k,).

    For constant Q, q_ij = (√det Q / 2)(cot θ'_k + cot θ'_l) (MATH.md, Glickenstein 2007).
    Summed per edge from the element matrices, so no sparse look-up is needed; on a boundary
    edge (one triangle) q_ij is the off-diagonal entry of that triangle's element matrix.
    """
    checks.mesh(mesh)
    _check(anisotropy, mesh, allow_none=True)
    T = mesh.triangles
    # −K_T[a, b] for the three corner pairs only, CHUNK triangles at a time (the (M, 3, 3)
    # element matrices of a whole mesh would be the largest array of `qmesh mesh`'s summary at 1e6)
    q_part: NDArray[np.float64] = np.empty((len(_EDGE_CORNERS), len(T)))
    regions = mesh.region_tags
    zero = 0                                                   # counted over all blocks
    for c in chunks(len(T)):
        K, z = _element_entries(mesh.points, T[c], anisotropy,
                                None if regions is None else regions[c], *_EDGE_PAIRS)
        q_part[:, c], zero = -K.T, zero + z
    _refuse_zero_areas(zero)
    q_part = q_part.ravel()
    pairs = _edge_pairs(T, mesh.n_vertices)
    # summed per (i, j) by a sparse matrix (a counting sort), in the order of sorted (i, j)
    edges, (q, count) = _sum_per_edge(pairs, mesh.n_vertices, q_part, np.ones(len(q_part), np.int8))
    return edges, q, count == 2                                       # q_ij = −K_ij (2.67)


def _edge_pairs(T: NDArray[np.int64], n: int) -> NDArray[np.signedinteger]:
    """(3M, 2) sorted vertex pairs of every triangle's edges, corner pair by corner pair
    (_EDGE_CORNERS); int32 where the indices fit (half the memory at 1e6 vertices)."""
    T = T.astype(np.int32) if n < 2**31 - 1 else T
    a, b = T[:, _EDGE_PAIRS[0]].T, T[:, _EDGE_PAIRS[1]].T                # (3, M) each
    # the smaller and the larger end, not a sort along rows: a third of the time at 1e6
    return np.stack([np.minimum(a, b).ravel(), np.maximum(a, b).ravel()], axis=1)


def _sum_per_edge(pairs: NDArray[np.signedinteger], n: int,
                  *values: NDArray[Any]) -> tuple[NDArray[np.int64], list[NDArray[Any]]]:
    """The distinct rows (i, j) of `pairs`, sorted, and each of `values` summed over them."""
    shape = (n, n)
    sums = [sp.csr_matrix((v, (pairs[:, 0], pairs[:, 1])), shape=shape) for v in values]
    first = sums[0]
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(first.indptr))
    return np.stack([rows, first.indices.astype(np.int64)], axis=1), [m.data for m in sums]


def interface_edges(mesh: Mesh) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Every edge (k, 2) (i < j, as `edge_weights`) and whether its two triangles lie in
    different regions (an interface edge)."""
    T = mesh.triangles
    pairs = _edge_pairs(T, mesh.n_vertices)
    rank = np.unique(mesh.region_tags, return_inverse=True)[1].ravel().astype(float)   # 0, 1, …
    r = np.tile(rank, 3)
    # two triangles' regions a, b differ iff 2(a² + b²) > (a + b)² (exact: small integers)
    edges, (count, total, squares) = _sum_per_edge(pairs, mesh.n_vertices, np.ones(len(r)), r, r * r)
    return edges, (count == 2) & (2.0 * squares > total * total)


def _relative_q(mesh: Mesh, anisotropy: Conductivity | None,
                split: bool = False) -> tuple[NDArray[np.float64], ...]:
    """Interior and boundary q_ij, each divided by max |q| over all edges; with `split`, the
    interior ones apart from the interface ones: (interior, boundary, interface)."""
    _, q, interior = edge_weights(mesh, anisotropy)
    scale = np.abs(q).max() if len(q) else 1.0
    r = q / (scale if scale > 0 else 1.0)
    if not split:
        return r[interior], r[~interior]
    tags = mesh.region_tags
    inter = (interface_edges(mesh)[1] if len(tags) and tags.min() != tags.max()
             else np.zeros(len(q), bool))                      # one region: no interface
    return r[interior & ~inter], r[~interior], r[interior & inter]


def q_nonnegative_fractions(mesh: Mesh, anisotropy: Conductivity | None,
                            rtol: float = 1e-9) -> dict[str, float | None]:
    """The shares of q_ij ≥ −rtol·max|q| as `report` gives them, from one assembly:
    "q_nonnegative_fraction" (interior edges; None also with no interior vertex: no Dirichlet
    matrix), "q_nonnegative_fraction_boundary", and "q_nonnegative_fraction_interface" when
    the mesh has interface edges or `anisotropy` is a mapping."""
    rtol = checks.real(rtol, "rtol", low=0.0, high=1.0)
    return _shares(_relative_q(mesh, anisotropy, split=True), len(free_vertices(mesh)) > 0,
                   isinstance(anisotropy, Mapping), rtol)


def _shares(relative: tuple[NDArray[np.float64], ...], has_interior: bool, per_region: bool,
            rtol: float) -> dict[str, float | None]:
    r_in, r_b, r_if = relative
    out = {"q_nonnegative_fraction": _fraction_nonnegative(r_in, rtol) if has_interior else None,
           "q_nonnegative_fraction_boundary": _fraction_nonnegative(r_b, rtol)}
    if len(r_if) or per_region:
        out["q_nonnegative_fraction_interface"] = _fraction_nonnegative(r_if, rtol)
    return out


def q_nonnegative_fraction(mesh: Mesh, anisotropy: Conductivity | None, rtol: float = 1e-9) -> float | None:
    """Fraction of interior edges with q_ij ≥ −rtol·max|q| (None when there is no interior edge).

    ≥ 0 on every interior edge makes the Dirichlet stiffness matrix an M-matrix.
    """
    rtol = checks.real(rtol, "rtol", low=0.0, high=1.0)
    return _fraction_nonnegative(_relative_q(mesh, anisotropy, split=True)[0], rtol)


def q_nonnegative_fraction_interface(mesh: Mesh, anisotropy: Conductivity | None,
                                     rtol: float = 1e-9) -> float | None:
    """Fraction of interface edges (two triangles of different regions, each with its own Q)
    with q_ij ≥ −rtol·max|q| (None when there is none). MEDIA.md §2."""
    rtol = checks.real(rtol, "rtol", low=0.0, high=1.0)
    return _fraction_nonnegative(_relative_q(mesh, anisotropy, split=True)[2], rtol)


def q_nonnegative_fraction_boundary(mesh: Mesh, anisotropy: Conductivity | None,
                                    rtol: float = 1e-9) -> float | None:
    """Fraction of boundary edges with q_ij ≥ −rtol·max|q| (None when there is no boundary edge).

    A boundary edge's q_ij is the off-diagonal of its one triangle's element matrix; ≥ 0 there
    as well as inside makes the Neumann stiffness matrix an M-matrix too.
    """
    rtol = checks.real(rtol, "rtol", low=0.0, high=1.0)
    return _fraction_nonnegative(_relative_q(mesh, anisotropy)[1], rtol)


def _fraction_nonnegative(r: NDArray[np.float64], rtol: float) -> float | None:
    return float(np.mean(r >= -rtol)) if len(r) else None


# --------------------------------------------------------------------------- conditioning

def condition_number(mesh: Mesh, anisotropy: Conductivity | None = None, *,
                     method: Literal["auto", "dense", "sparse"] = "auto", tol: float = 1e-10) -> float:
    """κ2 = λ_max / λ_min of the Dirichlet-reduced stiffness matrix (MATH.md "conditioning").

    `anisotropy=None` is the Laplacian (Q = I). `method`: "dense" (eigvalsh), "sparse"
    (eigsh for λ_max; λ_min as 1 / the largest eigenvalue of K⁻¹ applied by a sparse LU),
    or "auto" (dense up to DENSE_LIMIT unknowns). `tol` is eigsh's relative tolerance.
    """
    checks.mesh(mesh)
    _check(anisotropy, mesh, allow_none=True)
    checks.choice(method, "method", ("auto", "dense", "sparse"))
    tol = checks.real(tol, "tol", low=0.0, high=1.0, high_open=True)
    K = stiffness_interior(mesh, anisotropy)
    n = K.shape[0]
    if n == 0:
        raise QmeshError("the mesh has no interior vertex; κ2 of the Dirichlet matrix is undefined")
    if method == "dense" or n < 3 or (method == "auto" and n <= DENSE_LIMIT):
        w = scipy.linalg.eigvalsh(K.toarray())
        return float(w[-1] / w[0])
    v0 = np.random.default_rng(0).random(n)                   # fixed start: same mesh ⇒ same κ2
    lmax = spla.eigsh(K, k=1, which="LA", tol=tol, v0=v0, return_eigenvectors=False)[0]
    lu = spla.splu(K.tocsc())        # COLAMD: MMD_AT_PLUS_A fills less but orders far slower
    K_inv = spla.LinearOperator((n, n), matvec=lu.solve, dtype=float)
    mu = spla.eigsh(K_inv, k=1, which="LA", tol=tol, v0=v0, return_eigenvectors=False)[0]
    return float(lmax * mu)


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


def interpolation_errors(mesh: Mesh, anisotropy: Conductivity) -> tuple[float, float]:
    """(‖s_h − s‖_L2 (2.96), |s_h − s|_h1 = ‖∇s_h − ∇s‖_L2 (2.97)), exact for quadratic s.

    Both integrands are integrated with the degree-4 Dunavant rule: (s_h − s)² has degree 4 and
    |∇s_h − ∇s|² degree 2 when s is quadratic.
    """
    checks.mesh(mesh)
    l2 = h1 = 0.0
    for sel, A in _by_region(mesh, anisotropy):
        a, b = _interpolation_errors2(mesh.points, mesh.triangles[sel], A)
        l2, h1 = l2 + a, h1 + b
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

def report(mesh: Mesh, anisotropy: Conductivity) -> Report:
    """All measurements of one mesh as plain Python numbers (JSON-serialisable).

    Entries that need a stiffness matrix or ∇s_h are None when the mesh has a zero-area
    triangle; κ2 is None when there is no interior vertex; a share of q_ij ≥ 0 is None when
    there is no edge of its kind (interior, boundary), and the interior share also when there
    is no interior vertex (no Dirichlet matrix whose signs would matter).

    `anisotropy` may be a mapping {region tag: Anisotropy}: every triangle then uses its own
    region's Q. When the mesh has interface edges (or a mapping is given), the interior share
    counts edges inside one region, and `q_nonnegative_fraction_interface` /
    `min_q_ij_relative_interface` the interface edges (MEDIA.md §4).
    """
    checks.mesh(mesh)
    _check(anisotropy, mesh)
    P, T = mesh.points, mesh.triangles
    area = signed_areas(P, T)
    qual = quality(mesh, anisotropy)
    n_interior = int(len(free_vertices(mesh)))
    out: Report = {
        "n_vertices": int(mesh.n_vertices),
        "n_triangles": int(mesh.n_triangles),
        "n_boundary": int(mesh.boundary.sum()),
        "n_interior": n_interior,
        "inverted_triangles": int(np.sum(area <= 0.0)),
        "energy": energy(mesh, anisotropy),
        "min_quality": float(qual.min()) if len(qual) else None,
        "mean_quality": float(qual.mean()) if len(qual) else None,
        "l2_error": None, "h1_error": None, "kappa2": None, "kappa2_laplacian": None,
        "q_nonnegative_fraction": None, "q_nonnegative_fraction_boundary": None,
        "min_q_ij_relative": None, "min_q_ij_relative_boundary": None,
    }
    if len(T) == 0 or np.any(area == 0.0):
        return out
    out["l2_error"], out["h1_error"] = interpolation_errors(mesh, anisotropy)
    r_in, r_b, r_if = relative = _relative_q(mesh, anisotropy, split=True)
    out.update(_shares(relative, n_interior > 0, isinstance(anisotropy, Mapping), 1e-9))
    if len(r_if) or isinstance(anisotropy, Mapping):
        out["min_q_ij_relative_interface"] = float(r_if.min()) if len(r_if) else None
    out["min_q_ij_relative"] = float(r_in.min()) if len(r_in) else None
    out["min_q_ij_relative_boundary"] = float(r_b.min()) if len(r_b) else None
    if n_interior > 0:
        out["kappa2"] = condition_number(mesh, anisotropy)
        out["kappa2_laplacian"] = condition_number(mesh, None)
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
