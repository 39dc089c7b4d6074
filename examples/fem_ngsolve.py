"""Solve −div(Q∇u) = 1 with NGSolve on a qmesh mesh read by NGSolve's own gmsh reader.

qmesh writes the holed plate (`fem_problem.py`) as gmsh 2.2 ASCII; `netgen.read_gmsh.ReadGmsh`
reads it with the boundary names "wall" and "hole" and the material "domain"; u = 0 on "wall"
(Dirichlet), natural on "hole". Q comes from `Anisotropy.matrix`. The M-matrix check counts
the positive off-diagonal entries of the assembled stiffness matrix between free dofs.
(`qmesh.io.to_ngsolve(mesh)` gives the same mesh without a file.)

Run: python examples/fem_ngsolve.py [TARGET_VERTICES]      (needs qmesh[io,fem-ngsolve])
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).resolve().parent))
import fem_problem  # noqa: E402

import qmesh.io  # noqa: E402


def solve(path) -> dict:
    """Read the .msh at `path` with NGSolve, solve, and return u at the file's nodes and the checks."""
    import ngsolve as ngs
    from netgen.read_gmsh import ReadGmsh

    mesh = ngs.Mesh(ReadGmsh(str(path)))
    fes = ngs.H1(mesh, order=1, dirichlet="wall")
    u, v = fes.TnT()
    Q = ngs.CoefficientFunction(tuple(fem_problem.ANISOTROPY.matrix.ravel()), dims=(2, 2))
    a = ngs.BilinearForm(fes)
    a += (Q * ngs.grad(u)) * ngs.grad(v) * ngs.dx
    a.Assemble()
    f = ngs.LinearForm(fes)
    f += 1 * v * ngs.dx
    f.Assemble()
    gfu = ngs.GridFunction(fes)
    gfu.vec.data = a.mat.Inverse(fes.FreeDofs(), inverse="sparsecholesky") * f.vec
    rows, cols, vals = a.mat.COO()
    K = sp.coo_matrix((np.asarray(vals), (np.asarray(rows), np.asarray(cols))), shape=(fes.ndof, fes.ndof))
    free = np.flatnonzero(np.array(list(fes.FreeDofs())))
    return {"u": np.array(gfu.vec), "boundaries": sorted(set(mesh.GetBoundaries())),
            "materials": list(mesh.GetMaterials()), "n_vertices": mesh.nv,
            "positive_off_diagonals": fem_problem.positive_off_diagonals(K, free)}


def main(target_vertices: int = 1500) -> dict:
    mesh = fem_problem.make_mesh(target_vertices)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "plate.msh"
        qmesh.io.write(path, mesh, anisotropy=fem_problem.ANISOTROPY)
        result = solve(path)
    print(f"NGSolve: N={result['n_vertices']} boundaries={result['boundaries']} materials={result['materials']} "
          f"max u={result['u'].max():.6g} positive off-diagonals={result['positive_off_diagonals']}")
    return {**result, "mesh": mesh}


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1500)
