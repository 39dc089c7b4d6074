"""The three views of one mesher `Step` as PyVista meshes: lifted, projected, quality.

Pure functions, no plotter, no server, no widgets, so they run off-screen in tests and are shared
by the trame app and the Jupyter widget (ARCHITECTURE.md "qmesh_view.scene").

- `lifted`: the chapter's picture of the Q-Delaunay connectivity (Section 2.3.1, (2.74)–(2.75)):
  the smooth convex s(x) over the domain Ω (holes left open), the vertices lifted onto it, and the facets of the
  piecewise-linear interpolant s_h (one facet per mesh triangle; after a triangulate stage they
  are the lower convex hull of the lifted vertices).
- `projected`: the mesh in the plane, the fixed seed vertices, the points the last insert stage
  added and the displacements of the last adjust stage ((2.90)–(2.91)).
- `quality`: triangles coloured by the metric quality (2.94) or the metric area, and optionally
  every edge coloured by the sign of q_ij = −K_ij (Glickenstein 2007).
- `solution`: the quality view's other content, the discrete maximum principle: u_h of
  −div(Q∇u) = 0 with steep Dirichlet data on the Step's mesh or on an isotropic mesh of the same
  N (`qmesh_view.maximum_principle`), its vertices outside [0, 1] marked.

A medium (a `{region tag: Anisotropy}` mapping) has one s per region, not one surface: the
lifted view then shows each region's own piece (its triangles lifted onto its s_r less its
least-squares plane, normalised per region, no smooth surface); the projected mesh is coloured by region; the quality view
uses each triangle's own metric and marks the interface edges (two triangles, two regions).

A conductivity field (`qmesh.TensorField`, a formula or a raster of Q(x)) has no s, so no surface
to lift: the first view then shows Q itself as ellipses over the domain (`ellipses`: one per cell
of a coarse grid, axes along Q's eigenvectors, semi-axes ∝ √eigenvalues) with the mesh, and the
quality view and the q_ij signs use each triangle's own element mean Q̄_T (the means the last
Step's mesh carries and was certified with, or for a stage before it the field's own means on
that mesh: `problem.element_means`).

Every array operation is vectorised over vertices, triangles or edges (and looped only over the
few regions of a medium).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pyvista as pv
from scipy.spatial import ConvexHull, Delaunay, cKDTree

from qmesh import measure
from qmesh.conductivity.anisotropy import shape_metric
from qmesh.errors import QmeshError
from qmesh.geometry.rings import inside
from qmesh.geometry.triangles import metric_areas, metric_hessians, metric_quality

from . import maximum_principle
from .problem import element_means, is_field_conductivity as is_field

COLOUR_BY = ("quality", "metric_area")
"""What the quality view can colour triangles by."""

REGION_COLOURS = ("#8dd3c7", "#fdb462", "#bebada", "#fb8072", "#80b1d3", "#b3de69", "#fccde5",
                  "#ffffb3", "#bc80bd", "#d9d9d9")
"""The mesh view's colour of region k (matplotlib's Set3, reordered), k modulo 10."""

SURFACE_RESOLUTION = 41
"""Grid points across the domain's bounding box used to sample the smooth s(x)."""


# --------------------------------------------------------------------------- helpers

def _faces(T: np.ndarray) -> np.ndarray:
    """VTK's flat face array [3, a, b, c, 3, …] for triangles (M, 3)."""
    return np.column_stack([np.full(len(T), 3, dtype=np.int64), T]).ravel()


def _lines(E: np.ndarray) -> np.ndarray:
    """VTK's flat line array [2, a, b, …] for segments (k, 2)."""
    return np.column_stack([np.full(len(E), 2, dtype=np.int64), E]).ravel()


def _xyz(P: np.ndarray, z: np.ndarray | float = 0.0) -> np.ndarray:
    out = np.zeros((len(P), 3))
    out[:, :2] = P
    out[:, 2] = z
    return out


def triangles_polydata(P: np.ndarray, T: np.ndarray, z: np.ndarray | float = 0.0) -> pv.PolyData:
    """Triangles (M, 3) on points P (N, 2) at heights z as a PolyData (VTK's cell array built
    from the connectivity directly, not parsed from the legacy [3, a, b, c, …] form)."""
    if len(T) == 0:
        return pv.PolyData(_xyz(P, z))
    return pv.PolyData.from_regular_faces(_xyz(P, z), np.ascontiguousarray(T))


def points_polydata(P: np.ndarray, z: np.ndarray | float = 0.0) -> pv.PolyData:
    """Points (n, 2) at heights z as a vertex-only PolyData (empty arrays give an empty PolyData)."""
    if len(P) == 0:
        return pv.PolyData()
    return pv.PolyData(_xyz(P, z))


def segments_polydata(A: np.ndarray, B: np.ndarray, z: float = 0.0) -> pv.PolyData:
    """Line segments A[k] → B[k] as a PolyData of lines."""
    if len(A) == 0:
        return pv.PolyData()
    k = len(A)
    pts = _xyz(np.concatenate([A, B]), z)
    E = np.column_stack([np.arange(k), np.arange(k, 2 * k)])
    return pv.PolyData(pts, lines=_lines(E))


def arrows_polydata(start: np.ndarray, vec: np.ndarray, head: float = 0.3,
                    z: float = 0.0) -> pv.PolyData:
    """Flat 2-D arrows start → start + vec (shaft plus two head strokes), all as line cells.

    Cheap at 1e4 vertices (four points and three lines per arrow), unlike 3-D arrow glyphs.
    """
    if len(start) == 0:
        return pv.PolyData()
    tip = start + vec
    back = -head * vec
    side = head * 0.5 * np.column_stack([-vec[:, 1], vec[:, 0]])
    k = len(start)
    pts = _xyz(np.concatenate([start, tip, tip + back + side, tip + back - side]), z)
    i = np.arange(k)
    E = np.concatenate([np.column_stack([i, i + k]),
                        np.column_stack([i + k, i + 2 * k]),
                        np.column_stack([i + k, i + 3 * k])])
    poly = pv.PolyData(pts, lines=_lines(E))
    poly.cell_data["length"] = np.tile(np.hypot(vec[:, 0], vec[:, 1]), 3)
    return poly


def domain_rings(step, domain=None) -> tuple[np.ndarray, ...]:
    """The boundary rings of Ω, (k, 2) each: the domain's (outline counter-clockwise, holes
    clockwise), or without a domain the convex hull of the mesh's points."""
    if domain is not None:
        return tuple(np.asarray(r, dtype=float) for r in domain.rings)
    P = step.mesh.points
    return (P[ConvexHull(P).vertices],)


def sample_domain(rings, resolution: int = SURFACE_RESOLUTION,
                  contains=None) -> tuple[np.ndarray, np.ndarray]:
    """A triangulation (points, triangles) filling the domain bounded by `rings`.

    Points along every ring plus the grid points inside Ω (by `contains`, a point-in-domain
    test) and clear of the boundary, Delaunay-triangulated; triangles whose centroid lies
    outside Ω are dropped, so holes stay open and re-entrant corners are not bridged. The
    smooth surface is drawn on it. Cached: the domain stays the same for a whole run.
    """
    rings = tuple(np.ascontiguousarray(r, dtype=float) for r in rings)
    key = (b"".join(r.tobytes() for r in rings), tuple(len(r) for r in rings), int(resolution))
    hit = _samples.get(key)
    if hit is None:
        hit = _sample_domain(rings, int(resolution), contains)
        if len(_samples) >= 8:
            _samples.pop(next(iter(_samples)))
        _samples[key] = hit
    return hit


_samples: dict = {}


def _inside_rings(rings, P: np.ndarray) -> np.ndarray:
    """Even-odd point-in-polygon test against all rings at once (qmesh.geometry.rings.inside)."""
    A = np.concatenate(rings)
    B = np.concatenate([np.roll(ring, -1, axis=0) for ring in rings])
    return inside(P, A, B)


def _sample_domain(rings, resolution: int, contains) -> tuple[np.ndarray, np.ndarray]:
    contains = contains or (lambda P: _inside_rings(rings, P))
    allp = np.concatenate(rings)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    h = (hi - lo).max() / (resolution - 1)
    boundary = []
    for ring in rings:
        nxt = np.roll(ring, -1, axis=0)
        counts = np.maximum(1, np.ceil(np.hypot(*(nxt - ring).T) / h).astype(int))
        seg = np.repeat(np.arange(len(ring)), counts)
        starts = np.repeat(np.cumsum(counts) - counts, counts)
        t = (np.arange(counts.sum()) - starts) / counts[seg]     # 0 ≤ t < 1 along each edge
        boundary.append(ring[seg] + t[:, None] * (nxt - ring)[seg])
    boundary = np.concatenate(boundary)
    gx, gy = np.meshgrid(np.arange(lo[0] + h, hi[0], h), np.arange(lo[1] + h, hi[1], h))
    G = np.column_stack([gx.ravel(), gy.ravel()])
    near, _ = cKDTree(boundary).query(G)          # boundary samples are ≤ h apart
    G = G[(near > h / 2) & np.asarray(contains(G), dtype=bool)]
    P = np.concatenate([boundary, G])
    T = Delaunay(P).simplices
    T = T[np.asarray(contains(P[T].mean(axis=1)), dtype=bool)]
    P.setflags(write=False)
    T.setflags(write=False)
    return P, T


def region_colour(tag: int) -> str:
    """The mesh view's colour of region `tag` (hex)."""
    return REGION_COLOURS[int(tag) % len(REGION_COLOURS)]


def region_rgb(tags: np.ndarray) -> np.ndarray:
    """(M, 3) uint8 colours of regions `tags`."""
    rgb = np.array([pv.Color(c).int_rgb for c in REGION_COLOURS], dtype=np.uint8)
    return rgb[np.asarray(tags) % len(REGION_COLOURS)]


def is_medium(anisotropy) -> bool:
    """True for a conductivity per region (`{tag: Anisotropy}`)."""
    return isinstance(anisotropy, Mapping)


def mean_metrics(Q: np.ndarray) -> np.ndarray:
    """H_T = adj Q̄_T / √det Q̄_T of per-triangle conductivities (M, 2, 2) (FIELDS.md §3: the
    metric in which a triangle's q_ij share is the cotangent formula); NaN where Q̄_T is not
    positive definite."""
    return shape_metric(Q)


def hessians(mesh, anisotropy) -> np.ndarray:
    """The metric H of every triangle (M, 2, 2): its region's for a medium, its own element
    mean's (`mean_metrics`) for a field."""
    P, T = mesh.points, mesh.triangles
    if is_field(anisotropy):
        return mean_metrics(element_means(mesh, anisotropy))
    if not is_medium(anisotropy):
        return metric_hessians(anisotropy, P, T)
    tags = mesh.region_tags
    missing = sorted(set(np.unique(tags).tolist()) - {int(k) for k in anisotropy})
    if missing:
        raise QmeshError(f"no conductivity for region {missing[0]} of the mesh")
    H = np.empty((len(T), 2, 2))
    for tag in np.unique(tags).tolist():
        sel = tags == tag
        H[sel] = metric_hessians(anisotropy[tag], P, T[sel])
    return H


# --------------------------------------------------------------------------- lifted view

@dataclass(frozen=True)
class LiftedScene:
    """The lifted view: smooth s(x) (translucent), lifted vertices, the facets of s_h."""

    surface: pv.PolyData      # s(x) sampled over the domain
    vertices: pv.PolyData     # (x_i, y_i, s(x_i))
    facets: pv.PolyData       # one lifted facet per mesh triangle: the piecewise-linear s_h
    z_scale: float


def height_map(s_values: np.ndarray, s_min: float, s_max: float, width: float,
               z_scale: float) -> np.ndarray:
    """Displayed height: s mapped so that z_scale = 1 spans half the domain's width.

    s is defined up to an affine function and its range varies by orders of magnitude with Q,
    so the lifted view normalises it; only the shape matters to the lower hull (MATH.md).
    """
    span = s_max - s_min
    return z_scale * 0.5 * width * (s_values - s_min) / (span if span > 0 else 1.0)


def lifted(step, anisotropy, z_scale: float = 1.0, *, domain=None,
           resolution: int = SURFACE_RESOLUTION) -> LiftedScene:
    """The lifted view of `step`: s over the domain, lifted vertices and the s_h facets.

    `z_scale` multiplies the displayed height (1 = the surface rises half the domain's width).
    """
    if not np.isfinite(z_scale) or z_scale <= 0:
        raise QmeshError(f"z_scale must be finite and > 0, got {z_scale}")
    P, T = step.mesh.points, step.mesh.triangles
    rings = domain_rings(step, domain)
    if is_medium(anisotropy):
        return _lifted_pieces(step, anisotropy, z_scale, rings)
    SP, ST = sample_domain(rings, resolution,
                           None if domain is None else lambda X: domain.contains(X))
    s_surface = np.asarray(anisotropy.s(SP), dtype=float)
    s_vertex = np.asarray(anisotropy.s(P), dtype=float)
    # the sampled surface's range alone: s(x) keeps its picture while vertices come and go
    # (the vertices, inside Ω, may lie a hair beyond it: the mapping is linear all the same)
    s_min, s_max = s_surface.min(), s_surface.max()
    width = float(np.ptp(np.concatenate(rings), axis=0).max())
    z_surface = height_map(s_surface, s_min, s_max, width, z_scale)
    z_vertex = height_map(s_vertex, s_min, s_max, width, z_scale)
    # faces oriented downwards: the lower hull is seen from below, through the translucent s
    surface = triangles_polydata(SP, ST[:, ::-1], z_surface)
    surface.point_data["s"] = s_surface
    # vertex normals: shaded smoothly, the coarse surface shows no bands where it stands
    # for facets too small to see (draw.ViewSet._fine_facets)
    surface = surface.compute_normals(cell_normals=False, split_vertices=False,
                                      consistent_normals=False)
    facets = triangles_polydata(P, T[:, ::-1], z_vertex)  # s_h: linear on every triangle
    facets.point_data["s"] = s_vertex
    return LiftedScene(surface, points_polydata(P, z_vertex), facets, float(z_scale))


def _lifted_pieces(step, anisotropy, z_scale: float, rings) -> LiftedScene:
    """A medium: every region's triangles lifted onto its own s_r relative to its own plane.

    s_r is only defined up to an affine function, and the affine parts of different regions
    tilt their pieces every which way; what matters to the lower hull is the convex rest. So
    each region shows s_r minus its least-squares plane over the region's vertices, normalised
    to its own range, starting from the plane z = 0: one bowl (or trough) per region, side by
    side over the plane, no smooth surface (there is no single one). A piece rises at most half
    its region's narrower side (times `z_scale`), not half the domain's width: a thin layer or a
    small inclusion stays a low relief over its own footprint, coloured by region, instead of a
    sheet leaning over its neighbours."""
    P, T, tags = step.mesh.points, step.mesh.triangles, step.mesh.region_tags
    points, faces, heights, region, offset = [], [], [], [], 0
    for tag in np.unique(tags).tolist():
        Tr = T[tags == tag]
        used, local = np.unique(Tr, return_inverse=True)
        X = P[used]
        s_r = np.asarray(anisotropy[tag].s(X), dtype=float)
        rest = s_r - own_plane(X, s_r)
        narrow = float(np.ptp(X, axis=0).min()) if len(X) else 0.0
        heights.append(height_map(rest, rest.min(), rest.max(), narrow, z_scale))
        points.append(X)
        faces.append(local.reshape(Tr.shape)[:, ::-1] + offset)
        region.append(np.full(len(Tr), tag))
        offset += len(used)
    X, z = np.concatenate(points), np.concatenate(heights)
    facets = triangles_polydata(X, np.concatenate(faces), z)
    facets.cell_data["region"] = np.concatenate(region)
    facets.cell_data["region_rgb"] = region_rgb(facets.cell_data["region"])
    return LiftedScene(pv.PolyData(), points_polydata(X, z), facets, float(z_scale))


def own_plane(X: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The least-squares plane a + b x + c y through the values `s` at points X (n, 2), at X."""
    if len(X) < 3 or not np.all(np.isfinite(s)):
        return np.full(len(X), float(np.nanmin(s)) if len(s) else 0.0)
    A = np.column_stack([np.ones(len(X)), X - X.mean(axis=0)])
    coef, *_ = np.linalg.lstsq(A, s, rcond=None)
    return A @ coef


# --------------------------------------------------------------------------- a field's view

GLYPH_CELLS = 12
"""Ellipses across the domain's longer side in the field view (one per grid cell inside Ω)."""
GLYPH_FILL = 0.45
"""Largest semi-axis of an ellipse as a share of its grid cell (0.5 would touch the neighbours)."""
ELLIPSE_SEGMENTS = 40


@dataclass(frozen=True)
class FieldScene:
    """The first view of a field (no s, no surface): Q(x) as ellipses over the flat mesh.

    Each ellipse sits at a grid cell's centre c inside Ω with its axes along the eigenvectors
    of Q(c) and semi-axes ∝ √eigenvalues, scaled so that its larger one is GLYPH_FILL of the
    cell (shape and direction, each ellipse on its own scale); its colour (cell array
    "log10_k_max") is log10 of Q(c)'s larger eigenvalue, the size the shape leaves out.
    """

    ellipses: pv.PolyData     # one polygon per ellipse, cell array "log10_k_max"
    outlines: pv.PolyData     # the same ellipses as closed lines (a 1000 : 1 one is all outline)
    mesh: pv.PolyData         # the Step's triangles, flat (z = 0)
    centres: np.ndarray       # (n, 2) where Q was evaluated
    tensors: np.ndarray       # (n, 2, 2) Q at the centres
    clim: tuple[float, float]  # the colour range of log10_k_max
    n_skipped: int = 0        # grid centres where the field refused to be evaluated
    uniform: float | None = None  # log10_k_max when it is one value everywhere: no colour scale


def glyph_centres(rings, cells: int = GLYPH_CELLS, contains=None) -> tuple[np.ndarray, float]:
    """Centres of the cells of a grid `cells` wide over the rings' bounding box that lie inside
    Ω (by `contains`, else the even-odd rule on the rings), and the cell size."""
    allp = np.concatenate(rings)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    h = float((hi - lo).max()) / int(cells)
    if not h > 0:
        return np.zeros((0, 2)), 1.0
    nx, ny = (max(1, int(np.ceil((hi[k] - lo[k]) / h - 1e-9))) for k in (0, 1))
    x = lo[0] + (hi[0] - lo[0] - nx * h) / 2 + h * (np.arange(nx) + 0.5)
    y = lo[1] + (hi[1] - lo[1] - ny * h) / 2 + h * (np.arange(ny) + 0.5)
    C = np.column_stack([a.ravel() for a in np.meshgrid(x, y)])
    test = contains or (lambda X: _inside_rings(rings, X))
    return C[np.asarray(test(C), dtype=bool)], h


def _field_at(field, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Q at the centres (n, 2, 2) and which centres it was evaluated at: a field refusing a
    point (QmeshError: not SPD there, outside a raster) loses that glyph, not the view."""
    try:
        return np.asarray(field(C), dtype=float), np.ones(len(C), dtype=bool)
    except QmeshError:
        pass
    ok = np.zeros(len(C), dtype=bool)
    Q = np.zeros((len(C), 2, 2))
    for k in range(len(C)):                        # a few hundred centres at most
        try:
            Q[k] = np.asarray(field(C[k:k + 1]), dtype=float)[0]
            ok[k] = True
        except QmeshError:
            continue
    return Q[ok], ok


def ellipse_polydata(C: np.ndarray, Q: np.ndarray, size: float, z: float = 0.0,
                     segments: int = ELLIPSE_SEGMENTS) -> tuple[pv.PolyData, np.ndarray]:
    """Ellipses at centres C (n, 2) for SPD Q (n, 2, 2): axes along Q's eigenvectors, semi-axes
    size · √(λ_i / λ_max) (each ellipse's larger semi-axis is `size`). Returns the polygons and
    each Q's eigenvalues (n, 2), ascending."""
    if len(C) == 0:
        return pv.PolyData(), np.zeros((0, 2))
    lam, V = np.linalg.eigh(0.5 * (Q + np.transpose(Q, (0, 2, 1))))
    lam = np.maximum(lam, 0.0)
    top = np.maximum(lam[:, 1:], 1e-300)
    radii = size * np.sqrt(lam / top)                                 # (n, 2)
    t = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    circle = np.stack([np.cos(t), np.sin(t)], axis=1)                  # (s, 2)
    pts = C[:, None, :] + np.einsum("nij,nj,sj->nsi", V, radii, circle)
    n = len(C)
    faces = np.column_stack([np.full(n, segments, dtype=np.int64),
                             np.arange(n * segments, dtype=np.int64).reshape(n, segments)])
    poly = pv.PolyData(_xyz(pts.reshape(-1, 2), z), faces=faces.ravel())
    return poly, lam


def outline_polydata(ellipses: pv.PolyData, segments: int = ELLIPSE_SEGMENTS) -> pv.PolyData:
    """The polygons of `ellipse_polydata` as closed polylines on the same points, with the same
    cell arrays."""
    if ellipses.n_points == 0:
        return pv.PolyData()
    n = ellipses.n_cells
    ring = np.arange(n * segments, dtype=np.int64).reshape(n, segments)
    lines = np.column_stack([np.full(n, segments + 1, dtype=np.int64), ring, ring[:, :1]])
    out = pv.PolyData(ellipses.points.copy(), lines=lines.ravel())
    for name in ellipses.cell_data.keys():
        out.cell_data[name] = ellipses.cell_data[name]
    return out


def ellipses(step, field, *, domain=None, cells: int = GLYPH_CELLS) -> FieldScene:
    """The first view of `step` for a conductivity field: Q(x) as ellipses on a coarse grid
    over Ω (see `FieldScene`), drawn just above the flat mesh. With a `domain` the ellipses
    are the same at every stage: made once per field and domain (`_ellipse_glyphs`), only
    the mesh under them is new."""
    if not is_field(field):
        raise QmeshError(f"ellipses show a qmesh.TensorField, got {type(field).__name__}")
    P, T = step.mesh.points, step.mesh.triangles
    if domain is None:
        glyphs = _ellipse_glyphs(field, domain_rings(step), cells, None)
    else:
        key = (id(field), id(domain), int(cells))
        hit = _glyph_cache.get(key)
        if hit is None or hit[0] is not field or hit[1] is not domain:
            hit = (field, domain, _ellipse_glyphs(field, domain_rings(step, domain), cells,
                                                  domain.contains))
            while len(_glyph_cache) >= 8:
                _glyph_cache.pop(next(iter(_glyph_cache)), None)
            _glyph_cache[key] = hit
        glyphs = hit[2]
    return FieldScene(mesh=triangles_polydata(P, T), **glyphs)


_glyph_cache: dict = {}
"""The last few fields' ellipses, by (field, domain, cells): a Run draws the same ones at every
stage, and each drawing evaluated the field at the grid's centres again."""


def _ellipse_glyphs(field, rings, cells: int, contains) -> dict:
    """The fields of a `FieldScene` that depend on the field and Ω only, not on the mesh."""
    C, h = glyph_centres(rings, cells, contains)
    Q, ok = _field_at(field, C)
    C_ok = C[ok]
    width = float(np.ptp(np.concatenate(rings), axis=0).max()) or 1.0
    poly, lam = ellipse_polydata(C_ok, Q, GLYPH_FILL * h, z=2e-3 * width)
    clim, uniform = (0.0, 1.0), None
    if len(lam):
        value = np.log10(np.maximum(lam[:, 1], 1e-300))
        poly.cell_data["log10_k_max"] = value
        lo, hi = float(value.min()), float(value.max())
        if hi - lo > 1e-9 * max(1.0, abs(lo)):
            clim = (lo, hi)
        else:
            clim, uniform = (lo - 1.0, lo + 1.0), lo
    return dict(ellipses=poly, outlines=outline_polydata(poly), centres=C_ok, tensors=Q,
                clim=clim, n_skipped=int((~ok).sum()), uniform=uniform)


# --------------------------------------------------------------------------- projected view

@dataclass(frozen=True)
class ProjectedScene:
    """The plane view: mesh with edges, fixed seeds, points just added, displacement arrows."""

    mesh: pv.PolyData
    fixed: pv.PolyData
    added: pv.PolyData        # empty unless the step is an insert stage that added points
    arrows: pv.PolyData       # empty unless the step is an adjust stage that moved points
    n_added: int
    n_moved: int
    sample: pv.PolyData = None   # outlines of one triangle per cell of a coarse grid (crowded)
    interfaces: pv.PolyData = None   # a medium's interface edges (two regions), else empty
    n_fixed: int = 0          # fixed vertices (`fixed` and `added` hold at most MAX_MARKERS)


def projected(step, *, arrow_scale: float = 1.0, min_move: float = 0.0) -> ProjectedScene:
    """The projected Q-Delaunay mesh of `step` with what its stage fixed, added or moved.

    Arrows run from each vertex's position before the adjust stage to its new one, scaled by
    `arrow_scale`; moves no longer than `min_move` are left out.
    """
    m = step.mesh
    P = m.points
    added = np.asarray(step.added if step.added is not None else [], dtype=np.int64)
    added = added[(added >= 0) & (added < len(P))]
    if step.moved is not None:
        # the moves of the vertices there were: a stage that then appended vertices (a metric
        # without s splits edges while it re-triangulates) holds fewer moves than vertices
        D = np.asarray(step.moved, dtype=float)[:len(P)]
        length = np.hypot(D[:, 0], D[:, 1])
        keep = np.flatnonzero(length > min_move)
        shown = keep[longest_per_cell(P[keep], length[keep])]
        arrows = arrows_polydata(P[shown] - D[shown], arrow_scale * D[shown])
        n_moved = len(keep)
    else:
        arrows, n_moved = pv.PolyData(), 0
    tri = triangles_polydata(P, m.triangles)
    T = m.triangles
    x, y = P[:, 0], P[:, 1]
    ax, ay = x[T[:, 0]], y[T[:, 0]]
    area = 0.5 * np.abs((x[T[:, 1]] - ax) * (y[T[:, 2]] - ay) - (y[T[:, 1]] - ay) * (x[T[:, 2]] - ax))
    tri.cell_data["log_area"] = np.log10(np.maximum(area, 1e-300))   # colour when crowded
    tags = np.asarray(m.region_tags)
    interfaces = pv.PolyData()
    if len(tags) and tags.min() != tags.max():                         # a medium: by region
        tri.cell_data["region"] = tags
        tri.cell_data["region_rgb"] = region_rgb(tags)
        E = np.unique(np.sort(T[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
        E = E[interface_mask(m, E)]
        if len(E):
            lift = 2e-3 * max(float(np.ptp(P, axis=0).max()), 1e-300)
            interfaces = pv.PolyData(_xyz(P, lift), lines=_lines(E))
    fixed = np.flatnonzero(m.fixed)
    return ProjectedScene(tri, points_polydata(P[markers(fixed)]),
                          points_polydata(P[markers(added)]), arrows, len(added), n_moved,
                          sample_outlines(P, T), interfaces, len(fixed))


MAX_MARKERS = 2000
"""At most this many seed or inserted-point markers (evenly taken): more only hide the mesh."""


def markers(index: np.ndarray, most: int = MAX_MARKERS) -> np.ndarray:
    """`index` thinned evenly to at most `most` entries."""
    index = np.asarray(index)
    if len(index) <= most:
        return index
    return index[np.linspace(0, len(index) - 1, most).round().astype(np.int64)]


def longest_per_cell(P: np.ndarray, length: np.ndarray, most: int = MAX_MARKERS) -> np.ndarray:
    """Indices into P (n, 2) of the moves to draw: all of them when there are at most `most`,
    else in each cell of a square grid of at most `most` cells over their bounding box the
    longest (the first on a tie). At 1e5 vertices an arrow per vertex is thinner than a pixel
    and 3e5 line cells to draw; one per cell shows the same field of moves."""
    if len(P) <= most:
        return np.arange(len(P))
    cells = max(int(np.sqrt(most)), 1)
    low = P.min(axis=0)
    g = max(float(np.ptp(P, axis=0).max()) / cells, 1e-300)
    ij = np.minimum(np.floor((P - low) / g), cells - 1).astype(np.int64)   # the far side: last cell
    key = ij[:, 0] * cells + ij[:, 1]
    best = np.full(cells * cells, -np.inf)
    np.maximum.at(best, key, length)
    longest = np.flatnonzero(length == best[key])
    _, first = np.unique(key[longest], return_index=True)
    return np.sort(longest[first])


SAMPLE_CELLS = 36            # grid cells across the domain's width for the sampled outlines
SAMPLE_NEAR = 0.25           # a cell's nearest centroid is first sought this close to its centre


def sample_outlines(P: np.ndarray, T: np.ndarray, cells: int = SAMPLE_CELLS) -> pv.PolyData:
    """A decimated wireframe: the outline of one triangle per cell of a `cells`-wide grid (the
    one whose centroid is nearest the cell's centre, the first of them on a tie), so shape, size
    and direction of the elements stay visible when all edges together would only paint the
    domain grey.

    Each cell's nearest is found by `minimum.at` over the centroids within `SAMPLE_NEAR` (in
    cells) of their cell's centre, then over the others of the cells that have none there (the
    same triangles as one pass over all, a fraction of the work on a fine mesh). The lines hold
    only the points they use."""
    if len(T) == 0:
        return pv.PolyData()
    x, y = P[:, 0], P[:, 1]
    cx = (x[T[:, 0]] + x[T[:, 1]] + x[T[:, 2]]) / 3
    cy = (y[T[:, 0]] + y[T[:, 1]] + y[T[:, 2]]) / 3
    x0, y0 = cx.min(), cy.min()
    g = max(float(max(cx.max() - x0, cy.max() - y0)) / cells, 1e-300)
    u, v = (cx - x0) / g, (cy - y0) / g
    i, j = np.floor(u), np.floor(v)
    off = np.hypot(u - i - 0.5, v - j - 0.5)
    key = i.astype(np.int64) * (cells + 2) + j.astype(np.int64)
    best = np.full(int(key.max()) + 1, np.inf)
    near = np.flatnonzero(off < SAMPLE_NEAR)
    np.minimum.at(best, key[near], off[near])             # per cell, the smallest offset
    rest = np.flatnonzero((off >= SAMPLE_NEAR) & ~(best[key] < SAMPLE_NEAR))
    np.minimum.at(best, key[rest], off[rest])
    nearest = np.flatnonzero(off == best[key])
    _, first = np.unique(key[nearest], return_index=True)   # cells in order, lowest index
    E = T[nearest[first]][:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    used, local = np.unique(E, return_inverse=True)
    lift = 1e-3 * max(float(np.ptp(P, axis=0).max()), 1e-300)     # just above the triangles
    return pv.PolyData(_xyz(P[used], lift), lines=_lines(local.reshape(E.shape)))


# --------------------------------------------------------------------------- quality view

@dataclass(frozen=True)
class QualityScene:
    """The quality view: triangles with one cell scalar, optional edges by sign of q_ij."""

    triangles: pv.PolyData
    scalars: str              # name of the cell array the triangles are coloured by
    clim: tuple[float, float]
    edges: pv.PolyData | None  # cell array "q_sign": interior +1 (q_ij ≥ 0) / −1 (< 0), boundary 0,
    #                            interface (two regions) with q_ij ≥ 0: 2
    n_negative: int           # interior edges with q_ij < 0
    n_interface: int = 0      # interface edges (a medium) with q_ij ≥ 0


def q_signs(step, anisotropy, rtol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Every edge (k, 2) and its sign: +1 interior with q_ij ≥ 0, −1 interior with q_ij < 0,
    0 on the boundary (where the M-matrix property says nothing), 2 on an interface between two
    regions with q_ij ≥ 0 (assembled from both sides, each triangle with its own Q). Round-off
    counts as ≥ 0."""
    conductivity = element_means(step.mesh, anisotropy) if is_field(anisotropy) else anisotropy
    edges, q, interior = measure.edge_weights(step.mesh, conductivity)
    scale = np.abs(q).max() if len(q) else 1.0
    sign = np.where(interior, np.where(q >= -rtol * scale, 1, -1), 0)
    if is_medium(anisotropy):
        sign[interface_mask(step.mesh, edges) & (sign == 1)] = 2
    return edges, sign


def interface_mask(mesh, edges: np.ndarray) -> np.ndarray:
    """Which of `edges` (k, 2) lie on an interface: their two triangles are in different
    regions (by `mesh.region_tags`)."""
    T, tags = mesh.triangles, np.asarray(mesh.region_tags)
    n = np.int64(mesh.n_vertices)
    sides = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    key = sides[:, 0] * n + sides[:, 1]
    r = np.tile(tags, 3)
    order = np.lexsort((r, key))
    key, r = key[order], r[order]
    first = np.r_[True, key[1:] != key[:-1]]
    start = np.flatnonzero(first)
    stop = np.r_[start[1:], len(key)] - 1
    across = key[start][r[start] != r[stop]]            # lowest and highest tag differ
    E = np.sort(np.asarray(edges, dtype=np.int64), axis=1)
    return np.isin(E[:, 0] * n + E[:, 1], across)


def quality(step, anisotropy, colour_by: str = "quality",
            q_sign_edges: bool = False) -> QualityScene:
    """Triangles coloured by metric quality (2.94) or metric area, and optionally q_ij signs."""
    if colour_by not in COLOUR_BY:
        raise QmeshError(f"colour_by must be one of {COLOUR_BY}, got {colour_by!r}")
    P, T = step.mesh.points, step.mesh.triangles
    H = hessians(step.mesh, anisotropy)                    # each triangle its own metric
    tri = triangles_polydata(P, T)
    if colour_by == "quality":
        values = metric_quality(P, T, H)                   # (2.94)
        clim = (0.0, 1.0)
    else:
        values = metric_areas(P, T, H)
        clim = (float(values.min()), float(values.max())) if len(values) else (0.0, 1.0)
        if clim[0] == clim[1]:
            clim = (clim[0], clim[0] + 1.0)
    tri.cell_data[colour_by] = values
    edges, n_negative = None, 0
    if q_sign_edges:
        E, sign = q_signs(step, anisotropy)
        edges = pv.PolyData(_xyz(P, 0.0), lines=_lines(E))
        edges.cell_data["q_sign"] = sign
        n_negative = int(np.sum(sign < 0))
    return QualityScene(tri, colour_by, clim, edges, n_negative,
                        0 if edges is None else int(np.sum(sign == 2)))


# --------------------------------------------------------------------------- maximum principle

@dataclass(frozen=True)
class SolutionScene:
    """The maximum-principle view: u_h (point array "u_h"; a value within the tolerance of
    [0, 1] put on its end, so round-off never colours a face as outside) on the mesh shown, the
    Step's or the isotropic one of the same N (`isotropic`), and its vertices with u_h < 0
    (`below`) and u_h > 1 (`above`) beyond `maximum_principle.TOLERANCE`; `comparison` holds
    both solutions."""

    triangles: pv.PolyData
    below: pv.PolyData
    above: pv.PolyData
    sample: pv.PolyData       # one triangle per cell of a grid outlined (crowded edges)
    comparison: maximum_principle.Comparison
    isotropic: bool

    @property
    def shown(self) -> maximum_principle.Solution:
        return self.comparison.isotropic if self.isotropic else self.comparison.mesh


def solution(step, anisotropy, isotropic: bool = False) -> SolutionScene:
    """u_h of −div(Q∇u) = 0 (u = 1 on the boundary left of the middle of the x-range, 0 on the
    rest) on `step`'s mesh, or with `isotropic` on the isotropic mesh of the same N; both are
    solved (and kept for the next redraw of this Step) so the legend can give both counts."""
    comparison = maximum_principle.cached(step.mesh, anisotropy)
    shown = comparison.isotropic if isotropic else comparison.mesh
    P, T, u = shown.mesh.points, shown.mesh.triangles, shown.u
    tri = triangles_polydata(P, T)
    inside = np.ones(len(u), bool)
    inside[shown.outside] = False
    tri.point_data["u_h"] = np.where(inside, np.clip(u, 0.0, 1.0), u)
    lift = 2e-3 * max(float(np.ptp(P, axis=0).max()), 1e-300)    # over the sampled outlines
    low = shown.outside[u[shown.outside] < 0.0]
    high = shown.outside[u[shown.outside] > 1.0]
    return SolutionScene(tri, points_polydata(P[markers(low)], lift),
                         points_polydata(P[markers(high)], lift), sample_outlines(P, T),
                         comparison, bool(isotropic))


def solution_info(view: SolutionScene) -> dict:
    """What the legend says of a `SolutionScene`: for the mesh and the isotropic mesh their N and
    the vertices below 0 and above 1; where u = 1 was imposed; which mesh is shown."""
    def counts(s):
        return {"n_vertices": s.mesh.n_vertices, "n_outside": s.n_outside,
                "n_below": s.n_below, "n_above": s.n_above,
                "u_min": float(s.u.min()), "u_max": float(s.u.max())}
    c = view.comparison
    return {"mesh": counts(c.mesh), "isotropic": counts(c.isotropic), "centre": c.centre,
            "tolerance": maximum_principle.TOLERANCE, "shown": "isotropic" if view.isotropic
            else "mesh"}
