"""Run in DOLFINx's venv (`dolfinx_env`): read a qmesh `.xdmf` with DOLFINx's own reader (the
mesh, the cell tags from its grid, the facet tags from `name_facets.xdmf`), make the element
means a DG0 tensor Function "Q" (`qmesh.io.adapters.dolfinx_means` on the means `qmesh.io.read`
finds in the file), assemble a(u, v) = ∫ Q∇u·∇v, and do the same on `qmesh.io.to_dolfinx` of
the Mesh read back. Writes, in the file's own numbering (vertex i = point i, cell i = triangle
i), both stiffness matrices as triplets, the cell tags and the tagged facets, to a JSON file.

Usage: python dolfinx_means_check.py PATH.xdmf OUT.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

import qmesh.io
from qmesh.io.adapters import _dolfinx_first, dolfinx_means
from qmesh.io.xdmf import facets_name

_dolfinx_first()
import ufl  # noqa: E402
from dolfinx import fem  # noqa: E402
from dolfinx import io as dio  # noqa: E402
from mpi4py import MPI  # noqa: E402


def _geometry_dofmap(msh) -> np.ndarray:
    dofmaps = getattr(msh.geometry, "dofmaps", None)          # DOLFINx 0.10+: one per cell type
    return np.asarray(dofmaps(0) if callable(dofmaps) else dofmaps[0] if dofmaps is not None else msh.geometry.dofmap)


def vertex_to_input(msh) -> np.ndarray:
    """The input index (the file's point) of each topology vertex of `msh`."""
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim, 0)
    c2v = msh.topology.connectivity(tdim, 0)
    n_cells = msh.topology.index_map(tdim).size_local + msh.topology.index_map(tdim).num_ghosts
    cells_v = np.array([c2v.links(c) for c in range(n_cells)], dtype=np.int64)
    nodes = _geometry_dofmap(msh)[:n_cells]
    out = np.empty(msh.topology.index_map(0).size_local + msh.topology.index_map(0).num_ghosts, np.int64)
    out[cells_v.ravel()] = np.asarray(msh.geometry.input_global_indices)[nodes.ravel()]
    return out


def stiffness(msh, Q) -> dict:
    """K of ∫ Q∇u·∇v on P1 as triplets in the input vertex numbering."""
    V = fem.functionspace(msh, ("Lagrange", 1))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    K = fem.assemble_matrix(fem.form(ufl.inner(ufl.dot(Q, ufl.grad(u)), ufl.grad(v)) * ufl.dx))
    K.scatter_reverse()
    K = K.to_scipy().tocoo()
    nodes = _geometry_dofmap(msh)
    dofs = np.asarray(V.dofmap.list)
    to_input = np.empty(V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts, np.int64)
    to_input[dofs.ravel()] = np.asarray(msh.geometry.input_global_indices)[nodes.ravel()]
    return {"rows": to_input[K.row].tolist(), "cols": to_input[K.col].tolist(), "vals": K.data.tolist()}


def main(path: Path, out: Path) -> None:
    comm = MPI.COMM_WORLD
    with dio.XDMFFile(comm, str(path), "r") as xdmf:
        msh = xdmf.read_mesh(name="mesh")
        msh.topology.create_connectivity(msh.topology.dim - 1, msh.topology.dim)
        cell_tags = xdmf.read_meshtags(msh, name="mesh", attribute_name="cell_tags")
    with dio.XDMFFile(comm, str(facets_name(path)), "r") as xdmf:
        facet_tags = xdmf.read_meshtags(msh, name="facet_tags")
    mesh = qmesh.io.read(path)
    result = {"file": stiffness(msh, dolfinx_means(msh, mesh.conductivity)),
              "cells": np.asarray(msh.topology.original_cell_index)[cell_tags.indices].tolist(),
              "cell_values": np.asarray(cell_tags.values).tolist()}
    msh.topology.create_connectivity(1, 0)
    f2v = msh.topology.connectivity(1, 0)
    to_input = vertex_to_input(msh)
    result["facets"] = [sorted(to_input[f2v.links(f)].tolist()) for f in facet_tags.indices]
    result["facet_values"] = np.asarray(facet_tags.values).tolist()

    adapted = qmesh.io.to_dolfinx(mesh, comm)
    result["adapter"] = stiffness(adapted.mesh, adapted.conductivity)
    result["adapter_value_shape"] = list(adapted.conductivity.ufl_shape)
    result["adapter_name"] = adapted.conductivity.name
    out.write_text(json.dumps(result))


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))
