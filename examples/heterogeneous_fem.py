"""FVCA5 test 4, the vertical fault, solved with scikit-fem on a qmesh mesh with regions.

The unit square in horizontal strips 0.1 high of K2 = diag(1e2, 1e1) and K1 = diag(1e-2, 1e-3),
offset by 0.05 across the fault x = 0.5, with u = 1 − x on the boundary and no source
(Herbin & Hubert 2008, test 4: `qmesh.domain.media_cases.fvca4`, which cites its sources). The
solution of −div(K∇u) = 0 satisfies the maximum principle, 0 ≤ u ≤ 1; the P1 solution keeps it
when the stiffness matrix is an M-matrix, i.e. every q_ij ≥ 0 — interface edges included, each
side in its own region's K. The same problem is solved on an isotropic Triangle mesh of the
same N (regions as segments), and the vertices outside [0, 1] are counted on both.

Run: python examples/heterogeneous_fem.py [TARGET_VERTICES]      (needs qmesh[fem,compare])
"""

import sys
import warnings

import numpy as np
import skfem
from skfem import BilinearForm, ElementTriP1

import qmesh
from qmesh.compare import media_peers as peers
from qmesh.domain import media_cases as cases


@BilinearForm
def stiffness(u, v, w):
    """∫ K∇u·∇v with K constant on each triangle (w.k11, w.k12, w.k22)."""
    return ((w.k11 * u.grad[0] + w.k12 * u.grad[1]) * v.grad[0]
            + (w.k12 * u.grad[0] + w.k22 * u.grad[1]) * v.grad[1])


def solve(mesh: qmesh.Mesh, conductivity: dict, g) -> np.ndarray:
    """The P1 solution with scikit-fem, K per triangle from its region."""
    m = skfem.MeshTri(mesh.points.T.copy(), mesh.triangles.T.copy())
    basis = skfem.Basis(m, ElementTriP1())
    K = np.stack([conductivity[int(r)].Q(np.zeros((1, 2)))[0] for r in mesh.region_tags])
    nqp = basis.X.shape[1]
    coeff = {name: np.repeat(K[:, i, j][:, None], nqp, axis=1)
             for name, (i, j) in (("k11", (0, 0)), ("k12", (0, 1)), ("k22", (1, 1)))}
    A = stiffness.assemble(basis, **coeff)
    D = m.boundary_nodes()
    x = np.zeros(m.nvertices)
    x[D] = g(*m.p[:, D])
    return skfem.solve(*skfem.condense(A, x=x, D=D))


def outside(u, lo=0.0, hi=1.0, tol=1e-10) -> tuple[int, float]:
    """Vertices outside [lo, hi] (beyond tol), and the worst excess."""
    excess = np.maximum(u - hi, lo - u)
    return int(np.sum(excess > tol)), float(max(excess.max(), 0.0))


def main(n: int = 2000) -> dict:
    domain, conductivity, g = cases.fvca4()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        adapted = qmesh.mesh(domain, conductivity, target_vertices=n)
    iso = peers.triangle(domain, adapted.n_vertices).mesh
    results = {}
    for name, m in (("qmesh", adapted), ("Triangle (isotropic)", iso)):
        r = qmesh.measure.report(m, conductivity)
        bad, worst = outside(solve(m, conductivity, g))
        results[name] = (m.n_vertices, bad, worst, r["q_nonnegative_fraction"],
                         r.get("q_nonnegative_fraction_interface"), r["q_nonnegative_fraction_boundary"])
    print("mesh                  N      outside [0, 1]  worst     q_ij>=0 interior/interface/boundary")
    for name, (N, bad, worst, qi, qf, qb) in results.items():
        print(f"{name:<20s} {N:6d}  {bad:8d}        {worst:.1e}   "
              f"{100 * qi:.1f}% / {100 * qf:.1f}% / {100 * qb:.1f}%")
    return results


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 2000)
