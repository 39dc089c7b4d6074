"""The qmesh API in ten lines: mesh the chapter's case, measure it, write it to a file.

Run: python examples/api_example.py [OUT.vtu]
"""
import sys

import qmesh
from qmesh import measure

anisotropy = qmesh.Anisotropy.constant([[0.1, 0.0], [0.0, 10.0]])   # Q = diag(0.1, 10) (2.95)
mesh = qmesh.mesh(qmesh.Disk(64), anisotropy, target_vertices=212, seed=0)
report = measure.report(mesh, anisotropy)
print(f"N = {mesh.n_vertices}, triangles = {mesh.n_triangles}, "
      f"min quality = {report['min_quality']:.3f}, kappa2 = {report['kappa2']:.3g} "
      f"(Laplacian on the same mesh: {report['kappa2_laplacian']:.3g})")
if len(sys.argv) > 1:
    import qmesh.io
    qmesh.io.write(sys.argv[1], mesh, anisotropy=anisotropy)   # format from the extension
# A Q-Delaunay mesh for a constant Q: every interior q_ij ≥ 0, the stiffness matrix is an M-matrix.
assert report["q_nonnegative_fraction"] == 1.0
