"""Say when a finished mesh cannot serve its request well: a domain thinner than two elements,
or a target that the boundary's points use up.

The mesher always returns a valid mesh, but when the domain, measured in the metric ∇²s, is
thinner than about two elements of the requested size, that mesh has no interior vertex (the
Dirichlet matrix is empty, κ2 undefined) or only slivers across the middle. `thin_domain`
detects this from the mesh alone and returns a message with the vertex count that would put
two elements across; `mesher.mesh` warns with it (`QmeshWarning`), the CLI prints it.
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import ConvexHull, QhullError

from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.errors import QmeshWarning
from qmesh.geometry.portable import cholesky2, times2
from qmesh.geometry.rings import convex_width
from qmesh.geometry.triangles import (extent, metric_areas, metric_hessians, metric_quality,
                                      worst_metric_quality)
from qmesh.mesher.sizing import equilateral_area, vertices_from_counts

if TYPE_CHECKING:
    from qmesh.triangle_mesh import Mesh

ROWS = 2.0               # elements across the domain that a usable mesh needs
ROW_HEIGHT = np.sqrt(3.0) / 2.0   # height of an equilateral triangle of metric edge length 1
SLIVER = 0.1             # metric quality (2.94) below which a triangle is a sliver


def element_size(metric_area: float, n_triangles: int) -> float:
    """Metric edge length h of the equilateral triangle of the mean metric area: M·(√3/4)h² = area."""
    return float(np.sqrt(metric_area / (equilateral_area(1.0) * max(n_triangles, 1))))


def metric_width(points: NDArray[np.float64], H: NDArray[np.float64], metric_area: float,
                 metric_perimeter: float, holes: int = 0) -> float:
    """An estimate of the domain's width in the metric H: the smaller of the minimum width of
    the convex hull of the mapped points (exact for convex domains) and, for what the hull does
    not see, 4·area/perimeter without holes (the diameter of a disk, twice the width of a long
    arm) or 2·area/perimeter with holes (the width R − r of an annulus)."""
    L = cholesky2(H)                               # H = L Lᵀ, metric length |Lᵀ d|
    X = times2(points, L)
    factor = 2.0 if holes else 4.0
    by_area = factor * metric_area / metric_perimeter if metric_perimeter > 0 else np.inf
    try:
        V = X[ConvexHull(X).vertices]
    except (QhullError, ValueError):
        return 0.0                                  # all points on a line: no width at all
    return float(min(convex_width(V), by_area))


def vertices_for(metric_area: float, metric_perimeter: float, h: float) -> int:
    """Vertex count of a mesh of metric size h: M = 2N − N_b − 2 with N_b ≈ perimeter / h."""
    return int(np.ceil(vertices_from_counts(metric_area, h, metric_perimeter / h)))


def thin_face(mesh: Mesh, anisotropy: Anisotropy, k: float = 1.0) -> str | None:
    """`thin_domain` in the shape of a constant Q (Q / k: a Q of 1e300 would overflow the
    areas), and None at once for a mesh with an interior vertex and no sliver, of which it has
    nothing to say (its hull would be the cost, for each of a thousand small faces)."""
    if (~mesh.boundary).any() and worst_metric_quality(mesh.points, mesh.triangles, anisotropy) >= SLIVER:
        return None
    return thin_domain(mesh, Anisotropy.constant(anisotropy.matrix / k) if anisotropy.is_constant else anisotropy,
                       region=True)


def thin_faces(meshes: list[Mesh], anisotropy: Anisotropy, k: float = 1.0) -> list[str | None]:
    """`thin_face` of each of meshes of one constant Q, its quick test taken on all at once (a
    call per face of a thousand cost more than the test)."""
    if len(meshes) == 1 or not anisotropy.is_constant:
        return [thin_face(m, anisotropy, k) for m in meshes]
    nv, nt = np.array([m.n_vertices for m in meshes]), np.array([m.n_triangles for m in meshes])
    off = np.cumsum(nv) - nv
    P = np.concatenate([m.points for m in meshes])
    T = np.concatenate([m.triangles + o for m, o in zip(meshes, off)])
    b = np.unique(np.concatenate([m.boundary_edges.ravel() + o for m, o in zip(meshes, off)]))
    inner = nv > np.bincount(np.searchsorted(off, b, side="right") - 1, minlength=len(meshes))
    worst = np.full(len(meshes), -np.inf)
    has = nt > 0
    worst[has] = np.minimum.reduceat(metric_quality(P, T, metric_hessians(anisotropy, P, T)),
                                     (np.cumsum(nt) - nt)[has])
    return [None if ok else thin_face(m, anisotropy, k) for m, ok in zip(meshes, inner & (worst >= SLIVER))]


def thin_domain(mesh: Mesh, anisotropy: Anisotropy, region: bool = False) -> str | None:
    """A message when the domain is too thin for the mesh's size, else None. `region`: the mesh
    is one region's of a medium, whose count is its share of target_vertices (the message then
    says what the region would need, not what to ask for)."""
    X, T = mesh.points, mesh.triangles
    if len(T) == 0:
        return None
    what, share = ("region", "its whole share of the target") if region else ("domain", "the whole target")
    more = "a larger target_vertices / --target-vertices (or a smaller size) gives it more"
    Hs = metric_hessians(anisotropy, X, T)
    # lengths in units of the mesh's extent (a domain 1e300 across overflows its areas);
    # every test below compares ratios, and sizes are reported back in the user's units
    lo, hi = extent(X)
    unit = float((hi - lo).max()) or 1.0
    P = (X - (0.5 * lo + 0.5 * hi)) / unit
    areas = metric_areas(P, T, Hs)
    area_m = float(areas.sum())
    E = mesh.boundary_edges
    d = P[E[:, 1]] - P[E[:, 0]]
    if anisotropy.is_constant:
        H = np.asarray(anisotropy.H, float)
        perimeter = float(np.sqrt(np.einsum("ni,ij,nj->n", d, H, d)).sum())
    else:
        H = np.einsum("m,mij->ij", np.abs(areas), Hs) / max(np.abs(areas).sum(), 1e-300)
        He = np.asarray(anisotropy.hessian(0.5 * (X[E[:, 0]] + X[E[:, 1]])), float)
        perimeter = float(np.sqrt(np.einsum("ni,nij,nj->n", d, He, d)).sum())
    h = element_size(area_m, len(T))
    edges = (3 * len(T) + len(E)) // 2
    holes = max(0, 1 - (mesh.n_vertices - edges + len(T)))    # Euler: V − E + T = 1 − holes
    width = metric_width(P[mesh.boundary], H, area_m, perimeter, holes)
    n_interior = int((~mesh.boundary).sum())
    thin = width < ROWS * ROW_HEIGHT * h
    # the quality pass is half this function's time at 1e6 vertices: only for a thin domain
    min_q = float(metric_quality(P, T, Hs).min()) if thin and n_interior else None
    if not (n_interior == 0 or (thin and min_q is not None and min_q < SLIVER)):
        return None
    if not thin:
        # wide enough, yet every vertex is on the boundary: the input points (and the boundary's
        # splits) took the whole target; the N whose interior matches the boundary's spacing
        n_b = int(mesh.boundary.sum())
        need: int | None = max(vertices_for(area_m, perimeter, perimeter / max(n_b, 1)), mesh.n_vertices + 1)
        ask = (f"the region would need about {need} vertices to fill its interior at the "
               f"boundary's spacing; {more}"
               if region else
               f"about {need} vertices (target_vertices / --target-vertices) would fill the interior "
               "at the boundary's spacing")
        return (f"every one of the N = {mesh.n_vertices} vertices lies on the boundary (no interior "
                f"vertex), although the {what} is {width / (ROW_HEIGHT * h):.2g} elements wide in "
                f"the metric: the boundary's points take {share}; {ask}")
    symptom = ("no interior vertex" if n_interior == 0
               else f"{n_interior} interior vertices, minimum metric quality {min_q:.3f}")
    h_need = width / (ROWS * ROW_HEIGHT)
    # the count at that size, and at least the mesh's own N scaled by the missing width (tiny
    # meshes are mostly boundary, which the area formula undercounts)
    ratio = width / (ROWS * ROW_HEIGHT * h)
    need = (max(vertices_for(area_m, perimeter, h_need), int(mesh.n_vertices / min(ratio, 1.0)) + 1)
            if h_need > 0 else None)
    if not need:
        advice = "its metric width is zero"
    elif region:
        advice = f"the region would need about {need} vertices to put {ROWS:g} elements across it; {more}"
    else:
        advice = (f"about {need} vertices (target_vertices / --target-vertices, or a metric size "
                  f"of {h_need * unit:.3g}) would put {ROWS:g} elements across it")
    return (f"the {what} is {width / (ROW_HEIGHT * h):.2g} elements wide in the metric at this "
            f"size (N = {mesh.n_vertices}, {symptom}); {advice}")


def warn_if_thin(mesh: Mesh, anisotropy: Anisotropy, stacklevel: int = 3) -> None:
    """warnings.warn(thin_domain(...), QmeshWarning) when there is something to say."""
    message = thin_domain(mesh, anisotropy)
    if message is not None:
        warnings.warn(message, QmeshWarning, stacklevel=stacklevel)
