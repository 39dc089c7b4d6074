"""qmesh's own XDMF writer and reader, in the layout DOLFINx reads.

`name.xdmf` (XML) and `name.h5` (uncompressed HDF5 beside it: DOLFINx's wheels have no gzip):

- Grid "mesh": Triangle topology, XY geometry (2-D points), and as Attributes the point data
  ("fixed", extras) and cell data ("quality", extras): `XDMFFile.read_mesh(name="mesh")`;
- Grid "facet_tags": the boundary edges (PolyLine, 2 nodes) with Attribute "facet_tags", the
  boundary tags: `read_meshtags(mesh, name="facet_tags")`;
- Grid "cell_tags": the triangles with Attribute "cell_tags", the region tags:
  `read_meshtags(mesh, name="cell_tags")`;
- `<Information Name="qmesh" Value="{...}">`: qmesh's metadata (names, conductivity).

meshio reads one grid per file only, so it cannot read these files (a foreign single-grid
.xdmf is read through meshio); `read` here gives a meshio-like mesh back for `qmesh.io.read`.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from qmesh.errors import QmeshError
from qmesh.io import metadata
from qmesh.io.meshio_writers import _meshio, optional

XINCLUDE = "http://www.w3.org/2001/XInclude"


def _h5py():
    return optional("h5py", "XDMF files")


def h5_name(path: Path) -> Path:
    return path.with_suffix(".h5")


def write(tmp: Path, final: Path, p) -> list[tuple[Path, Path]]:
    """Write Payload `p` to `tmp` (XML) and a temporary HDF5 beside it; the XML refers to the
    HDF5 by its final name. Returns the (temporary, final) pairs to rename."""
    h5py = _h5py()
    h5_path = h5_name(tmp)
    final_h5 = h5_name(final).name
    root = ET.Element("Xdmf", Version="3.0")
    root.set("xmlns:xi", XINCLUDE)
    domain = ET.SubElement(root, "Domain")
    with h5py.File(h5_path, "w") as h5:
        def item(parent, key, a, number):
            h5.create_dataset(key, data=a)  # no compression filter
            dims = " ".join(map(str, a.shape))
            el = ET.SubElement(parent, "DataItem", Dimensions=dims, NumberType=number, Format="HDF")
            el.set("Precision", str(a.dtype.itemsize))
            el.text = f"{final_h5}:{key}"

        def kind(a):
            return "Int" if a.dtype.kind in "iub" else "Float"

        grid = ET.SubElement(domain, "Grid", Name="mesh", GridType="Uniform")
        topo = ET.SubElement(grid, "Topology", TopologyType="Triangle", NumberOfElements=str(len(p.triangles)),
                             NodesPerElement="3")
        item(topo, "/Mesh/mesh/topology", p.triangles.astype(np.int64), "Int")
        geo = ET.SubElement(grid, "Geometry", GeometryType="XY")
        item(geo, "/Mesh/mesh/geometry", p.points.astype(np.float64), "Float")
        for center, data in (("Node", {"fixed": p.fixed, **p.point_data}), ("Cell", p.cell_data)):
            for i, (name, a) in enumerate(data.items()):
                att = ET.SubElement(grid, "Attribute", Name=name, Center=center,
                                    AttributeType="Scalar" if a.ndim == 1 else "Vector" if a.shape[1] == 2 else "Matrix")
                item(att, f"/Data/{center}/{i}", a, kind(a))

        for name, cells, values, topo_type in (("facet_tags", p.edges, p.tags, "PolyLine"),
                                               ("cell_tags", p.triangles, p.regions, "Triangle")):
            grid = ET.SubElement(domain, "Grid", Name=name, GridType="Uniform")
            ET.SubElement(grid, f"{{{XINCLUDE}}}include",
                          xpointer="xpointer(/Xdmf/Domain/Grid[@GridType='Uniform'][1]/Geometry)")
            topo = ET.SubElement(grid, "Topology", TopologyType=topo_type, NumberOfElements=str(len(cells)),
                                 NodesPerElement=str(cells.shape[1]))
            item(topo, f"/MeshTags/{name}/topology", cells.astype(np.int64), "Int")
            att = ET.SubElement(grid, "Attribute", Name=name, AttributeType="Scalar", Center="Cell")
            item(att, f"/MeshTags/{name}/Values", values.astype(np.int32), "Int")
        ET.SubElement(domain, "Information", Name=metadata.ATTRIBUTE, Value=p.meta)
    ET.indent(root)
    text = ET.tostring(root, encoding="unicode").replace(f' xmlns:ns0="{XINCLUDE}"', "").replace("ns0:", "xi:")
    Path(tmp).write_text('<?xml version="1.0"?>\n' + text + "\n", encoding="ascii")
    return [(h5_path, h5_name(final)), (tmp, final)]


def is_qmesh_layout(path: Path) -> bool:
    """True when the file has a Grid named "mesh" among several (the layout written here)."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, RecursionError, OSError):
        return False
    domain = root.find("Domain")
    return domain is not None and len(domain.findall("Grid")) > 1 and domain.find("Grid[@Name='mesh']") is not None


def read(path: Path):
    """A meshio.Mesh of the triangles, the tagged lines and the data of a qmesh-layout file."""
    meshio = _meshio()
    source = repr(str(path))
    root = ET.parse(path).getroot()
    domain = root.find("Domain")
    grids = {g.get("Name"): g for g in domain.findall("Grid")}
    h5py = _h5py()
    files = {}

    def data(parent) -> np.ndarray:
        el = parent.find("DataItem")
        if el is None or el.get("Format") != "HDF" or ":" not in (el.text or ""):
            raise QmeshError(f"{source}: expected an HDF DataItem in {parent.tag}")
        name, key = el.text.strip().split(":", 1)
        h5 = Path(path).parent / name
        if os.path.basename(name) != name:
            raise QmeshError(f"{source}: the HDF5 file {name!r} must lie beside the .xdmf")
        if h5 not in files:
            if not h5.is_file():
                raise QmeshError(f"{source}: its HDF5 file {str(h5)!r} does not exist")
            files[h5] = h5py.File(h5, "r")
        return np.asarray(files[h5][key][()])

    try:
        mesh_grid = grids["mesh"]
        T = data(mesh_grid.find("Topology")).astype(np.int64)
        P = data(mesh_grid.find("Geometry")).astype(np.float64)
        point_data, cell_data = {}, {}
        cells = [meshio.CellBlock("triangle", T.reshape(-1, 3))]
        for att in mesh_grid.findall("Attribute"):
            a = data(att)
            if att.get("Center") == "Node":
                point_data[att.get("Name")] = a
            else:
                cell_data[att.get("Name")] = [a]
        if "cell_tags" in grids:
            cell_data["region"] = [data(grids["cell_tags"].find("Attribute")).ravel()]
        if "facet_tags" in grids:
            g = grids["facet_tags"]
            E = data(g.find("Topology")).astype(np.int64).reshape(-1, 2)
            cells.append(meshio.CellBlock("line", E))
            cell_data = {k: v + [np.zeros((len(E),) + v[0].shape[1:], v[0].dtype)] for k, v in cell_data.items()}
            cell_data["boundary_tag"] = [np.zeros(len(T), np.int32), data(g.find("Attribute")).ravel()]
    finally:
        for f in files.values():
            f.close()
    return meshio.Mesh(P, cells, point_data=point_data, cell_data=cell_data)
