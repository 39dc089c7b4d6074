"""The mesh file formats, one record each (as meshio registers its formats): what writes a
format, what reads it, where qmesh's metadata goes, and what the format keeps.

`qmesh.io.write` and `read` look the extension up here and do no per-format branching of
their own; `FORMATS` and the `KEEPS_*` sets are views of these records.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from qmesh.io import gmsh22, meshio_writers, xdmf


@dataclass(frozen=True)
class Format:
    extension: str
    meshio_name: str              # meshio's reader for files from other programs
    writers: dict                 # version → writer(tmp, final, payload) → [(tmp, final)]; first = default
    metadata: str                 # where qmesh's JSON line goes (`qmesh.io.metadata`)
    keeps_fixed: bool = True
    keeps_data: bool = True       # quality and extra point/cell data (.msh 2.2: point data only)
    keeps_tags: bool = True       # boundary edges with their tags
    keeps_regions: bool = True
    tag_key: str | None = None    # the line cells' tag in files from other programs
    region_key: str | None = None  # the triangles' tag in files from other programs
    region_key_shifted: bool = True  # qmesh writes region_key in gmsh numbering (region + offset)
    reader: Callable | None = None          # own reader, when `own_layout(path)` says the file is ours
    own_layout: Callable | None = None
    more_cell_data: Callable | None = None  # (path, meshio mesh): adds cell data meshio does not read
    notes: str = ""
    keeps_conductivity: bool = field(default=True)
    keeps_means: bool = True      # the element means Q̄_T as cell data "Q11" "Q12" "Q22" (`Mesh.conductivity`)

    @property
    def keeps_tag_names(self) -> bool:  # names travel in the metadata wherever tags do
        return self.keeps_tags

    @property
    def default_version(self) -> str:
        return next(iter(self.writers))


REGISTRY: dict[str, Format] = {}


def register(fmt: Format) -> None:
    REGISTRY[fmt.extension] = fmt


register(Format(".vtu", "vtu", {"": meshio_writers.vtk_family("vtu")}, "root",
                tag_key="gmsh:physical", region_key="gmsh:physical",
                notes="VTK XML; FieldData names the groups for meshio/scikit-fem"))
register(Format(".vtk", "vtk", {"": meshio_writers.vtk_family("vtk")}, "title",
                tag_key="gmsh:physical", region_key="gmsh:physical", notes="legacy VTK; metadata ≤ 256 characters"))
register(Format(".msh", "gmsh", {"2.2": gmsh22.write, "4.1": meshio_writers.gmsh41}, "section",
                keeps_data=False, tag_key="gmsh:physical", region_key="gmsh:physical",
                more_cell_data=gmsh22.read_means,
                notes="gmsh 2.2 ASCII (4.1 binary by option); named physical groups; the element means in "
                      "$QmeshElementMeans (2.2) or as element data (4.1)"))
register(Format(".xdmf", "xdmf", {"": xdmf.write}, "information", reader=xdmf.read,
                own_layout=xdmf.is_qmesh_layout,
                notes="one grid (DOLFINx and meshio read it), facet tags in name_facets.xdmf, "
                      "uncompressed HDF5 beside them"))
register(Format(".mesh", "medit", {"": meshio_writers.medit}, "comment", keeps_data=False,
                tag_key="medit:ref", region_key="medit:ref", region_key_shifted=False, keeps_means=False,
                notes="medit: references only"))
register(Format(".obj", "obj", {"": meshio_writers.obj}, "comment", keeps_fixed=False, keeps_data=False,
                keeps_tags=False, keeps_regions=False, keeps_means=False, notes="triangles only"))

FORMATS = {ext: f.meshio_name for ext, f in REGISTRY.items()}
"""Extension → meshio format name."""
KEEPS_FIXED = {ext for ext, f in REGISTRY.items() if f.keeps_fixed}
KEEPS_DATA = {ext for ext, f in REGISTRY.items() if f.keeps_data}
KEEPS_TAGS = {ext for ext, f in REGISTRY.items() if f.keeps_tags}
KEEPS_TAG_NAMES = {ext for ext, f in REGISTRY.items() if f.keeps_tag_names}
KEEPS_REGIONS = {ext for ext, f in REGISTRY.items() if f.keeps_regions}
KEEPS_CONDUCTIVITY = {ext for ext, f in REGISTRY.items() if f.keeps_conductivity}
KEEPS_MEANS = {ext for ext, f in REGISTRY.items() if f.keeps_means}
"""Formats that keep a Mesh's element means (`Mesh.conductivity`) as cell data Q11 Q12 Q22."""
