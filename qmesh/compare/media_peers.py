"""Peers on a domain with regions, at the same N: MMG2D with a per-vertex metric, and Triangle.

- `mmg2d`: MMG2D (mmgpy, through `qmesh.compare.peers.mmg_remesh`) from Triangle's constrained
  triangulation of every partition edge (outline, holes, interfaces), the partition's vertices
  required and marked as corners, every partition edge given as an edge so MMG keeps the
  interfaces; the tensor at a vertex is its region's metric ∇²s_r / k_r (the same size-free
  metric qmesh meshes, media/plan.py) scaled by 1/h²; a vertex on an interface (in the closure of
  several regions) gets the mean of its regions' tensors; h calibrated to the target N.
- `triangle`: Shewchuk's Triangle, isotropic (`pq30a`), every partition edge a segment, the
  maximum area calibrated to the target N.
Triangles get their region from their centroid (`region_of`).
"""

from __future__ import annotations

import numpy as np

from qmesh.compare import require
from qmesh.compare.metric_peers import hole_points
from qmesh.compare.peers import MMG_PASSES, PeerMesh, calibrate
from qmesh.errors import QmeshError
from qmesh.geometry import rings as _rings
from qmesh.domain import faces as _faces
from qmesh.mesher.normalise import hessian_scale
from qmesh.triangle_mesh import Mesh


def _face_domains(domain):
    part = domain.partition
    return part, [_faces.face_domain(part, f, {}, f"face {i}") for i, f in enumerate(part.faces)]


def region_of(domain, X) -> np.ndarray:
    """Region tag of points strictly inside faces (centroids); -1 outside Ω."""
    part, doms = _face_domains(domain)
    tag = np.full(len(X), -1, np.int64)
    for f, d in zip(part.faces, doms):
        A, B = d.segment_ends
        tag[_rings.inside(X, A, B)] = f.region
    return tag


def _pslg(domain):
    part = domain.partition
    pslg = {"vertices": np.array(part.points, dtype=float),
            "segments": np.array(part.edges, dtype=np.int32)}
    holes = hole_points(domain) if len(domain.rings) > 1 else []
    if len(holes):
        pslg["holes"] = np.asarray(holes, dtype=float)
    return part, pslg


def _as_mesh(domain, P, T, n_fixed) -> Mesh:
    P = np.asarray(P, dtype=float)
    T = np.asarray(T, dtype=np.int64)
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    T[cw] = T[cw][:, [0, 2, 1]]
    tags = region_of(domain, P[T].mean(axis=1))
    if (tags < 0).any():
        raise QmeshError("a peer put a triangle outside the domain")
    fixed = np.zeros(len(P), bool)
    fixed[:n_fixed] = True
    return Mesh(P, T, fixed, region_tags=tags, region_names=domain.region_names)


def triangle(domain, target_vertices: int, *, rtol: float = 0.03) -> PeerMesh:
    """Isotropic Triangle, regions as segments, area calibrated to the target N."""
    tr = require("triangle", "the Triangle peer")
    part, pslg = _pslg(domain)
    n_b = len(part.points)

    def once(h):
        t = tr.triangulate({k: v.copy() for k, v in pslg.items()},
                           f"pq30a{np.sqrt(3) / 4 * h * h:.15f}Q")
        return _as_mesh(domain, t["vertices"], t["triangles"], n_b)

    h0 = np.sqrt(2 * domain.area / (np.sqrt(3) * max(target_vertices - n_b, 1)))
    return calibrate(once, h0, target_vertices, n_b, rtol=rtol, max_runs=12)


def mmg2d(domain, conductivities, target_vertices: int, *, rtol: float = 0.03) -> PeerMesh:
    """MMG2D with the per-vertex metric described in the module docstring."""
    tr = require("triangle", "the MMG2D start mesh")
    part, pslg = _pslg(domain)
    t = tr.triangulate({k: v.copy() for k, v in pslg.items()}, "pQ")
    P0, T0 = np.asarray(t["vertices"], dtype=float), np.asarray(t["triangles"], dtype=np.int64)
    if len(P0) != len(part.points):
        raise QmeshError("Triangle added points to the start mesh of the partition")
    _, doms = _face_domains(domain)
    ref0 = region_of(domain, P0[T0].mean(axis=1)) + 1         # MMG keeps interfaces between refs
    anis = [conductivities[f.region] for f in part.faces]
    ks = [hessian_scale(a, d.seeds) for a, d in zip(anis, doms)]
    reach = 1e-9 * domain.diameter

    def metric(V):
        H = np.zeros((len(V), 2, 2))
        count = np.zeros(len(V))
        for d, a, k in zip(doms, anis, ks):
            A, B = d.segment_ends
            on = _rings.inside(V, A, B) | np.isfinite(_rings.distance(V, A, B, reach))
            if on.any():
                H[on] += np.asarray(a.hessian(V[on]), dtype=float).reshape(-1, 2, 2) / k
                count[on] += 1
        return H / np.maximum(count, 1)[:, None, None]

    def median_length(P, T, c):
        A = np.concatenate([P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]])
        B = np.concatenate([P[T[:, 1]], P[T[:, 2]], P[T[:, 0]]])
        E = B - A
        H = metric(0.5 * (A + B))
        return float(np.median(np.sqrt(c * np.einsum("ni,nij,nj->n", E, H, E))))

    def once(h):
        c = 1.0 / h**2

        def tensor(V):
            H = c * metric(V)
            return np.column_stack([H[:, 0, 0], H[:, 0, 1], H[:, 1, 1]])
        P, T, ref = _mmg(P0, T0, ref0, part.edges, len(part.points), tensor,
                         lambda P, T: median_length(P, T, c))
        m = _as_mesh(domain, P, T, len(part.points))
        if not np.array_equal(m.region_tags, ref - 1):
            raise QmeshError("MMG2D put a triangle across an interface")
        return m

    total = sum(float(np.sqrt(np.linalg.det(np.asarray(a.hessian(d.seeds[:1]))[0]))) / k * d.area
                for a, d, k in zip(anis, doms, ks))
    h0 = np.sqrt(2 * total / (np.sqrt(3) * max(target_vertices - len(part.points), 1)))
    return calibrate(once, h0, target_vertices, len(part.points), rtol=rtol, max_runs=10)


def _mmg(P, T, ref, edges, n_required, tensor, median_length):
    """MMG2D with triangle references (regions + 1: MMG keeps the edges between different
    references), re-run on its own output until the median metric edge length is ≤ 1.1, as
    `qmesh.compare.peers.mmg_remesh` does for one region."""
    mmgpy = require("mmgpy", "the MMG2D peer")
    m = mmgpy.MmgMesh2D()
    m.set_mesh_size(vertices=len(P), triangles=len(T), edges=len(edges))
    m.set_vertices(np.asarray(P, dtype=float))
    m.set_triangles(np.asarray(T).astype(np.int32), np.asarray(ref).astype(np.int32))
    m.set_edges(np.asarray(edges).astype(np.int32))
    required = np.arange(n_required, dtype=np.int32)
    m.set_required_vertices(required)
    m.set_corners(required)
    for _ in range(MMG_PASSES):
        m.set_field("tensor", tensor(m.get_vertices()[:, :2]))
        m.remesh(nosizreq=1, hgradreq=-1, verbose=-1)
        P = m.get_vertices()[:, :2]
        T, ref = m.get_triangles_with_refs()
        if median_length(P, T) <= 1.1:
            break
    return P, np.asarray(T, dtype=np.int64), np.asarray(ref, dtype=np.int64)
