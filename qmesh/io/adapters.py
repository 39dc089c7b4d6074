"""A qmesh `Mesh` handed to a FEM code without a file: scikit-fem, DOLFINx, NGSolve.

Each adapter imports its FEM code only when called (none is a dependency of qmesh) and names
the boundary and the regions as the files do (`boundary.file_names`: plain identifiers, the
same names a `.msh` or `.vtu` gives the code's own reader).
"""

from __future__ import annotations

from types import ModuleType
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from qmesh.errors import QmeshError
from qmesh.io import boundary
from qmesh.triangle_mesh import Mesh


def _import(module: str, extra: str) -> ModuleType:
    try:
        return __import__(module, fromlist=["_"])
    except ImportError as e:
        raise QmeshError(f"{module} is not installed: pip install qmesh[{extra}] ({e})") from e


def _check(mesh: object) -> None:
    if not isinstance(mesh, Mesh):
        raise QmeshError(f"mesh must be a qmesh.Mesh, got {type(mesh).__name__}")


def _groups(mesh: Mesh) -> tuple[NDArray[np.int64], NDArray[np.int64], dict[int, str],
                                  NDArray[np.int64], dict[int, str]]:
    """(edges, tags, {tag: name}, regions, {region: name} or {} when the mesh has no regions)."""
    E, tags, tag_names = boundary.boundary_of(mesh)
    regions, region_names = boundary.regions_of(mesh)
    has_regions = bool(region_names) or bool(np.any(regions != 0))
    return (E, tags, boundary.file_names(tags, tag_names, "boundary"), regions,
            boundary.file_names(regions, region_names, "region") if has_regions else {})


def to_skfem(mesh: Mesh) -> Any:
    """A `skfem.MeshTri` (typed Any: scikit-fem is optional) with `boundaries` {name: facet indices} and, with regions,
    `subdomains` {name: triangle indices}."""
    _check(mesh)
    skfem = _import("skfem", "fem")
    E, tags, names, regions, region_names = _groups(mesh)
    plain = skfem.MeshTri(np.ascontiguousarray(mesh.points.T), np.ascontiguousarray(mesh.triangles.T))
    n = max(mesh.n_vertices, 1)
    key = boundary.edge_keys(plain.facets.T, n)
    order = np.argsort(key)
    found = order[np.searchsorted(key[order], boundary.edge_keys(E, n))]
    boundaries = {names[t]: np.sort(found[tags == t]) for t in names}
    subdomains = {region_names[r]: np.flatnonzero(regions == r) for r in region_names} or None
    return skfem.MeshTri(plain.p, plain.t, _boundaries=boundaries, _subdomains=subdomains)


class DolfinxMesh(NamedTuple):
    mesh: object            # dolfinx.mesh.Mesh
    facet_tags: object      # dolfinx.mesh.MeshTags of the boundary edges: the boundary tags
    cell_tags: object       # dolfinx.mesh.MeshTags of the triangles: the region tags
    names: dict[str, dict[int, str]]   # {"facets": {tag: name}, "cells": {region: name}}


def to_dolfinx(mesh: Mesh, comm: Any) -> DolfinxMesh:
    """A DOLFINx mesh (2-D geometry) on MPI communicator `comm` with its facet tags (the
    boundary tags) and cell tags (the region tags); rank 0 gives the data, DOLFINx distributes it."""
    _check(mesh)
    dmesh = _import("dolfinx.mesh", "fem-dolfinx")
    dio = _import("dolfinx.io", "fem-dolfinx")
    graph = _import("dolfinx.graph", "fem-dolfinx")
    basix_ufl = _import("basix.ufl", "fem-dolfinx")
    ufl = _import("ufl", "fem-dolfinx")
    E, tags, names, regions, region_names = _groups(mesh)
    root = comm.rank == 0
    T = np.ascontiguousarray(mesh.triangles if root else np.empty((0, 3)), dtype=np.int64)
    x = np.ascontiguousarray(mesh.points if root else np.empty((0, 2)), dtype=np.float64)
    element = ufl.Mesh(basix_ufl.element("Lagrange", "triangle", 1, shape=(2,)))
    msh = dmesh.create_mesh(comm, cells=T, x=x, e=element)  # keywords: 0.9 and 0.10 order them differently
    tagged = []
    for dim, cells, values in ((1, E, tags), (2, mesh.triangles, regions)):
        cells = cells if root else np.empty((0, dim + 1), np.int64)
        values = (values if root else np.empty(0)).astype(np.int32)
        local, local_values = dio.distribute_entity_data(msh, dim, cells.astype(np.int64), values)
        msh.topology.create_connectivity(dim, 0)
        tagged.append(dmesh.meshtags_from_entities(msh, dim, graph.adjacencylist(local),
                                                   local_values.astype(np.int32)))
    return DolfinxMesh(msh, tagged[0], tagged[1], {"facets": names, "cells": region_names})


def to_ngsolve(mesh: Mesh) -> Any:
    """An `ngsolve.Mesh` (typed Any: NGSolve is optional) whose boundaries carry the boundary names (bc index = tag order) and
    whose materials are the region names ("domain" without regions)."""
    _check(mesh)
    meshing = _import("netgen.meshing", "fem-ngsolve")
    ngsolve = _import("ngsolve", "fem-ngsolve")
    E, tags, names, regions, region_names = _groups(mesh)
    region_names = region_names or {0: "domain"}
    m = meshing.Mesh(dim=2)
    first = m.AddPoints(np.ascontiguousarray(mesh.points, dtype=np.float64))  # netgen numbers from 1
    base = int(first.nr) - 1 if hasattr(first, "nr") else 0
    for i, r in enumerate(sorted(region_names), start=1):
        m.Add(meshing.FaceDescriptor(surfnr=i, domin=i, bc=i))
        m.SetMaterial(i, region_names[r])
        cells = np.ascontiguousarray(mesh.triangles[regions == r] + base, dtype=np.int32)
        m.AddElements(dim=2, index=i, data=cells, base=0)
    for i, t in enumerate(sorted(names), start=1):
        m.SetBCName(i - 1, names[t])
        m.AddElements(dim=1, index=i, data=np.ascontiguousarray(E[tags == t] + base, dtype=np.int32), base=0)
    return ngsolve.Mesh(m)
