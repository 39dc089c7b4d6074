"""How many vertices each face of a multi-region domain gets, and where interfaces are split.

MEDIA.md §3 "Sizing": the target N is shared between regions by metric area ∫_r √det H_r plus
what the boundary and the interfaces need (Euler's relation, as in `qmesh.mesher.sizing`).
Each region's metric is taken with its size divided out, H_r / k_r (k_r the norm the mesher's
own normalisation uses, GEOMETRY.md §3): the mesher meshes the *shape* of Q, not its size, so
a contrast of 1e4 between two isotropic regions must not put 1e4 times more vertices per unit
area into the conductive one. One metric edge length h then holds for every region, and an
interface edge is split so that its pieces are at most h long in the metric of both sides.
"""

from __future__ import annotations

import numpy as np

from qmesh.mesher import sizing
from qmesh.mesher.normalise import _hessian_scale

BOUNDARY_FACTOR = 1.0     # as the single-region mesher: boundary pieces of at most h


def region_scale(anisotropy, points) -> float:
    """k_r: the typical norm of ∇²s_r on a face (exact for constant Q)."""
    return _hessian_scale(anisotropy, points)


def edge_lengths(A, B, anisotropy, k: float) -> np.ndarray:
    """Length of segments A→B in the metric ∇²s / k (8-point Gauss rule for a varying s)."""
    E = B - A
    X = A[:, None, :] + sizing._GL_X[None, :, None] * E[:, None, :]
    Hs = (np.broadcast_to(anisotropy.H, (X.shape[0] * X.shape[1], 2, 2)) if anisotropy.is_constant
          else np.asarray(anisotropy.hessian(X.reshape(-1, 2)), dtype=float))
    Ek = np.repeat(E, len(sizing._GL_X), axis=0)
    dens = np.sqrt(np.einsum("ni,nij,nj->n", Ek, Hs, Ek) / k).reshape(len(A), -1)
    return dens @ sizing._GL_W


def interface_pieces(part, face_anis, face_k, h: float) -> np.ndarray:
    """For every edge of the partition, into how many pieces it is cut before meshing: interface
    edges so that each piece is ≤ h in the metric of both faces, other edges 1 (the face's own
    mesher splits its boundary)."""
    E, V = part.edges, part.points
    pieces = np.ones(len(E), np.int64)
    inter = np.flatnonzero(part.interface)
    if not len(inter):
        return pieces
    A, B = V[E[inter, 0]], V[E[inter, 1]]
    longest = np.zeros(len(inter))
    for side in (0, 1):
        f = part.edge_faces[inter, side]
        for face in np.unique(f):
            on = f == face
            L = edge_lengths(A[on], B[on], face_anis[face], face_k[face])
            longest[on] = np.maximum(longest[on], L)
    pieces[inter] = np.maximum(1, np.ceil(longest / (BOUNDARY_FACTOR * h))).astype(np.int64)
    return pieces


def expected_vertices(part, face_area, face_lengths, h: float, pieces_fn) -> float:
    """Expected N of the stitched mesh for metric edge length h: Σ over faces of Euler's
    estimate, less the interface vertices counted on both sides."""
    pieces = pieces_fn(h)
    n = sum(sizing.vertices_for_size(a, L, h, BOUNDARY_FACTOR)
            for a, L in zip(face_area, face_lengths))
    return n - float(pieces[part.interface].sum())


def size_for_vertices(part, face_area, face_lengths, n: int, pieces_fn) -> float:
    """The h whose expected stitched N is n (bisection in log h)."""
    total = sum(face_area)
    lo = 1e-9 * np.sqrt(total)
    hi = 10.0 * (np.sqrt(total) + sum(float(L.sum()) for L in face_lengths))
    for _ in range(100):
        mid = np.sqrt(lo * hi)
        if expected_vertices(part, face_area, face_lengths, mid, pieces_fn) > n:
            lo = mid
        else:
            hi = mid
    return float(np.sqrt(lo * hi))
