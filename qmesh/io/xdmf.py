"""qmesh's own XDMF writer and reader: one grid every client reads, the facet tags beside it.

`name.xdmf` holds one Grid, so that meshio (and scikit-fem through it) reads the file as well
as DOLFINx; its facet tags lie in `name_facets.xdmf`; each has its uncompressed HDF5 beside it,
`name.h5` and `name_facets.h5` (DOLFINx reads the HDF5 named after the .xdmf it opens, and its
wheels have no gzip):

- `name.xdmf`, Grid "mesh": Triangle topology, XY geometry (2-D points) and as Attributes the
  point data ("fixed", extras) and the cell data: "cell_tags" (the region tags); the named
  groups as scikit-fem encodes them in cell data, so that `skfem.Mesh.load` finds its
  `boundaries` and `subdomains` by name: "skfem:b:NAME" (per triangle, bit f set when the
  triangle's facet f, in scikit-fem's order of its sorted vertices, lies on that boundary) and
  "skfem:s:NAME" (1 in the region); "quality", the element means "Q11" "Q12" "Q22" when the
  mesh has them, extras. Its `<Information Name="qmesh" Value="{...}">` holds qmesh's metadata
  (names, conductivity), with meshio's empty field-data text. DOLFINx:
  `XDMFFile.read_mesh(name="mesh")` and `read_meshtags(mesh, name="mesh", attribute_name="cell_tags")`.
- `name_facets.xdmf`, Grid "facet_tags": the boundary edges (Polyline, 2 nodes), the mesh's
  geometry (a reference to `name.h5`, which DOLFINx does not need), Attribute "facet_tags"
  (the boundary tags). DOLFINx: `read_meshtags(mesh,
  name="facet_tags")` on an `XDMFFile` of that file.

`read` here gives a
meshio-like mesh of both files back for `qmesh.io.read`; it also reads the earlier layout with
grids "facet_tags" and "cell_tags" in the same file.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from qmesh.errors import QmeshError
from qmesh.io import metadata, sizes
from qmesh.io.meshio_writers import _meshio, optional

FACETS = "_facets"
"""`name.xdmf`'s facet tags are in `name` + FACETS + `.xdmf`."""


def _h5py():
    return optional("h5py", "XDMF files")


def h5_name(path: Path) -> Path:
    return path.with_suffix(".h5")


def facets_name(path: Path) -> Path:
    """The companion file of `path` that holds the facet tags."""
    path = Path(path)
    return path.with_name(path.stem + FACETS + path.suffix)


SKFEM = "skfem:"
"""The prefix of scikit-fem's named groups in cell data ("skfem:b:NAME", "skfem:s:NAME")."""


def skfem_groups(p) -> dict[str, np.ndarray]:
    """The boundaries and regions of Payload `p` as scikit-fem encodes them in cell data.

    scikit-fem's MeshTri sorts each triangle's vertices; its facet f of sorted vertices
    (s0, s1, s2) is (s0, s1), (s1, s2), (s0, s2) for f = 0, 1, 2."""
    T = np.sort(p.triangles, axis=1)
    n = max(len(p.points), 1)
    keys = np.stack([T[:, 0] * n + T[:, 1], T[:, 1] * n + T[:, 2], T[:, 0] * n + T[:, 2]], axis=1).ravel()
    order = np.argsort(keys, kind="stable")
    E = np.sort(p.edges, axis=1)
    at = order[np.searchsorted(keys[order], E[:, 0] * n + E[:, 1])] if len(E) else np.zeros(0, np.int64)
    out = {}
    for tag, name in p.tag_ids.items():
        code = np.zeros(len(T), np.int32)
        on = at[p.tags == tag]
        np.bitwise_or.at(code, on // 3, (1 << (on % 3)).astype(np.int32))
        out[f"{SKFEM}b:{name}"] = code
    for region, name in p.region_ids.items():
        out[f"{SKFEM}s:{name}"] = (p.regions == region).astype(np.int32)
    return out


def write(tmp: Path, final: Path, p) -> list[tuple[Path, Path]]:
    """Write Payload `p` to `tmp` (XML) and its facet tags beside it, each with a temporary HDF5;
    the XML refers to the HDF5 files by their final names. Returns the (temporary, final) pairs
    to rename; on an error, removes what it wrote."""
    h5py = _h5py()
    tmp_facets = facets_name(tmp)
    try:
        return _write(tmp, final, p, h5py)
    except BaseException:
        for part in (h5_name(tmp), h5_name(tmp_facets), tmp_facets, tmp):
            Path(part).unlink(missing_ok=True)
        raise


def _write(tmp: Path, final: Path, p, h5py) -> list[tuple[Path, Path]]:
    tmp_facets, final_facets = facets_name(tmp), facets_name(final)
    mesh_root, facets_root = ET.Element("Xdmf", Version="3.0"), ET.Element("Xdmf", Version="3.0")
    with h5py.File(h5_name(tmp), "w") as h5, h5py.File(h5_name(tmp_facets), "w") as h5_facets:
        def item(parent, key, a, number, into=h5, name=h5_name(final).name):
            if into is not None:
                into.create_dataset(key, data=a)  # no compression filter
            dims = " ".join(map(str, a.shape))
            el = ET.SubElement(parent, "DataItem", Dimensions=dims, NumberType=number, Format="HDF")
            el.set("Precision", str(a.dtype.itemsize))
            el.text = f"{name}:{key}"

        def kind(a):
            return "Int" if a.dtype.kind in "iub" else "Float"

        grid = ET.SubElement(ET.SubElement(mesh_root, "Domain"), "Grid", Name="mesh", GridType="Uniform")
        topo = ET.SubElement(grid, "Topology", TopologyType="Triangle", NumberOfElements=str(len(p.triangles)),
                             NodesPerElement="3")
        item(topo, "/Mesh/mesh/topology", p.triangles.astype(np.int64), "Int")
        geo = ET.SubElement(grid, "Geometry", GeometryType="XY")
        item(geo, "/Mesh/mesh/geometry", p.points.astype(np.float64), "Float")
        tags = {"cell_tags": p.regions.astype(np.int32), **skfem_groups(p)}
        for center, data in (("Node", {"fixed": p.fixed, **p.point_data}),
                             ("Cell", {**tags, **p.cell_data, **p.means})):
            for i, (name, a) in enumerate(data.items()):
                att = ET.SubElement(grid, "Attribute", Name=name, Center=center,
                                    AttributeType="Scalar" if a.ndim == 1 else "Vector" if a.shape[1] == 2 else "Matrix")
                key = "/MeshTags/cell_tags/Values" if name == "cell_tags" else f"/Data/{center}/{i}"
                item(att, key, a, kind(a))
        info = ET.SubElement(grid, "Information", Name=metadata.ATTRIBUTE, Value=p.meta)
        info.text = "<main/>"  # meshio reads an Information's text as field data: none

        grid = ET.SubElement(ET.SubElement(facets_root, "Domain"), "Grid", Name="facet_tags", GridType="Uniform")
        topo = ET.SubElement(grid, "Topology", TopologyType="Polyline", NumberOfElements=str(len(p.edges)),
                             NodesPerElement="2")
        facets_h5 = h5_name(final_facets).name   # DOLFINx reads the HDF5 named after the .xdmf
        item(topo, "/MeshTags/facet_tags/topology", p.edges.astype(np.int64), "Int", h5_facets, facets_h5)
        geo = ET.SubElement(grid, "Geometry", GeometryType="XY")   # for meshio: the mesh's own points
        item(geo, "/Mesh/mesh/geometry", p.points.astype(np.float64), "Float", None)
        att = ET.SubElement(grid, "Attribute", Name="facet_tags", AttributeType="Scalar", Center="Cell")
        item(att, "/MeshTags/facet_tags/Values", p.tags.astype(np.int32), "Int", h5_facets, facets_h5)
    for root, target in ((mesh_root, tmp), (facets_root, tmp_facets)):
        ET.indent(root)
        Path(target).write_text('<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n",
                                encoding="ascii")
    return [(h5_name(tmp), h5_name(final)), (h5_name(tmp_facets), h5_name(final_facets)),
            (tmp_facets, final_facets), (tmp, final)]


def _domain(path: Path):
    """The Domain element of an XDMF file, or None when it is not one."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, RecursionError, OSError, UnicodeDecodeError):
        return None
    return root.find("Domain")


def is_qmesh_layout(path: Path) -> bool:
    """True for the layout written here: a Grid named "mesh" with qmesh's Information in it, or
    beside further grids (the earlier layout)."""
    domain = _domain(path)
    if domain is None or domain.find("Grid[@Name='mesh']") is None:
        return False
    return (len(domain.findall("Grid")) > 1
            or domain.find(f"Grid[@Name='mesh']/Information[@Name='{metadata.ATTRIBUTE}']") is not None)


def read(path: Path):
    """A meshio.Mesh of the triangles, the tagged lines (from `name_facets.xdmf` when it lies
    beside the file) and the data of a qmesh-layout file. Every HDF5 dataset's declared size is
    checked against the mesh and the HDF5 file before it is read."""
    meshio = _meshio()
    source = repr(str(path))
    domain = _domain(path)
    if domain is None:
        raise QmeshError(f"{source} is not an XDMF file")
    grids = {g.get("Name"): g for g in domain.findall("Grid")}
    companion = facets_name(path)
    if "facet_tags" not in grids and companion.is_file():
        other = _domain(companion)
        if other is None:
            raise QmeshError(f"{str(companion)!r} is not an XDMF file")
        grids.update({g.get("Name"): g for g in other.findall("Grid") if g.get("Name") == "facet_tags"})
    h5py = _h5py()
    files = {}

    def data(parent, rows: int | None = None) -> np.ndarray:
        el = parent.find("DataItem") if parent is not None else None
        if el is None or el.get("Format") != "HDF" or ":" not in (el.text or ""):
            raise QmeshError(f"{source}: expected an HDF DataItem in {getattr(parent, 'tag', 'a grid')}")
        name, key = el.text.strip().split(":", 1)
        h5 = Path(path).parent / name
        if os.path.basename(name) != name:
            raise QmeshError(f"{source}: the HDF5 file {name!r} must lie beside the .xdmf")
        if h5 not in files:
            if not h5.is_file():
                raise QmeshError(f"{source}: its HDF5 file {str(h5)!r} does not exist")
            files[h5] = h5py.File(h5, "r")
        ds = sizes.dataset(path, files[h5], key, h5)   # its declared size against its file and the budget
        if rows is not None and (len(ds.shape) == 0 or ds.shape[0] != rows or ds.size > 9 * rows):
            raise QmeshError(f"{source}: dataset {key!r} has shape {ds.shape}, expected {rows} rows")
        return np.asarray(ds[()])

    try:
        mesh_grid = grids["mesh"]
        T = data(mesh_grid.find("Topology")).astype(np.int64)
        P = data(mesh_grid.find("Geometry")).astype(np.float64)
        T = T.reshape(-1, 3)
        point_data, cell_data = {}, {}
        cells = [meshio.CellBlock("triangle", T)]
        for att in mesh_grid.findall("Attribute"):
            name = att.get("Name")
            if name.startswith(SKFEM):
                continue  # the tags again, for scikit-fem
            if att.get("Center") == "Node":
                point_data[name] = data(att, len(P))
            else:
                cell_data["region" if name == "cell_tags" else name] = [data(att, len(T))]
        if "cell_tags" in grids:
            cell_data["region"] = [data(grids["cell_tags"].find("Attribute"), len(T)).ravel()]
        if "facet_tags" in grids:
            g = grids["facet_tags"]
            E = data(g.find("Topology")).astype(np.int64).reshape(-1, 2)
            cells.append(meshio.CellBlock("line", E))
            cell_data = {k: v + [np.zeros((len(E),) + v[0].shape[1:], v[0].dtype)] for k, v in cell_data.items()}
            cell_data["boundary_tag"] = [np.zeros(len(T), np.int32), data(g.find("Attribute"), len(E)).ravel()]
    finally:
        for f in files.values():
            f.close()
    return meshio.Mesh(P, cells, point_data=point_data, cell_data=cell_data)
