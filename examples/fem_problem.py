"""The problem the FEM examples solve, and scikit-fem's solve on qmesh's arrays to compare with.

A plate [0, 2] × [0, 1] with a square hole, outline "wall", hole "hole"; Q = principal(1, 50, 30)
(a rotated conductivity, anisotropy 50); −div(Q∇u) = 1, u = 0 on "wall", Q∇u·n = 0 on "hole".
`examples/fem_dolfinx.py`, `fem_ngsolve.py` read qmesh's files with their own readers and
solve it; `reference` solves it with scikit-fem on the Mesh's own arrays (no file).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

import qmesh

ANISOTROPY = qmesh.Anisotropy.principal(1, 50, 30)


def plate() -> qmesh.Domain:
    return qmesh.Domain([[0, 0], [2, 0], [2, 1], [0, 1]], holes=[[[0.8, 0.3], [1.2, 0.3], [1.2, 0.7], [0.8, 0.7]]],
                        names={1: "wall", 2: "hole"})


def make_mesh(target_vertices: int = 1500) -> qmesh.Mesh:
    return qmesh.mesh(plate(), ANISOTROPY, target_vertices=target_vertices, seed=0)


def positive_off_diagonals(K, free) -> int:
    """How many off-diagonal entries of K between free (non-Dirichlet) dofs are > 0: an
    M-matrix has none (the share q_ij ≥ 0 the mesh is built for)."""
    K = sp.coo_matrix(K)
    keep = np.zeros(K.shape[0], bool)
    keep[np.asarray(free)] = True
    off = (K.row != K.col) & keep[K.row] & keep[K.col]
    scale = np.abs(K.data).max(initial=0.0)
    return int(np.count_nonzero(K.data[off] > 1e-12 * scale))


def reference(mesh: qmesh.Mesh) -> np.ndarray:
    """u at the Mesh's vertices, by scikit-fem on the Mesh's arrays (`qmesh.io.to_skfem`)."""
    import skfem
    from skfem.helpers import dot, grad

    import qmesh.io

    m = qmesh.io.to_skfem(mesh)
    Q = ANISOTROPY.matrix

    @skfem.BilinearForm
    def stiffness(u, v, w):
        return dot(np.einsum("ij,j...->i...", Q, grad(u)), grad(v))

    @skfem.LinearForm
    def load(v, w):
        return v

    basis = skfem.Basis(m, skfem.ElementTriP1())
    A, b = stiffness.assemble(basis), load.assemble(basis)
    return skfem.solve(*skfem.condense(A, b, D=basis.get_dofs(m.boundaries["wall"])))
