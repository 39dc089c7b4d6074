"""Anisotropic peers: gmsh's BAMG and MMG2D (through mmgpy), driven to the same N as qmesh.

Both receive the metric a user of those tools would give: the constant tensor ∇²s (MATH.md:
lengths are measured in H = ∇²s) divided by h², with h calibrated by a few runs until the
vertex count lands near the target. The VB-gon's sides are kept whole (no boundary point
added), as in the chapter's adapted meshes:
- BAMG (Borouchaki, Hecht et al.) via gmsh, `Mesh.Algorithm = 7`, the metric as a tensor
  post-processing view used as background field, every boundary line transfinite with 2 nodes;
- MMG2D (Dapogny, Dobrzynski, Frey) via mmgpy: required boundary edges and vertices, a tensor
  metric, and `nosizreq` (without it MMG overwrites the metric at required vertices with an
  isotropic size and the mesh is barely anisotropic).
Both are optional: `available()` says which import here, and why not. BAMG through gmsh is
not deterministic here (the same input gave 209 or 213 vertices on repeated calls), so its rows
vary slightly from run to run; MMG2D is deterministic.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from qmesh.errors import QmeshError
from qmesh.mesher import sizing
from qmesh.geometry.triangles import signed_areas
from qmesh.triangle_mesh import Mesh
from qmesh.compare import require

PEERS = ("bamg", "mmg2d")
_MODULE = {"bamg": "gmsh", "mmg2d": "mmgpy"}


@dataclass(frozen=True)
class PeerMesh:
    """A peer's mesh, the wall time of its final (calibrated) run, and how many runs it took."""

    mesh: Mesh
    seconds: float
    runs: int
    h: float


def available() -> dict[str, str | None]:
    """{peer: None if it imports here, else the reason it does not}."""
    out = {}
    for peer in PEERS:
        try:
            require(_MODULE[peer], peer)
            out[peer] = None
        except QmeshError as exc:
            out[peer] = str(exc)
    return out


def _constant_metric(anisotropy) -> np.ndarray:
    if not anisotropy.is_constant:
        raise QmeshError("the peers are driven with a constant metric; this anisotropy varies")
    return np.asarray(anisotropy.H, dtype=float)


def _with_fixed(P: np.ndarray, T: np.ndarray, seeds: np.ndarray) -> Mesh:
    """A Mesh with counter-clockwise triangles and the seed points marked fixed."""
    P = np.ascontiguousarray(P[:, :2], dtype=float)
    T = np.asarray(T, dtype=np.int64).copy()
    cw = signed_areas(P, T) < 0
    T[cw] = T[cw][:, [0, 2, 1]]
    dist, idx = cKDTree(P).query(seeds)
    if np.any(dist > 1e-9 * max(1.0, np.abs(seeds).max())):
        raise QmeshError("the peer moved or dropped a seed boundary point")
    fixed = np.zeros(len(P), bool)
    fixed[idx] = True
    return Mesh(P, T, fixed)


def _fan(seeds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A valid start mesh of a convex polygon: its corners fanned around their mean."""
    n = len(seeds)
    P = np.vstack([seeds, seeds.mean(axis=0)])
    i = np.arange(n)
    return P, np.column_stack([i, (i + 1) % n, np.full(n, n)])


# --------------------------------------------------------------------------- BAMG (gmsh)

def _bamg_once(seeds: np.ndarray, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    gmsh = require("gmsh", "the BAMG peer")
    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("qmesh-peer")
        geo = gmsh.model.geo
        pts = [geo.addPoint(x, y, 0.0) for x, y in seeds]
        n = len(pts)
        lines = [geo.addLine(pts[i], pts[(i + 1) % n]) for i in range(n)]
        geo.addPlaneSurface([geo.addCurveLoop(lines)])
        for line in lines:                       # keep every side whole: 2 nodes, no new point
            geo.mesh.setTransfiniteCurve(line, 2)
        geo.synchronize()
        # The metric as a tensor view on two triangles covering the polygon's bounding box.
        lo, hi = seeds.min(axis=0) - 1.0, seeds.max(axis=0) + 1.0
        tensor = [M[0, 0], M[0, 1], 0.0, M[1, 0], M[1, 1], 0.0, 0.0, 0.0, 1.0] * 3
        cover = [[lo[0], hi[0], hi[0], lo[1], lo[1], hi[1], 0, 0, 0],
                 [lo[0], hi[0], lo[0], lo[1], hi[1], hi[1], 0, 0, 0]]
        view = gmsh.view.add("metric")
        gmsh.view.addListData(view, "TT", 2, [v for xyz in cover for v in xyz + tensor])
        field = gmsh.model.mesh.field.add("PostView")
        gmsh.model.mesh.field.setNumber(field, "ViewTag", view)
        gmsh.model.mesh.field.setAsBackgroundMesh(field)
        for name, value in (("Mesh.MeshSizeExtendFromBoundary", 0), ("Mesh.MeshSizeFromPoints", 0),
                            ("Mesh.MeshSizeFromCurvature", 0), ("Mesh.AnisoMax", 1e6),
                            ("Mesh.Algorithm", 7)):
            gmsh.option.setNumber(name, value)
        gmsh.model.mesh.generate(2)
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        _, nodes = gmsh.model.mesh.getElementsByType(2)
        index = np.zeros(int(tags.max()) + 1, np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        gmsh.view.remove(view)
        gmsh.model.remove()
        return xyz.reshape(-1, 3)[:, :2], index[nodes.astype(np.int64).reshape(-1, 3)]
    finally:
        if own:
            gmsh.finalize()


# --------------------------------------------------------------------------- MMG2D (mmgpy)

def _median_metric_length(P: np.ndarray, T: np.ndarray, M: np.ndarray) -> float:
    E = np.concatenate([P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 1]], P[T[:, 0]] - P[T[:, 2]]])
    return float(np.median(np.sqrt(np.einsum("ni,ij,nj->n", E, M, E))))


MMG_PASSES = 4
"""MMG2D stops after a fixed number of sweeps: from the coarse start mesh one pass leaves edges
too long in the metric once N exceeds ~1e4 (median metric length 1.49 at 5e4 vertices here).
It is run again on its own output until the median metric edge length is within 10% of 1."""


def mmg_remesh(P: np.ndarray, T: np.ndarray, edges: np.ndarray, n_required: int, tensor,
               median_length, *, keep_sides: bool) -> tuple[np.ndarray, np.ndarray]:
    """MMG2D from the mesh (P, T) whose boundary is `edges` and whose first n_required points
    are required, with the metric tensor(V) → (n, 3) [m11, m12, m22] at its vertices V,
    re-evaluated and MMG re-run on its own output until median_length(P, T) ≤ 1.1.

    keep_sides: every boundary edge required (sides kept whole); else the required points are
    corners, so the points MMG adds on the straight sides stay on them.
    """
    mmgpy = require("mmgpy", "the MMG2D peer")
    m = mmgpy.MmgMesh2D()
    m.set_mesh_size(vertices=len(P), triangles=len(T), edges=len(edges))
    m.set_vertices(np.asarray(P, dtype=float))
    m.set_triangles(np.asarray(T).astype(np.int32))
    m.set_edges(np.asarray(edges).astype(np.int32))
    required = np.arange(n_required, dtype=np.int32)
    m.set_required_vertices(required)
    if keep_sides:
        m.set_required_edges(np.arange(len(edges), dtype=np.int32))
    else:
        m.set_corners(required)
    for _ in range(MMG_PASSES):
        m.set_field("tensor", tensor(m.get_vertices()[:, :2]))
        m.remesh(nosizreq=1, hgradreq=-1, verbose=-1)
        P, T = m.get_vertices()[:, :2], m.get_triangles()
        if median_length(P, T) <= 1.1:
            break
    return P, T


def _mmg_once(seeds: np.ndarray, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = len(seeds)
    edges = np.column_stack([np.arange(n), (np.arange(n) + 1) % n])
    return mmg_remesh(*_fan(seeds), edges, n, lambda V: np.tile([M[0, 0], M[0, 1], M[1, 1]], (len(V), 1)),
                      lambda P, T: _median_metric_length(P, T, M), keep_sides=True)


# --------------------------------------------------------------------------- calibration

_ONCE = {"bamg": _bamg_once, "mmg2d": _mmg_once}


def peer_mesh(peer: str, domain, anisotropy, target_vertices: int, *, rtol: float = 0.03,
              max_runs: int = 8) -> PeerMesh:
    """Mesh `domain` with a peer, scaling the metric ∇²s / h² until N is within rtol of the target.

    The interior vertex count scales like h⁻²; each run refits that exponent from the last two
    runs (a secant step in log-log) and the closest run is returned.
    """
    if peer not in _ONCE:
        raise QmeshError(f"unknown peer {peer!r}; choose from {PEERS}")
    H = _constant_metric(anisotropy)
    seeds = np.asarray(domain.seeds, dtype=float)
    n_b = len(seeds)
    if int(target_vertices) - n_b < 1:
        raise QmeshError(f"target_vertices must exceed the {n_b} boundary points")
    metric_area = np.sqrt(np.linalg.det(H)) * domain.area
    h = sizing.size_of_area(metric_area / (2 * (int(target_vertices) - n_b)))   # equilateral metric triangles

    def once(h):
        P, T = _ONCE[peer](seeds, H / h**2)
        return _with_fixed(P, T, seeds)

    return calibrate(once, h, target_vertices, n_b, rtol=rtol, max_runs=max_runs)


def calibrate(run_once, h0: float, target_vertices: int, n_fixed: int, *, rtol: float = 0.03,
              max_runs: int = 10, slope0: float = -2.0) -> PeerMesh:
    """Call run_once(h) → Mesh until N is within rtol of the target; the closest run is returned.

    N − n_fixed scales like h^slope (−2 in 2-D); each run refits the slope from the last two
    runs (a secant step in log-log).
    """
    want = int(target_vertices) - n_fixed
    if want < 1:
        raise QmeshError(f"target_vertices must exceed the {n_fixed} fixed points")
    h, history, best = float(h0), [], None
    for run in range(1, max_runs + 1):
        t0 = time.perf_counter()
        mesh = run_once(h)
        seconds = time.perf_counter() - t0
        miss = abs(mesh.n_vertices - target_vertices) / target_vertices
        if best is None or miss < best[0]:
            best = (miss, PeerMesh(mesh, seconds, run, h))
        if miss <= rtol:
            break
        got = max(mesh.n_vertices - n_fixed, 1)
        history.append((np.log(h), np.log(got)))
        slope = slope0
        if len(history) >= 2:
            (x0, y0), (x1, y1) = history[-2:]
            if abs(x1 - x0) > 1e-9 and y1 != y0:
                slope = float(np.clip((y1 - y0) / (x1 - x0), -4.0, -0.5))
        h *= float(np.exp(np.log(want / got) / slope))
    _, result = best
    return PeerMesh(result.mesh, result.seconds, run, result.h)
