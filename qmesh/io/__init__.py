"""Mesh files: `write` a qmesh `Mesh` with its tags, regions, conductivity and element means
(`Mesh.conductivity`, as cell data Q11 Q12 Q22), `read` any triangle mesh back as one,
`read_anisotropy` the conductivity a file remembers; the formats
are records in `registry` (one per extension). `to_skfem`, `to_dolfinx`, `to_ngsolve` hand a
Mesh to a FEM code without a file (`adapters`); `to_modflow6` writes it as a MODFLOW 6 DISU model
(`modflow6`). meshio is imported only when a file is used, and each of these modules when one
of its names is first used (PEP 562): writing a `.msh` loads neither the FEM adapters nor
MODFLOW's."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:   # for type checkers and IDEs; at run time `__getattr__` loads them
    from qmesh.io.adapters import to_dolfinx, to_ngsolve, to_skfem
    from qmesh.io.formats import check_writable, read, read_anisotropy, read_names, write
    from qmesh.io.modflow6 import modflow_cells, to_modflow6
    from qmesh.io.registry import (FORMATS, KEEPS_CONDUCTIVITY, KEEPS_DATA, KEEPS_FIXED, KEEPS_MEANS,
                                   KEEPS_REGIONS, KEEPS_TAG_NAMES, KEEPS_TAGS, REGISTRY)

_LAZY = {
    **dict.fromkeys(["to_dolfinx", "to_ngsolve", "to_skfem"], "qmesh.io.adapters"),
    **dict.fromkeys(["check_writable", "read", "read_anisotropy", "read_names", "write"], "qmesh.io.formats"),
    **dict.fromkeys(["modflow_cells", "to_modflow6"], "qmesh.io.modflow6"),
    **dict.fromkeys(["FORMATS", "KEEPS_CONDUCTIVITY", "KEEPS_DATA", "KEEPS_FIXED", "KEEPS_MEANS",
                     "KEEPS_REGIONS", "KEEPS_TAG_NAMES", "KEEPS_TAGS", "REGISTRY"], "qmesh.io.registry"),
}
"""Public name → the module that holds it."""

__all__ = ["FORMATS", "KEEPS_CONDUCTIVITY", "KEEPS_DATA", "KEEPS_FIXED", "KEEPS_MEANS", "KEEPS_REGIONS",
           "KEEPS_TAG_NAMES", "KEEPS_TAGS", "REGISTRY", "check_writable", "modflow_cells", "read", "read_anisotropy", "read_names", "to_dolfinx", "to_ngsolve",
           "to_modflow6", "to_skfem", "write"]


def __getattr__(name: str) -> Any:
    """Import a public name's module on first use and keep the name on the package; a
    submodule (`qmesh.io.gmsh22`) as Python's import does."""
    if name not in _LAZY:
        if name.startswith("_"):
            raise AttributeError(f"module 'qmesh.io' has no attribute {name!r}")
        try:
            return importlib.import_module(f"qmesh.io.{name}")
        except ModuleNotFoundError as e:
            if e.name != f"qmesh.io.{name}":
                raise
            raise AttributeError(f"module 'qmesh.io' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(_LAZY[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
