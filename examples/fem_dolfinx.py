"""Solve −div(Q∇u) = 1 with DOLFINx on a qmesh mesh read by DOLFINx's own XDMF reader.

qmesh writes the holed plate (`fem_problem.py`) as `plate.xdmf`, one grid "mesh" with 2-D points
and the region tags as its attribute "cell_tags", and its facet tags in `plate_facets.xdmf`
(grid "facet_tags"), each with uncompressed HDF5 beside it; `XDMFFile.read_mesh` and
`read_meshtags` read them as written. The tag of "wall" comes from the names qmesh stored;
u = 0 there (Dirichlet), natural on "hole". Q comes from `Anisotropy.matrix`. The M-matrix
check counts the positive off-diagonal entries of the assembled stiffness matrix between free
dofs. (`qmesh.io.to_dolfinx(mesh, comm)` gives the same mesh and tags without a file.)

DOLFINx's wheels need Python >= 3.12: `python3.12 -m venv .venv-dolfinx &&
. .venv-dolfinx/bin/activate && pip install -e ".[fem-dolfinx]"`. The wheel's package
`dolfinx_solver` loads its MPI library and is imported before `dolfinx`.

Run: python examples/fem_dolfinx.py [TARGET_VERTICES] [--out DIR] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla

sys.path.insert(0, str(Path(__file__).resolve().parent))
import fem_problem  # noqa: E402

import qmesh.io  # noqa: E402


def solve(path) -> dict:
    """Read the .xdmf at `path` with DOLFINx, solve, and return u at the dofs' points and the checks."""
    try:
        import dolfinx_solver  # noqa: F401 - PyPI's DOLFINx: loads MPI before dolfinx
    except ImportError:
        pass
    import ufl
    from dolfinx import default_scalar_type, fem
    from dolfinx import io as dio
    from mpi4py import MPI

    path = Path(path)
    with dio.XDMFFile(MPI.COMM_WORLD, str(path), "r") as xdmf:
        msh = xdmf.read_mesh(name="mesh")
        msh.topology.create_connectivity(msh.topology.dim - 1, msh.topology.dim)
    with dio.XDMFFile(MPI.COMM_WORLD, str(path.with_name(path.stem + "_facets.xdmf")), "r") as xdmf:
        facets = xdmf.read_meshtags(msh, name="facet_tags")
    names = qmesh.io.read_names(path)[0]          # {tag: name} as the user gave them (no h5py needed)
    wall = next(t for t, name in names.items() if name == "wall")

    V = fem.functionspace(msh, ("Lagrange", 1))
    Q = fem.Constant(msh, np.asarray(fem_problem.ANISOTROPY.matrix, dtype=default_scalar_type))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    a = fem.form(ufl.inner(ufl.dot(Q, ufl.grad(u)), ufl.grad(v)) * ufl.dx)
    L = fem.form(fem.Constant(msh, default_scalar_type(1.0)) * v * ufl.dx)
    K = fem.assemble_matrix(a)
    K.scatter_reverse()
    K = K.to_scipy()
    b = fem.assemble_vector(L).array
    n = V.dofmap.index_map.size_local
    K, b = K.tocsr()[:n, :n], b[:n]
    dirichlet = fem.locate_dofs_topological(V, msh.topology.dim - 1, facets.find(wall))
    free = np.setdiff1d(np.arange(n), dirichlet)
    uh = np.zeros(n)
    uh[free] = spla.spsolve(K[free][:, free].tocsc(), b[free])
    return {"points": V.tabulate_dof_coordinates()[:n, :2].tolist(), "u": uh.tolist(),
            "facet_tags": sorted(set(np.asarray(facets.values).tolist())), "names": names,
            "gdim": msh.geometry.dim, "positive_off_diagonals": fem_problem.positive_off_diagonals(K, free)}


def main(target_vertices: int = 1500, out: Path | None = None) -> dict:
    mesh = fem_problem.make_mesh(target_vertices)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(out or folder) / "plate.xdmf"
        qmesh.io.write(path, mesh, anisotropy=fem_problem.ANISOTROPY)
        result = solve(path)
    from mpi4py import MPI
    adapted = qmesh.io.to_dolfinx(mesh, MPI.COMM_WORLD)      # the same mesh without a file
    result["adapter"] = {"cells": int(adapted.mesh.topology.index_map(2).size_local),
                         "facet_tags": np.bincount(adapted.facet_tags.values).tolist(),
                         "names": {str(k): v for k, v in adapted.names["facets"].items()}}
    result["expected"] = {"cells": mesh.n_triangles, "facet_tags": np.bincount(mesh.boundary_tags).tolist()}
    print(f"DOLFINx: N={len(result['u'])} gdim={result['gdim']} facet tags={result['facet_tags']} "
          f"max u={max(result['u']):.6g} positive off-diagonals={result['positive_off_diagonals']}")
    return result


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("target_vertices", type=int, nargs="?", default=1500)
    parser.add_argument("--out", type=Path, help="keep plate.xdmf, plate_facets.xdmf and their .h5 in this folder")
    parser.add_argument("--json", type=Path, help="write the result (points, u, checks) as JSON")
    args = parser.parse_args()
    result = main(args.target_vertices, args.out)
    if args.json:
        args.json.write_text(json.dumps({**result, "names": {str(k): v for k, v in result["names"].items()}}))
