"""Solve −div(Q∇u) = f with scikit-fem on a qmesh mesh of a square with a hole.

Dirichlet u = g on the outline (boundary tag 1, "outline"), Neumann Q∇u·n = h on the hole
(tag 2, "hole"). The mesh goes through a .vtu file, read as written by `skfem.MeshTri.load`:
`qmesh.io.write` names the tags there (a FieldData block meshio reads), and scikit-fem turns
them into `mesh.boundaries["outline"]` and `["hole"]` (a .msh works the same way;
`qmesh.io.to_skfem(mesh)` skips the file). f, g and h come from a manufactured solution u, so
the error is known. The M-matrix check counts the stiffness matrix's positive off-diagonal
entries between free vertices: the Q-adapted mesh is built to have none.

The same problem is then solved on an isotropic mesh (qmesh with Q = I, the same target N),
and the unpreconditioned CG iteration counts are printed side by side: the stiffness matrix of
the Q-adapted mesh is much better conditioned (the chapter's Table 2.3, here on a holed domain).
The L2 error is printed too: the Q-adapted mesh is shaped for Q (and its s), not for this u,
and its error for this u is larger than the isotropic mesh's.

Run: python examples/holed_domain_fem.py [TARGET_VERTICES]      (needs qmesh[io,fem])
"""

import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla
import skfem
from skfem import BilinearForm, ElementTriP1, Functional, LinearForm

import qmesh
import qmesh.io

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fem_problem import positive_off_diagonals  # noqa: E402

Q = qmesh.Anisotropy.principal(1, 100, 30).matrix   # rotated, anisotropy 100
CG_RTOL = 1e-10


def exact(x, y):
    """The manufactured solution u."""
    return np.exp(0.5 * x) * np.sin(1.5 * y) + x * y


def exact_gradient(x, y):
    e = np.exp(0.5 * x)
    return np.array([0.5 * e * np.sin(1.5 * y) + y, 1.5 * e * np.cos(1.5 * y) + x])


def source(x, y):
    """f = −div(Q∇u) for the constant Q."""
    e = np.exp(0.5 * x)
    uxx, uxy, uyy = 0.25 * e * np.sin(1.5 * y), 0.75 * e * np.cos(1.5 * y) + 1.0, -2.25 * e * np.sin(1.5 * y)
    return -(Q[0, 0] * uxx + 2 * Q[0, 1] * uxy + Q[1, 1] * uyy)


@BilinearForm
def stiffness(u, v, w):
    """∫ Q∇u·∇v."""
    qx = Q[0, 0] * u.grad[0] + Q[0, 1] * u.grad[1]
    qy = Q[1, 0] * u.grad[0] + Q[1, 1] * u.grad[1]
    return qx * v.grad[0] + qy * v.grad[1]


@LinearForm
def load(v, w):
    return source(*w.x) * v


@LinearForm
def flux(v, w):
    """∫_hole (Q∇u·n) v, n the outward normal of the domain (into the hole)."""
    g = exact_gradient(*w.x)
    return ((Q[0, 0] * g[0] + Q[0, 1] * g[1]) * w.n[0] + (Q[1, 0] * g[0] + Q[1, 1] * g[1]) * w.n[1]) * v


@Functional
def squared_error(w):
    return (w["uh"] - exact(*w.x)) ** 2


@Functional
def squared_exact(w):
    return exact(*w.x) ** 2


def solve(mesh: qmesh.Mesh) -> dict:
    """Assemble and solve on `mesh` through a .vtu file; CG iterations, relative L2 error, residual."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "mesh.vtu"
        qmesh.io.write(path, mesh)
        fem_mesh = skfem.MeshTri.load(path)
    basis = skfem.Basis(fem_mesh, ElementTriP1())
    hole = skfem.FacetBasis(fem_mesh, ElementTriP1(), facets=fem_mesh.boundaries["hole"])
    A = stiffness.assemble(basis)
    b = load.assemble(basis) + flux.assemble(hole)
    dirichlet = basis.get_dofs(fem_mesh.boundaries["outline"])
    u = np.zeros(basis.N)
    u[dirichlet] = exact(*basis.doflocs[:, dirichlet])
    K, rhs, _, interior = skfem.condense(A, b, x=u, D=dirichlet)
    iterations = []
    u_interior, info = spla.cg(K, rhs, rtol=CG_RTOL, maxiter=50_000, callback=lambda _: iterations.append(1))
    u[interior] = u_interior
    error = np.sqrt(squared_error.assemble(basis, uh=basis.interpolate(u)) / squared_exact.assemble(basis))
    return {"n_vertices": mesh.n_vertices, "n_dirichlet": len(dirichlet),
            "n_hole_facets": len(fem_mesh.boundaries["hole"]), "n_hole_edges": int(np.sum(mesh.boundary_tags == 2)),
            "n_outline_vertices": len(np.unique(mesh.boundary_edges[mesh.boundary_tags == 1])),
            "cg_iterations": len(iterations), "cg_converged": info == 0,
            "positive_off_diagonals": positive_off_diagonals(A, interior),
            "relative_residual": float(np.linalg.norm(rhs - K @ u_interior) / np.linalg.norm(rhs)),
            "relative_l2_error": float(error)}


def main(target_vertices: int = 1000) -> dict:
    domain = qmesh.domains.square_with_hole()
    adapted = qmesh.mesh(domain, qmesh.Anisotropy.constant(Q), target_vertices=target_vertices, seed=0)
    # the same N: the Q-adapted mesh may land above its target (boundary vertices), so aim at its N
    isotropic = qmesh.mesh(domain, qmesh.Anisotropy.constant(np.eye(2)), target_vertices=adapted.n_vertices, seed=0)
    results = {"Q-adapted": solve(adapted), "isotropic (Q = I)": solve(isotropic)}
    print(f"-div(Q grad u) = f on a square with a hole, Q = [[{Q[0, 0]:.4g}, {Q[0, 1]:.4g}], "
          f"[{Q[1, 0]:.4g}, {Q[1, 1]:.4g}]]; Dirichlet on 'outline', Neumann on 'hole'")
    print(f"{'mesh':<18} {'N':>6} {'CG iterations':>14} {'rel. L2 error':>14} {'q_ij < 0':>9}")
    for name, r in results.items():
        print(f"{name:<18} {r['n_vertices']:>6} {r['cg_iterations']:>14} {r['relative_l2_error']:>14.2e} "
              f"{r['positive_off_diagonals']:>9}")
    for r in results.values():  # a sane solution on both meshes
        assert r["cg_converged"] and r["relative_residual"] < 1e-8, r
        assert r["relative_l2_error"] < 0.05, r
    return results


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1000)
