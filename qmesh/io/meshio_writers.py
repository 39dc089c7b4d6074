"""Writers that lay a Payload out as meshio cells and let meshio write the file (a large
.vtu: vtu_raw.py).

- `.vtu`, `.vtk`: triangles then one line block (int32 indices; a `.vtu` zlib-compressed up
  to ZLIB_MAX vertices, uncompressed beyond, and then in meshio's layout by `vtu_raw`); integer
  cell data "boundary_tag" (lines: the tag, triangles 0), "region" (triangles: the region tag,
  lines 0) and "gmsh:physical" (both in gmsh numbering, `Payload.cell_tags`); `.vtu` also gets
  a `<FieldData>` block {identifier: [tag, dim]}, which meshio reads as `field_data`, so that
  scikit-fem's `MeshTri.load` names `boundaries` and `subdomains` by it; the element means
  (`Mesh.conductivity`), when the mesh has them, as float cell data "Q11" "Q12" "Q22"
  (triangles: Q̄_T; lines 0);
- medit `.mesh`: 2-D points; references: vertices the fixed flag, edges the boundary tag,
  triangles the region tag;
- `.obj`: triangles only;
- `.msh` in gmsh 4.1 (binary, on request): one curve entity per boundary tag, the triangles
  one surface entity; regions as element data "region", the element means as element data
  "Q11" "Q12" "Q22" (see `_gmsh41`).

Each returns the (temporary, final) files written.
"""

from __future__ import annotations

import importlib

from pathlib import Path

import numpy as np

from qmesh.errors import QmeshError
from qmesh.io import metadata
from qmesh.io.boundary import filler

VERTEX_DATA = "qmesh:vertex"
ZLIB_MAX = 200_000      # .vtu of more vertices are written uncompressed: beyond, zlib's time is a
                        # large share of a `qmesh mesh` run (at 1e6 vertices: 49 MB compressed, 155 MB not)
                        # and by qmesh itself (vtu_raw.py: about half meshio's time, in one pass)
RAW_MAX = 2**32 // 24   # vtu_raw's byte counts are UInt32, as meshio's: points (N, 3) float64 fit


def optional(module: str, what: str):
    """The optional package `module` (an extra of qmesh[io]), or QmeshError saying `what` needs it."""
    try:
        return importlib.import_module(module)
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise QmeshError(f"{what} needs {module}: pip install qmesh[io]") from e


def _meshio():
    return optional("meshio", "reading and writing mesh files")


def _xyz(P):
    return np.column_stack([P, np.zeros(len(P))])


def vtk_family(fmt: str):
    def write(tmp: Path, final: Path, p):
        meshio = _meshio()
        k = len(p.edges)
        cell_data = {name: [a, filler(a, k)] for name, a in {**p.cell_data, **p.means}.items()}
        cell_data["boundary_tag"] = [np.zeros(len(p.triangles), np.int32), p.tags.astype(np.int32)]
        cell_data["region"] = [p.regions.astype(np.int32), np.zeros(k, np.int32)]
        cell_data["gmsh:physical"] = [p.cell_tags, p.tags.astype(np.int32)]
        if fmt == "vtu" and ZLIB_MAX < len(p.points) <= RAW_MAX:
            from qmesh.io import vtu_raw      # here: it imports xml's quoting, which imports urllib
            vtu_raw.write(tmp, _xyz(p.points), _compact(p.triangles), _compact(p.edges),
                          {"fixed": p.fixed, **p.point_data}, cell_data, p.meta,
                          _field_data(p.field_data()))
            return [(tmp, final)]
        m = meshio.Mesh(_xyz(p.points), [("triangle", _compact(p.triangles)), ("line", _compact(p.edges))],
                        point_data={"fixed": p.fixed, **p.point_data}, cell_data=cell_data)
        if fmt == "vtu":
            meshio.vtu.write(tmp, m, compression="zlib" if len(p.points) <= ZLIB_MAX else None)
        else:
            meshio.vtk.write(tmp, m)
        # the field data and the metadata in one pass over the file (155 MB at 1e6 vertices)
        metadata.add(tmp, "root" if fmt == "vtu" else "title", p.meta,
                     _field_data_edit(p.field_data()) if fmt == "vtu" else None)
        return [(tmp, final)]
    return write


def _compact(cells: np.ndarray) -> np.ndarray:
    """Vertex indices as int32 where they fit: half the bytes to encode and to read."""
    return cells.astype(np.int32) if cells.size == 0 or cells.max() < 2**31 - 1 else cells


def _field_data(groups: dict) -> str:
    """A VTK `<FieldData>` block {name: [tag, dim]}."""
    from xml.sax.saxutils import quoteattr        # here: it imports urllib and http; VTK files only
    arrays = "".join(f'<DataArray type="Int32" Name={quoteattr(name)} NumberOfTuples="2" '
                     f'format="ascii">{v[0]} {v[1]}</DataArray>'
                     for name, v in groups.items())
    return f"<FieldData>{arrays}</FieldData>"


def _field_data_edit(groups: dict):
    """The edit (bytes → bytes) that puts a VTK `<FieldData>` block {name: [tag, dim]} as the
    UnstructuredGrid's first child."""
    block = _field_data(groups).encode("ascii")

    def insert(data: bytes) -> bytes:
        start = data.index(b"<UnstructuredGrid")
        end = data.index(b">", start) + 1
        return data[:end] + block + data[end:]
    return insert


def medit(tmp: Path, final: Path, p):
    meshio = _meshio()
    m = meshio.Mesh(p.points, [("triangle", p.triangles), ("line", p.edges)],
                    point_data={"medit:ref": p.fixed},
                    cell_data={"medit:ref": [p.regions.astype(np.int32), p.tags.astype(np.int32)]})
    meshio.medit.write(tmp, m)
    metadata.add(tmp, "comment", p.meta)
    return [(tmp, final)]


def obj(tmp: Path, final: Path, p):
    meshio = _meshio()
    meshio.obj.write(tmp, meshio.Mesh(_xyz(p.points), [("triangle", p.triangles)]))
    metadata.add(tmp, "comment", p.meta)
    return [(tmp, final)]


# --------------------------------------------------------------------------- gmsh 4.1

def gmsh41(tmp: Path, final: Path, p):
    """gmsh 4.1 binary through meshio. meshio lists nodes entity by entity and reads points in
    that order but node data in node-tag order; so nodes are written sorted by entity with node
    data "qmesh:vertex" (each node's index in the Mesh), which `restore_order` undoes."""
    meshio = _meshio()
    E, tags, T = p.edges, p.tags, p.triangles
    dim_tags = _node_entities(len(p.points), E, tags)
    order = np.lexsort((dim_tags[:, 1], dim_tags[:, 0]))  # meshio's block order, stable
    position = np.empty_like(order)
    position[order] = np.arange(len(order))
    T, E = position[T], position[E]
    curve_tags = np.unique(tags)
    blocks = [E[tags == t] for t in curve_tags]
    cdata = {**p.cell_data, **p.means, "region": p.regions.astype(np.int32)}
    cell_data = {k: [v] + [filler(v, len(b)) for b in blocks] for k, v in cdata.items()}
    curves = [np.full(len(b), t, np.int32) for b, t in zip(blocks, curve_tags)]
    surface = int(p.cell_tags[0]) if len(T) else 1  # one surface entity: the regions travel as data
    cell_data["gmsh:physical"] = [np.full(len(T), surface, np.int32)] + curves
    cell_data["gmsh:geometrical"] = [np.ones(len(T), np.int32)] + [c.copy() for c in curves]
    groups = {name: np.array([t, 1]) for t, name in p.tag_ids.items()}
    point_data = {"fixed": p.fixed[order], **{k: v[order] for k, v in p.point_data.items()},
                  "gmsh:dim_tags": dim_tags[order], VERTEX_DATA: order.astype(np.float64)}
    m = meshio.Mesh(_xyz(p.points)[order], [("triangle", T)] + [("line", b) for b in blocks],
                    point_data=point_data, cell_data=cell_data, field_data=groups)
    meshio.gmsh.write(tmp, m, fmt_version="4.1", binary=True)
    metadata.add(tmp, "section", p.meta)
    return [(tmp, final)]


def restore_order(m) -> None:
    """Put the points of meshio mesh `m` (read from a qmesh gmsh 4.1 file) back in the Mesh's order."""
    order = m.point_data.pop(VERTEX_DATA, None)
    if order is None:
        return
    order = np.asarray(order).ravel()
    n = len(m.points)
    as_int = order.astype(np.int64) if np.all(np.isfinite(order)) else None
    if as_int is None or len(order) != n or not np.array_equal(np.sort(as_int), np.arange(n)):
        return  # not a permutation: leave the file's own order
    position = np.empty(n, np.int64)
    position[as_int] = np.arange(n)
    m.points = m.points[position]
    for name in list(m.point_data):
        m.point_data[name] = np.asarray(m.point_data[name])[position]
    for block in m.cells:
        block.data = as_int[block.data]


def _node_entities(n: int, E: np.ndarray, tags: np.ndarray) -> np.ndarray:
    """(dim, entity) of every node: meshio writes an entity only when some node lies on it.

    Interior nodes lie on the surface (2, 1); a boundary node on the curve (1, t) of the edge
    it starts. A surface without interior node takes one from the curve that has the most.
    """
    dim_tags = np.tile(np.array([2, 1], np.int64), (n, 1))
    dim_tags[E[:, 0]] = np.column_stack([np.ones(len(E), np.int64), tags])
    on_surface = dim_tags[:, 0] == 2
    if len(E) and not on_surface.any():
        curve_tags, counts = np.unique(dim_tags[:, 1], return_counts=True)
        if counts.max() > 1:
            dim_tags[np.flatnonzero(dim_tags[:, 1] == curve_tags[counts.argmax()])[0]] = (2, 1)
    owned = set(dim_tags[dim_tags[:, 0] == 1, 1].tolist())
    if set(tags.tolist()) - owned or not (dim_tags[:, 0] == 2).any():
        raise QmeshError("mesh: too few vertices to give the surface and every boundary tag a vertex of "
                         "its own, which meshio's gmsh 4.1 writer needs; write gmsh 2.2 or .vtu instead")
    return dim_tags
