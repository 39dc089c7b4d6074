"""The guide's two problems ("From conductivity to solution") solved by NGSolve on the mesh
scikit-fem solves them on, with the same element means, u and f.

`qmesh.io.to_ngsolve(mesh, with_means=True)` gives the mesh (its vertex k, P1 dof k, is qmesh's
vertex k) and Q̄_T as a piecewise-constant 2×2 CoefficientFunction; u and f are the problem's
SymPy expressions rebuilt as CoefficientFunctions (`solve_problems.translate`), integrated by
the 12-point rule of degree 6 that scikit-fem's `intorder=6` and DOLFINx's degree 6 use too; u is
set at the boundary vertices. Prints the L2 error and the positive off-diagonals of the
stiffness matrix between free dofs.

Run: python examples/ngsolve_solve.py [TARGET_VERTICES]      (needs qmesh[fem-ngsolve])
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).resolve().parent))
import solve_problems  # noqa: E402

import qmesh  # noqa: E402
import qmesh.io  # noqa: E402

DEGREE = 6      # the quadrature's exact degree for f φ_i and (u_h − u)², as scikit-fem's intorder=6


class Result(NamedTuple):
    u: np.ndarray           # u_h at the vertices
    error: float            # ‖u_h − u‖_L2
    positive: int           # positive off-diagonals of K between free vertices


def solve(mesh: qmesh.Mesh, problem: solve_problems.Problem, degree: int = DEGREE) -> Result:
    import ngsolve as ngs

    m, Q = qmesh.io.to_ngsolve(mesh, with_means=True)
    fes = ngs.H1(m, order=1, dirichlet=".*")                    # u given on every boundary
    u, v = fes.TnT()
    dx = ngs.dx(intrules={ngs.TRIG: ngs.IntegrationRule(ngs.TRIG, degree)})

    def code(expr):
        return solve_problems.translate(expr, ngs.x, ngs.y, {"sin": ngs.sin, "cos": ngs.cos}, ngs.IfPos)

    a = ngs.BilinearForm((Q * ngs.grad(u)) * ngs.grad(v) * ngs.dx).Assemble()   # Σ_T |T| ∇φ_iᵀ Q̄_T ∇φ_j
    f = ngs.LinearForm(fes)
    if problem.f_expr != 0:                                     # NGSolve refuses a zero integrand
        f += code(problem.f_expr) * v * dx
    f.Assemble()
    free = np.fromiter(fes.FreeDofs(), bool, fes.ndof)
    gfu = ngs.GridFunction(fes)
    gfu.vec.FV().NumPy()[~free] = problem.u(*mesh.points[~free].T)    # P1 dof k is vertex k
    r = f.vec.CreateVector()
    r.data = f.vec - a.mat * gfu.vec
    gfu.vec.data += a.mat.Inverse(fes.FreeDofs(), inverse="sparsecholesky") * r
    error = np.sqrt(ngs.Integrate((gfu - code(problem.u_expr)) ** 2, m, order=degree))
    rows, cols, values = a.mat.COO()
    K = sp.coo_matrix((np.asarray(values), (np.asarray(rows), np.asarray(cols))), shape=(fes.ndof, fes.ndof))
    return Result(gfu.vec.FV().NumPy().copy(), float(error),
                  solve_problems.positive_off_diagonals(K, np.flatnonzero(free)))


def main(target_vertices: int = 1500) -> dict[str, Result]:
    results = {}
    for name, problem, mesh in solve_problems.meshed(target_vertices):
        results[name] = result = solve(mesh, problem)
        print(solve_problems.summary("NGSolve", name, mesh.n_vertices, result.error, result.positive))
    return results


if __name__ == "__main__":
    results = main(*(int(a) for a in sys.argv[1:]))
