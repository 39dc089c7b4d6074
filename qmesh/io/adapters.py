"""A qmesh `Mesh` handed to a FEM code without a file: scikit-fem, DOLFINx, NGSolve.

Each adapter imports its FEM code only when called (none is a dependency of qmesh) and names
the boundary and the regions as the files do (`boundary.file_names`: plain identifiers, the
same names a `.msh` or `.vtu` gives the code's own reader).

A mesh made for a tensor field carries its element means Q̄_T (`Mesh.conductivity`), the
conductivity the P1 stiffness matrix K_ij = Σ_T |T| ∇φ_iᵀ Q̄_T ∇φ_j assembles exactly; each
adapter hands them over in its code's own form, so that the FEM code assembles what qmesh
certified: `to_skfem(mesh, with_means=True)` an element-wise array, `to_dolfinx` a DG0 tensor
Function "Q", `to_ngsolve(mesh, with_means=True)` a piecewise-constant 2×2 CoefficientFunction.
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


class SkfemMesh(NamedTuple):
    mesh: Any               # skfem.MeshTri
    conductivity: Any       # (2, 2, M, 1) element means, or None when the mesh has none


def to_skfem(mesh: Mesh, *, with_means: bool = False) -> Any:
    """A `skfem.MeshTri` (typed Any: scikit-fem is optional) with `boundaries` {name: facet indices} and, with regions,
    `subdomains` {name: triangle indices}; its element e is the Mesh's triangle e.

    With `with_means=True`, a `SkfemMesh(mesh, conductivity)`: the MeshTri and the element
    means as an array (2, 2, M, 1) (component, component, element, quadrature point: constant
    on each element), None when the Mesh has none. Passed to `assemble` as a keyword it
    reaches the form as `w.Q`::

        from skfem.helpers import dot, grad, mul
        m, Q = qmesh.io.to_skfem(mesh, with_means=True)
        basis = skfem.Basis(m, skfem.ElementTriP1())
        a = skfem.BilinearForm(lambda u, v, w: dot(mul(w.Q, grad(u)), grad(v)))
        K = a.assemble(basis, Q=Q)       # Σ_T |T| ∇φ_iᵀ Q̄_T ∇φ_j
    """
    _check(mesh)
    m = _skfem_mesh(mesh)
    if not with_means:
        return m
    Q = None if mesh.conductivity is None else np.ascontiguousarray(np.transpose(mesh.conductivity, (1, 2, 0)))[..., None]
    return SkfemMesh(m, Q)


def _skfem_mesh(mesh: Mesh) -> Any:
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
    conductivity: object = None        # DG0 tensor Function "Q" (shape (2, 2)): the element means, or None


def _dolfinx_first() -> None:
    """DOLFINx's PyPI wheels (dolfinx-solver-real/-complex) load their MPI library when the
    package `dolfinx_solver` is imported, before `dolfinx`; other installs have no such package."""
    try:
        __import__("dolfinx_solver")
    except ImportError:
        pass


def to_dolfinx(mesh: Mesh, comm: Any) -> DolfinxMesh:
    """A DOLFINx mesh (2-D geometry) on MPI communicator `comm` with its facet tags (the
    boundary tags) and cell tags (the region tags); rank 0 gives the data, DOLFINx distributes it.

    When the Mesh has element means, `conductivity` is a DG0 tensor Function "Q" of shape
    (2, 2) holding Q̄_T on each cell (every rank gets the means of its own cells)::

        Q = adapted.conductivity
        a = ufl.inner(ufl.dot(Q, ufl.grad(u)), ufl.grad(v)) * ufl.dx   # Σ_T |T| ∇φ_iᵀ Q̄_T ∇φ_j
    """
    _check(mesh)
    _dolfinx_first()
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
    Q = None
    has_means = comm.bcast(mesh.conductivity is not None if root else None, root=0)
    if has_means:
        Q = dolfinx_means(msh, comm.bcast(np.asarray(mesh.conductivity) if root else None, root=0))
    return DolfinxMesh(msh, tagged[0], tagged[1], {"facets": names, "cells": region_names}, Q)


def dolfinx_means(msh: Any, means: NDArray[np.float64]) -> Any:
    """The DG0 tensor Function "Q" (shape (2, 2)) on DOLFINx mesh `msh` whose value on each cell
    is `means[i]`, i the cell's index in the input (`topology.original_cell_index`)."""
    fem = _import("dolfinx.fem", "fem-dolfinx")
    V = fem.functionspace(msh, ("DG", 0, (2, 2)))
    Q = fem.Function(V, name="Q")
    n = msh.topology.index_map(msh.topology.dim).size_local
    original = np.asarray(msh.topology.original_cell_index)[:n]
    dofs = np.array([V.dofmap.cell_dofs(c)[0] for c in range(n)], dtype=np.int64)
    bs = V.dofmap.index_map_bs
    values = Q.x.array.reshape(-1, bs)
    values[dofs] = np.asarray(means, dtype=np.float64)[original].reshape(n, 4)   # row-major: Q[i, j] at 2i + j
    Q.x.scatter_forward()
    return Q


class NgsolveMesh(NamedTuple):
    mesh: Any               # ngsolve.Mesh
    conductivity: Any       # 2×2 CoefficientFunction of L2(order=0) GridFunctions, or None


def to_ngsolve(mesh: Mesh, *, with_means: bool = False) -> Any:
    """An `ngsolve.Mesh` (typed Any: NGSolve is optional) whose boundaries carry the boundary names (bc index = tag order) and
    whose materials are the region names ("domain" without regions).

    With `with_means=True`, an `NgsolveMesh(mesh, conductivity)`: the mesh and the element
    means as a 2×2 CoefficientFunction built from three L2(order=0) GridFunctions (Q11, Q12,
    Q22: one value per element), None when the Mesh has none::

        m, Q = qmesh.io.to_ngsolve(mesh, with_means=True)
        a += (Q * ngsolve.grad(u)) * ngsolve.grad(v) * ngsolve.dx    # Σ_T |T| ∇φ_iᵀ Q̄_T ∇φ_j
    """
    m = _ngsolve_mesh(mesh)
    if not with_means:
        return m
    return NgsolveMesh(m, None if mesh.conductivity is None else ngsolve_means(m, mesh))


def ngsolve_means(m: Any, mesh: Mesh) -> Any:
    """The element means of `mesh` on `m = to_ngsolve(mesh)` as a 2×2 CoefficientFunction."""
    ngsolve = _import("ngsolve", "fem-ngsolve")
    assert mesh.conductivity is not None
    _, _, _, regions, region_names = _groups(mesh)
    order = np.concatenate([np.flatnonzero(regions == r) for r in sorted(region_names or {0: "domain"})])
    # ^ the elements in the order `to_ngsolve` adds them: region by region
    V = ngsolve.L2(m, order=0)
    dofs = np.array([V.GetDofNrs(ngsolve.ElementId(ngsolve.VOL, e))[0] for e in range(m.ne)], dtype=np.int64)
    parts = []
    for i, j in ((0, 0), (0, 1), (1, 1)):
        gf = ngsolve.GridFunction(V)
        values = np.zeros(V.ndof)
        values[dofs] = mesh.conductivity[order, i, j]
        gf.vec.FV().NumPy()[:] = values
        parts.append(gf)
    q11, q12, q22 = parts
    return ngsolve.CoefficientFunction((q11, q12, q12, q22), dims=(2, 2))


def _ngsolve_mesh(mesh: Mesh) -> Any:
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
