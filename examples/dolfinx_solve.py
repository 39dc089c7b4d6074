"""The guide's two problems ("From conductivity to solution") solved by DOLFINx on the mesh
scikit-fem solves them on, with the same element means, u and f.

`qmesh.io.to_dolfinx(mesh, comm)` gives the mesh, its facet tags and Q̄_T as a DG0 tensor
Function "Q"; u and f are the problem's SymPy expressions rebuilt in UFL
(`solve_problems.translate`), integrated at quadrature degree 6 (basix's 12-point rule, the one
scikit-fem's `intorder=6` and NGSolve's degree 6 use); u is interpolated (P1: its nodal values)
on the dofs of the tagged boundary facets. DOLFINx assembles K and b, SciPy solves (no PETSc
needed), as in `fem_dolfinx.py`; one MPI process. Prints the L2 error and the positive
off-diagonals of the stiffness matrix between free dofs.

DOLFINx's wheels need Python >= 3.12: `python3.12 -m venv .venv-dolfinx &&
. .venv-dolfinx/bin/activate && pip install -e ".[fem-dolfinx]"`.

Run: python examples/dolfinx_solve.py [TARGET_VERTICES] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla

sys.path.insert(0, str(Path(__file__).resolve().parent))
import solve_problems  # noqa: E402

import qmesh  # noqa: E402
import qmesh.io  # noqa: E402

DEGREE = 6      # the quadrature's exact degree for f φ_i and (u_h − u)², as scikit-fem's intorder=6


def solve(mesh: qmesh.Mesh, problem: solve_problems.Problem, degree: int = DEGREE) -> dict:
    """u_h at the dofs' points, ‖u_h − u‖_L2 and the positive off-diagonals between free dofs."""
    try:
        import dolfinx_solver  # noqa: F401 - PyPI's DOLFINx: loads MPI before dolfinx
    except ImportError:
        pass
    import ufl
    from dolfinx import default_scalar_type, fem
    from mpi4py import MPI

    adapted = qmesh.io.to_dolfinx(mesh, MPI.COMM_WORLD)
    msh, Q = adapted.mesh, adapted.conductivity
    V = fem.functionspace(msh, ("Lagrange", 1))
    x = ufl.SpatialCoordinate(msh)
    dx = ufl.dx(metadata={"quadrature_degree": degree})

    def code(expr):
        source = solve_problems.translate(expr, x[0], x[1], {"sin": ufl.sin, "cos": ufl.cos},
                                          lambda t, a, b: ufl.conditional(ufl.gt(t, 0), a, b))
        return fem.Constant(msh, default_scalar_type(source)) if isinstance(source, float) else source

    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    a = ufl.inner(ufl.dot(Q, ufl.grad(u)), ufl.grad(v)) * ufl.dx           # Σ_T |T| ∇φ_iᵀ Q̄_T ∇φ_j
    K = fem.assemble_matrix(fem.form(a))
    K.scatter_reverse()
    b = fem.assemble_vector(fem.form(code(problem.f_expr) * v * dx)).array
    n = V.dofmap.index_map.size_local
    K, b = K.to_scipy().tocsr()[:n, :n], b[:n]
    u_h = fem.Function(V)
    u_h.interpolate(lambda p: problem.u(p[0], p[1]))            # u at the nodes; kept on the boundary
    msh.topology.create_connectivity(msh.topology.dim - 1, msh.topology.dim)
    rim = fem.locate_dofs_topological(V, msh.topology.dim - 1, adapted.facet_tags.indices)
    free = np.setdiff1d(np.arange(n), rim)
    values = u_h.x.array
    values[free] = spla.spsolve(K[free][:, free].tocsc(), b[free] - K[free][:, rim] @ values[rim])
    error = np.sqrt(fem.assemble_scalar(fem.form((u_h - code(problem.u_expr)) ** 2 * dx)))
    return {"n_vertices": mesh.n_vertices, "error": float(error),
            "positive": solve_problems.positive_off_diagonals(K, free),
            "points": V.tabulate_dof_coordinates()[:n, :2].tolist(), "u": values[:n].tolist()}


def main(target_vertices: int = 1500) -> dict[str, dict]:
    results = {}
    for name, problem, mesh in solve_problems.meshed(target_vertices):
        results[name] = result = solve(mesh, problem)
        print(solve_problems.summary("DOLFINx", name, mesh.n_vertices, result["error"], result["positive"]))
    return results


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("target_vertices", type=int, nargs="?", default=1500)
    parser.add_argument("--json", type=Path, help="write each problem's result (points, u_h, error, checks) as JSON")
    args = parser.parse_args()
    results = main(args.target_vertices)
    if args.json:
        args.json.write_text(json.dumps(results))
