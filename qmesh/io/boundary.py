"""How each mesh file format carries the boundary edges, their tags and the tags' names.

A solver needs to know which boundary edge gets which condition (Dirichlet on the outline,
Neumann on a hole…): `Mesh.boundary_edges` (k, 2) and `Mesh.boundary_tags` (k,), with
`Mesh.tag_names` {tag: name}. In a file they are line cells next to the triangles:

- `.msh` (gmsh 4.1): one line block per tag, each its own curve entity whose physical tag is
  the boundary tag; named tags in $PhysicalNames (dimension 1); the triangles are physical
  surface 1 (named by the conductivity record, `qmesh.io.conductivity`). gmsh lists the
  nodes entity by entity, and meshio reads points in that order but node data in node-tag
  order; so the nodes are written sorted by entity (tags 1…N in that order, every reader
  agrees) with node data "qmesh:vertex", each node's index in the Mesh, which `read` uses
  to give the vertices back in their own order;
- `.vtu`, `.vtk`, `.xdmf`: one line block with the integer cell data "boundary_tag"
  (triangles get 0 there); names (.vtu, .xdmf only) as JSON in the root attribute
  `qmesh_tag_names`;
- `.mesh` (medit): edges whose reference is the tag (no names);
- `.obj`: triangles only; nothing of this is kept.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from qmesh.io import conductivity as file_conductivity
from qmesh.errors import QmeshError

TAG_DATA = "boundary_tag"
VERTEX_DATA = "qmesh:vertex"
NAMES_ATTRIBUTE = "qmesh_tag_names"
KEEPS_TAGS = {".vtu", ".vtk", ".msh", ".xdmf", ".mesh"}
KEEPS_NAMES = {".vtu", ".msh", ".xdmf"}
_TAG_KEY = {"vtu": TAG_DATA, "vtk": TAG_DATA, "xdmf": TAG_DATA, "gmsh": "gmsh:physical", "medit": "medit:ref"}


# --------------------------------------------------------------------------- from the mesh

def boundary_of(mesh) -> tuple[np.ndarray, np.ndarray, dict[int, str]]:
    """(edges, tags, names) of `mesh`, edges oriented with their triangle on the left.

    Tags default to 1 and names to {} for a Mesh that has none (meshes from other programs).
    """
    E = np.asarray(mesh.boundary_edges, dtype=np.int64).reshape(-1, 2)
    tags = getattr(mesh, "boundary_tags", None)
    tags = np.ones(len(E), np.int64) if tags is None else np.asarray(tags, dtype=np.int64)
    if tags.shape != (len(E),):
        raise QmeshError(f"mesh: boundary_tags has shape {tags.shape}, expected ({len(E)},)")
    if len(tags) and (tags.min() < 1 or tags.max() > np.iinfo(np.int32).max):
        raise QmeshError(f"mesh: boundary_tags must be integers from 1 to 2**31 - 1 (0 marks the triangles "
                         f"in files), got {tags.min()} to {tags.max()}")
    names = {int(k): str(v) for k, v in (getattr(mesh, "tag_names", None) or {}).items()}
    return _oriented(mesh.triangles, E, mesh.n_vertices), tags, names


def _oriented(T: np.ndarray, E: np.ndarray, n: int) -> np.ndarray:
    """Edges turned so each runs as in its (counter-clockwise) triangle: Ω on the left."""
    half = T.ravel() * np.int64(n) + T[:, [1, 2, 0]].ravel()
    backwards = ~np.isin(E[:, 0] * np.int64(n) + E[:, 1], half)
    E = E.copy()
    E[backwards] = E[backwards][:, ::-1]
    return E


def _filler(a: np.ndarray, k: int) -> np.ndarray:
    """Values for `k` line cells of a per-triangle data array: NaN for floats, 0 otherwise."""
    return np.full((k,) + a.shape[1:], np.nan if a.dtype.kind == "f" else 0, dtype=a.dtype)


def cells_for(fmt: str, mesh, cdata: dict, record: str | None):
    """meshio (cells, cell_data, extra point_data, field_data, order) for triangles and tagged edges.

    `cdata` is the per-triangle cell data; line cells get NaN (floats) or 0 there. `order` is
    None, or (gmsh) the Mesh vertex to write at each position: the caller writes
    points[order] and point data [order]; cells and the extra point data already follow it.
    """
    T = np.asarray(mesh.triangles)
    if fmt == "obj":
        return [("triangle", T)], {k: [v] for k, v in cdata.items()}, {}, {}, None
    E, tags, names = boundary_of(mesh)
    if fmt == "gmsh":
        return _gmsh_cells(mesh, T, E, tags, names, cdata, record)
    cells = [("triangle", T), ("line", E)]
    cell_data = {k: [v, _filler(v, len(E))] for k, v in cdata.items()}
    key = _TAG_KEY[fmt]
    cell_data[key] = [np.zeros(len(T), np.int32), tags.astype(np.int32)]
    return cells, cell_data, {}, {}, None


def _gmsh_cells(mesh, T, E, tags, names, cdata, record):
    """Triangles = surface entity 1; the edges of tag t = curve entity t, physical tag t."""
    dim_tags = _gmsh_node_entities(mesh.n_vertices, E, tags)
    order = np.lexsort((dim_tags[:, 1], dim_tags[:, 0]))  # meshio's block order, stable
    position = np.empty_like(order)
    position[order] = np.arange(len(order))
    T, E = position[T], position[E]
    curve_tags = np.unique(tags)
    blocks = [E[tags == t] for t in curve_tags]
    cells = [("triangle", T)] + [("line", b) for b in blocks]
    cell_data = {k: [v] + [_filler(v, len(b)) for b in blocks] for k, v in cdata.items()}
    entity = [np.ones(len(T), np.int32)] + [np.full(len(b), t, np.int32) for b, t in zip(blocks, curve_tags)]
    cell_data["gmsh:physical"] = entity
    cell_data["gmsh:geometrical"] = [e.copy() for e in entity]
    field_data = {}
    if record is not None:
        field_data.update(file_conductivity.gmsh_field_data(record, 1))
    for t, name in sorted(names.items()):
        if '"' in name or "\n" in name:
            raise QmeshError(f"mesh: tag_names[{t}] = {name!r}: a gmsh physical name cannot hold quotes or newlines")
        if name in field_data:
            raise QmeshError(f"mesh: tag_names gives the name {name!r} twice; gmsh physical names must differ")
        field_data[name] = np.array([t, 1])
    extra = {"gmsh:dim_tags": dim_tags[order], VERTEX_DATA: order.astype(np.float64)}
    return cells, cell_data, extra, field_data, order


def restore_gmsh_order(m) -> None:
    """Put the points of meshio mesh `m` (read from a qmesh .msh) back in the Mesh's order."""
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


def _gmsh_node_entities(n: int, E: np.ndarray, tags: np.ndarray) -> np.ndarray:
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
                         "its own, which meshio's gmsh writer needs; write .vtu instead")
    return dim_tags


def add_names_to_file(path: Path, fmt: str, names: dict[int, str]) -> None:
    """Tag names as JSON in the root element of a .vtu/.xdmf file (gmsh has them already)."""
    if names and fmt in ("vtu", "xdmf"):
        text = json.dumps({str(k): v for k, v in sorted(names.items())}, ensure_ascii=False)
        path.write_bytes(file_conductivity.set_root_attribute(path.read_bytes(), fmt, NAMES_ATTRIBUTE, text))


# --------------------------------------------------------------------------- from the file

def boundary_from(m, fmt: str, path: Path) -> tuple[np.ndarray, np.ndarray, dict[int, str]] | None:
    """(edges, tags, names) from the tagged line cells of meshio mesh `m`, or None if it has none.

    Edges index `m.points`. Line cells without a tag array (files from other programs that
    draw lines without tags) are ignored.
    """
    key = _TAG_KEY.get(fmt)
    tagged = m.cell_data.get(key) if key else None
    if tagged is None:
        return None
    E, tags = [], []
    for block, values in zip(m.cells, tagged):
        if block.type == "line":
            E.append(np.asarray(block.data, dtype=np.int64).reshape(-1, 2))
            tags.append(np.asarray(values, dtype=np.int64).ravel())
    if not E:
        return None
    E, tags = np.concatenate(E), np.concatenate(tags)
    if len(tags) != len(E):
        raise QmeshError(f"{str(path)!r}: {key} has {len(tags)} values for {len(E)} line cells")
    return E, tags, _names_from(m, fmt, path)


def tags_on(mesh, E: np.ndarray, tags: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The boundary edges of `mesh`'s triangles (Ω on the left) and the tag of the file's line
    cell on each (1 where the file has none, or a tag ≤ 0: gmsh's "no physical group").

    Line cells that are not boundary edges of the triangles are ignored.
    """
    n = np.int64(max(mesh.n_vertices, 1))
    B = np.asarray(mesh.boundary_edges)  # from the triangles, Ω on the left
    kb = np.minimum(B[:, 0], B[:, 1]) * n + np.maximum(B[:, 0], B[:, 1])
    kf = np.minimum(E[:, 0], E[:, 1]) * n + np.maximum(E[:, 0], E[:, 1])
    order = np.argsort(kf, kind="stable")
    pos = np.minimum(np.searchsorted(kf[order], kb), max(len(kf) - 1, 0))
    hit = (kf[order][pos] == kb) if len(kf) else np.zeros(len(kb), bool)
    out = np.ones(len(B), np.int64)
    out[hit] = tags[order[pos[hit]]]
    out[out <= 0] = 1
    return B, out


def _names_from(m, fmt: str, path: Path) -> dict[int, str]:
    if fmt == "gmsh":
        return {int(v[0]): str(k) for k, v in m.field_data.items()
                if len(np.ravel(v)) == 2 and int(np.ravel(v)[1]) == 1}
    if fmt in ("vtu", "xdmf"):
        text = file_conductivity.root_attribute(path, fmt, NAMES_ATTRIBUTE)
        if text is None:
            return {}
        try:
            return {int(k): str(v) for k, v in json.loads(text).items()}
        except (ValueError, AttributeError) as e:
            raise QmeshError(f"{str(path)!r}: unreadable {NAMES_ATTRIBUTE} {text!r}") from e
    return {}
