"""Mesh files: `write` a qmesh `Mesh` with its tags, regions, conductivity and element means
(`Mesh.conductivity`, as cell data Q11 Q12 Q22), `read` any triangle mesh back as one,
`read_anisotropy` the conductivity a file remembers; the formats
are records in `registry` (one per extension). `to_skfem`, `to_dolfinx`, `to_ngsolve` hand a
Mesh to a FEM code without a file (`adapters`); `to_modflow6` writes it as a MODFLOW 6 DISU model
(`modflow6`). meshio is imported only when a file is used."""

from qmesh.io.adapters import to_dolfinx, to_ngsolve, to_skfem
from qmesh.io.formats import check_writable, read, read_anisotropy, read_names, write
from qmesh.io.modflow6 import modflow_cells, to_modflow6
from qmesh.io.registry import (FORMATS, KEEPS_CONDUCTIVITY, KEEPS_DATA, KEEPS_FIXED, KEEPS_MEANS,
                               KEEPS_REGIONS, KEEPS_TAG_NAMES, KEEPS_TAGS, REGISTRY)

__all__ = ["FORMATS", "KEEPS_CONDUCTIVITY", "KEEPS_DATA", "KEEPS_FIXED", "KEEPS_MEANS", "KEEPS_REGIONS",
           "KEEPS_TAG_NAMES", "KEEPS_TAGS", "REGISTRY", "check_writable", "modflow_cells", "read", "read_anisotropy", "read_names", "to_dolfinx", "to_ngsolve",
           "to_modflow6", "to_skfem", "write"]
