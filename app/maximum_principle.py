"""The discrete maximum principle on the mesh on screen, and on an isotropic mesh of the same N.

Why: a mesh whose every q_ij ≥ 0 gives an M-matrix, so the P1 solution of −div(Q∇u) = 0 stays
within its boundary values; an ordinary isotropic mesh of the same size does not, for an
anisotropic Q. Both are solved here with steep Dirichlet data (`dirichlet_data`: u = 1 on the
boundary vertices left of the centre of the mesh's x-range, 0 on the others, a jump) by
`qmesh.compare.solve.dirichlet`, and the vertices whose u_h leaves [0, 1] by more than
`TOLERANCE` are counted.

The conductivity is the one the mesh is measured with: a field's element means (the certified
ones the mesh carries), a constant or varying `Anisotropy`, or a medium's Q per region. The
isotropic mesh (`isotropic_mesh`) keeps the mesh's boundary vertices and fills the inside with
a jittered triangular lattice, triangulated by scipy's Delaunay; for a medium each of its
triangles takes the region of the nearest triangle of the mesh (it does not follow the
interfaces). No UI here: the scene builder draws a `Comparison`, the front ends only ask for it.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np
from scipy.spatial import Delaunay, cKDTree

from qmesh.compare.solve import dirichlet
from qmesh.errors import QmeshError
from qmesh.geometry import rings
from qmesh.geometry.triangles import signed_areas
from qmesh.triangle_mesh import Mesh

from .problem import element_means, is_field_conductivity

TOLERANCE = 1e-9
"""A vertex counts as outside [0, 1] when u_h < −TOLERANCE or u_h > 1 + TOLERANCE (the direct
solve's round-off is about 1e-14 here)."""
JITTER = 0.1
"""The lattice points move by up to this share of the spacing (breaks the lattice's ties)."""
LATTICE_SEED = 0


@dataclass(frozen=True)
class Solution:
    """u_h on `mesh` and the vertices (`outside`, indices) whose value lies outside [0, 1]."""

    mesh: Mesh
    u: np.ndarray
    outside: np.ndarray

    @property
    def n_outside(self) -> int:
        return int(len(self.outside))

    @property
    def n_below(self) -> int:
        return int(np.sum(self.u[self.outside] < 0.0))

    @property
    def n_above(self) -> int:
        return int(np.sum(self.u[self.outside] > 1.0))


@dataclass(frozen=True)
class Comparison:
    """The mesh's solution, the isotropic mesh's, and where u = 1 was imposed (x < `centre`)."""

    mesh: Solution
    isotropic: Solution
    centre: float


def dirichlet_data(mesh: Mesh, centre: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(boundary vertex indices, values): 1 where x < `centre` (default: the middle of the
    mesh's x-range), else 0."""
    fixed = np.flatnonzero(mesh.boundary)
    if centre is None:
        centre = middle(mesh)
    return fixed, (mesh.points[fixed, 0] < centre).astype(float)


def middle(mesh: Mesh) -> float:
    """The middle of the mesh's x-range."""
    x = mesh.points[:, 0]
    return 0.5 * (float(x.min()) + float(x.max()))


def conductivity_on(mesh: Mesh, anisotropy):
    """What `mesh` is solved with: a field's element means (`problem.element_means`), else the
    conductivity itself (an Anisotropy, or `{region tag: Anisotropy}` by `mesh.region_tags`)."""
    return element_means(mesh, anisotropy) if is_field_conductivity(anisotropy) else anisotropy


def solve(mesh: Mesh, anisotropy, centre: float | None = None,
          tolerance: float = TOLERANCE) -> Solution:
    """The P1 solution of −div(Q∇u) = 0 with `dirichlet_data` and its vertices outside [0, 1]."""
    tolerance = float(tolerance)
    if not (np.isfinite(tolerance) and 0.0 <= tolerance < 1.0):
        raise QmeshError(f"tolerance must be finite, ≥ 0 and < 1, got {tolerance}")
    if mesh.n_triangles == 0:
        raise QmeshError("mesh has no triangle to solve on")
    fixed, values = dirichlet_data(mesh, centre)
    u = dirichlet(mesh, conductivity_on(mesh, anisotropy), fixed, values)
    return Solution(mesh, u, np.flatnonzero((u < -tolerance) | (u > 1.0 + tolerance)))


def isotropic_mesh(mesh: Mesh, seed: int = LATTICE_SEED) -> Mesh:
    """A mesh of the same N with no direction preferred: `mesh`'s boundary vertices and edges,
    and inside a triangular lattice (spacing shrunk until it holds the N − boundary points
    needed, then that many taken evenly; the lattice jittered by `JITTER`; no point nearer the
    boundary than half a spacing), scipy's Delaunay triangles whose centroids lie inside.
    A medium's triangles take the region of `mesh`'s nearest triangle."""
    P, E = mesh.points, mesh.boundary_edges
    if len(E) == 0 or mesh.n_triangles == 0:
        raise QmeshError("mesh has no boundary to build an isotropic mesh in")
    A, B = P[E[:, 0]], P[E[:, 1]]
    used = np.unique(E)
    n_inside = mesh.n_vertices - len(used)
    area = float(np.abs(signed_areas(P, mesh.triangles)).sum())
    G = _lattice(A, B, P[used], n_inside, area, np.random.default_rng(seed))
    X = np.concatenate([P[used], G])
    T = Delaunay(X).simplices
    T = T[rings.inside(X[T].mean(axis=1), A, B)]
    flip = signed_areas(X, T) < 0
    T[flip] = T[flip][:, ::-1]
    keep, T = np.unique(T, return_inverse=True)            # drop a point no triangle kept
    X, T = X[keep], T.reshape(-1, 3)
    tags = np.asarray(mesh.region_tags)
    if len(tags) and tags.min() != tags.max():
        centroids = P[mesh.triangles].mean(axis=1)
        _, nearest = cKDTree(centroids).query(X[T].mean(axis=1))
        return Mesh(X, T, region_tags=tags[nearest], region_names=mesh.region_names)
    return Mesh(X, T)


def _lattice(A: np.ndarray, B: np.ndarray, boundary: np.ndarray, count: int, area: float,
             rng: np.random.Generator) -> np.ndarray:
    """`count` points of a jittered triangular lattice inside the rings A→B, at least half a
    spacing from them."""
    if count <= 0:
        return np.zeros((0, 2))
    lo, hi = boundary.min(axis=0), boundary.max(axis=0)
    h = np.sqrt(2.0 * area / (np.sqrt(3.0) * count))      # a triangular lattice's spacing
    for _ in range(60):
        rows = np.arange(lo[1] + h / 2, hi[1], h * np.sqrt(3.0) / 2)
        cols = np.arange(lo[0] + h / 4, hi[0], h)
        X, Y = np.meshgrid(cols, rows)
        X = X + (np.arange(len(rows))[:, None] % 2) * (h / 2)
        G = np.column_stack([X.ravel(), Y.ravel()])
        G = G + rng.uniform(-JITTER, JITTER, G.shape) * h
        G = G[rings.inside(G, A, B)]
        G = G[~np.isfinite(rings.distance(G, A, B, 0.5 * h))]
        if len(G) >= count:
            return G[np.linspace(0, len(G) - 1, count).round().astype(np.int64)]
        h *= 0.97
    raise QmeshError(f"no lattice of {count} points fits inside the mesh's boundary")


def compare(mesh: Mesh, anisotropy, tolerance: float = TOLERANCE) -> Comparison:
    """The maximum principle on `mesh` and on `isotropic_mesh(mesh)`, with the same data."""
    centre = middle(mesh)
    own = solve(mesh, anisotropy, centre, tolerance)
    iso = isotropic_mesh(mesh)
    return Comparison(own, solve(iso, anisotropy, centre, tolerance), centre)


_KEPT: dict = {}
_LOCK = threading.Lock()      # the app builds scenes in a worker thread


def cached(mesh: Mesh, anisotropy) -> Comparison:
    """`compare(mesh, anisotropy)`, kept for the last few meshes: a redraw of the same stage
    (another edge mode, the isotropic mesh shown) solves nothing again."""
    key = (id(mesh), id(anisotropy))
    with _LOCK:
        hit = _KEPT.get(key)
    if hit is None or hit[0] is not mesh or hit[1] is not anisotropy:
        hit = (mesh, anisotropy, compare(mesh, anisotropy))
        with _LOCK:
            while len(_KEPT) >= 4:
                _KEPT.pop(next(iter(_KEPT)))
            _KEPT[key] = hit
    return hit[2]
