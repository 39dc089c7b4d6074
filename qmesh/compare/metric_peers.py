"""Peers for any domain and a varying s: MMG2D with the vertex metric c·∇²s, stretched Triangle.

`qmesh.compare.peers` drives BAMG and MMG2D with one constant metric on a convex polygon whose
sides stay whole. The benchmarks for a varying s and for domains with holes need more:
- `mmg2d`: MMG2D (mmgpy, through `peers.mmg_remesh`) started from the constrained triangulation
  of Ω (holes included), the input points required and marked as corners (so added boundary
  points stay on the straight sides; MMG may split the sides, as qmesh does), the tensor metric
  c·∇²s evaluated at its own vertices and re-evaluated on every re-run, c calibrated until N is
  within `rtol` of the target;
- `stretched_triangle`: Shewchuk's Triangle in metric coordinates y = Lᵀx (LLᵀ = ∇²s, constant),
  conforming Delaunay `pq30D` with one maximum area bisected until N lands on the target, then
  mapped back — the peer that also gets every q_ij ≥ 0 for a constant Q.
The meshes are measured with `qmesh.measure` like qmesh's own.
"""

from __future__ import annotations

import time

import numpy as np

from qmesh.mesher import sizing
from qmesh.errors import QmeshError
from qmesh.geometry.triangles import Frame
from qmesh.compare import require
from qmesh.compare.peers import PeerMesh, _with_fixed, calibrate, mmg_remesh


def _equilateral_h(metric_area: float, n: int) -> float:
    """Metric edge length when n vertices (2n equilateral metric triangles) fill metric_area."""
    return float(sizing.size_of_area(metric_area / (2 * max(n, 1))))


# --------------------------------------------------------------------------- Ω for Triangle

def hole_points(domain) -> np.ndarray:
    """A point strictly inside each hole (the centroid of its largest triangle): Triangle's `holes`."""
    tr = require("triangle", "the Triangle peer")
    out = []
    for ring in domain.rings[1:]:
        n = len(ring)
        t = tr.triangulate({"vertices": np.array(ring, dtype=float), "segments": np.column_stack([np.arange(n), (np.arange(n) + 1) % n])}, "p")
        P, T = t["vertices"], t["triangles"]
        A = np.abs(Frame(P, T).A)
        out.append(P[T[int(np.argmax(A))]].mean(axis=0))
    return np.reshape(out, (-1, 2))


def _pslg(domain, L: np.ndarray | None = None) -> dict:
    """Triangle's input for Ω (optionally mapped by x ↦ x L)."""
    seeds = np.array(domain.seeds, dtype=float)          # Triangle writes into its inputs: copies
    pslg = {"vertices": seeds, "segments": np.array(domain.segments, dtype=np.int32)}
    holes = hole_points(domain)
    if len(holes):
        pslg["holes"] = holes
    if L is not None:
        pslg["vertices"] = seeds @ L
        if len(holes):
            pslg["holes"] = holes @ L
    return pslg


def start_mesh(domain) -> tuple[np.ndarray, np.ndarray]:
    """The constrained Delaunay triangulation of Ω's own points (no point added)."""
    tr = require("triangle", "the MMG2D start mesh")
    t = tr.triangulate(_pslg(domain), "p")
    if len(t["vertices"]) != len(domain.seeds):
        raise QmeshError("Triangle added points to the start mesh of the domain")
    return np.asarray(t["vertices"], dtype=float), np.asarray(t["triangles"], dtype=np.int64)


# --------------------------------------------------------------------------- MMG2D

def _median_metric_length(P: np.ndarray, T: np.ndarray, hessian, c: float) -> float:
    """Median length of the edges in the metric c·∇²s taken at their midpoints."""
    A = np.concatenate([P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]])
    B = np.concatenate([P[T[:, 1]], P[T[:, 2]], P[T[:, 0]]])
    H = np.asarray(hessian(0.5 * (A + B)), dtype=float)
    E = B - A
    return float(np.median(np.sqrt(c * np.einsum("ni,nij,nj->n", E, H, E))))


def mmg2d(domain, anisotropy, target_vertices: int, *, rtol: float = 0.03, max_runs: int = 10) -> PeerMesh:
    """MMG2D on Ω with the vertex metric ∇²s / h², h calibrated until N is within rtol of the target."""
    seeds = np.asarray(domain.seeds, dtype=float)
    P0, T0 = start_mesh(domain)
    segments = np.asarray(domain.segments)

    def once(h):
        c = 1.0 / h**2

        def tensor(V):
            H = c * np.asarray(anisotropy.hessian(V), dtype=float)
            return np.column_stack([H[:, 0, 0], H[:, 0, 1], H[:, 1, 1]])

        P, T = mmg_remesh(P0, T0, segments, len(seeds), tensor,
                          lambda P, T: _median_metric_length(P, T, anisotropy.hessian, c), keep_sides=False)
        return _with_fixed(P, T, seeds)

    h0 = _equilateral_h(sizing.metric_area(domain, anisotropy), int(target_vertices) - len(seeds))
    return calibrate(once, h0, target_vertices, len(seeds), rtol=rtol, max_runs=max_runs)


# --------------------------------------------------------------------------- stretched Triangle

def area_switch(area: float) -> str:
    """Triangle's maximum-area switch, the area in plain decimals: Triangle reads `a6.3e-05` as
    a6.3 followed by the switches e, -, 0, 5 (as `compare.isotropic.switches` does)."""
    return "a" + np.format_float_positional(float(area), trim="-")


def stretched_triangle(domain, anisotropy, target_vertices: int, *, rtol: float = 0.03,
                       max_runs: int = 40, switches: str = "pq30D") -> PeerMesh:
    """Triangle's conforming Delaunay mesh in metric coordinates y = Lᵀx (LLᵀ = ∇²s), mapped back.

    The one maximum triangle area is bisected (in log) until N is within rtol of the target.
    """
    if not anisotropy.is_constant:
        raise QmeshError("the stretched Triangle peer needs a constant Q")
    tr = require("triangle", "the Triangle peer")
    L = np.linalg.cholesky(anisotropy.H)            # LLᵀ = H; y = Lᵀx, as a row vector x @ L
    pslg = _pslg(domain, L)
    seeds = np.asarray(domain.seeds, dtype=float)
    metric_area = domain.area * float(np.sqrt(np.linalg.det(anisotropy.H)))
    area = metric_area / max(int(target_vertices) - len(seeds), 1)   # ≈ 2 triangles per vertex
    lo, hi, best = None, None, None
    for run in range(1, max_runs + 1):
        t0 = time.perf_counter()
        t = tr.triangulate(pslg, switches + area_switch(area))
        seconds = time.perf_counter() - t0
        P = np.linalg.solve(L.T, np.asarray(t["vertices"], dtype=float).T).T
        n = len(P)
        miss = abs(n - target_vertices) / target_vertices
        if best is None or miss < best[0]:
            best = (miss, PeerMesh(_with_fixed(P, t["triangles"], seeds), seconds, run, area))
        if miss <= rtol:
            break
        if n > target_vertices:
            lo = area
        else:
            hi = area
        area = np.sqrt(lo * hi) if lo is not None and hi is not None else area * (n / target_vertices)
    _, result = best
    return PeerMesh(result.mesh, result.seconds, run, result.h)


