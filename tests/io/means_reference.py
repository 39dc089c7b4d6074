"""The stiffness matrix with per-triangle Q that the adapters' assemblies are compared with:
K_ij = Σ_T |T| ∇φ_iᵀ Q̄_T ∇φ_j (FIELDS.md §2). Imported by the tests here and, in DOLFINx's own
venv, by `dolfinx_means_check.py` (NumPy and SciPy only, besides qmesh)."""

import numpy as np
import scipy.sparse as sp

import qmesh


def p1_stiffness(points, triangles, Q) -> sp.csr_matrix:
    """K_ij = Σ_T |T| ∇φ_iᵀ Q̄_T ∇φ_j, P1 on `triangles` (counter-clockwise) with Q (M, 2, 2) per triangle."""
    P, T = np.asarray(points, float), np.asarray(triangles)
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    area = 0.5 * ((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    G = np.stack([np.stack([b[:, 1] - c[:, 1], c[:, 1] - a[:, 1], a[:, 1] - b[:, 1]], 1),
                  np.stack([c[:, 0] - b[:, 0], a[:, 0] - c[:, 0], b[:, 0] - a[:, 0]], 1)], 1) / (2 * area[:, None, None])
    Ke = area[:, None, None] * np.einsum("kdi,kde,kej->kij", G, np.asarray(Q, float), G)
    rows, cols = np.repeat(T, 3, axis=1).ravel(), np.tile(T, (1, 3)).ravel()
    return sp.coo_matrix((Ke.ravel(), (rows, cols)), shape=(len(P), len(P))).tocsr()


def assert_assembles_the_means(K, mesh, rtol=1e-12) -> None:
    """K (in the Mesh's vertex numbering) equals the P1 formula with the mesh's element means and,
    where `qmesh.measure.stiffness` takes a per-triangle Q, qmesh's own assembly."""
    K = sp.csr_matrix(K)
    references = [p1_stiffness(mesh.points, mesh.triangles, mesh.conductivity)]
    try:
        references.append(sp.csr_matrix(qmesh.measure.stiffness(mesh, mesh.conductivity)))
    except (qmesh.QmeshError, TypeError, ValueError, AttributeError):
        pass    # measure's stiffness takes one Q per region only
    for R in references:
        assert K.shape == R.shape
        assert abs(K - R).max() <= rtol * abs(R).max()
