"""qmesh's own writer of gmsh's MSH 2.2 ASCII format: the `.msh` every client reads.

gmsh itself, DOLFINx's gmsh reader (through the gmsh API), NGSolve's `ReadGmsh` (2.2 ASCII
only) and meshio all read it. Layout: `$PhysicalNames` (the boundary tags, dimension 1, and the
regions, dimension 2, named by plain identifiers); `$Nodes` (x y 0: the format has three
coordinates); `$Elements` (lines of boundary tag t: physical and elementary tag t; triangles of
region r: tag r + region_offset); `$NodeData` "fixed" and any extra point data;
no cell data (meshio 5.3 splits 2.2 `$ElementData` wrongly; the quality and extra cell data
need `version="4.1"`); `$QmeshMetadata` (qmesh's JSON line,
which every other reader skips). Node i of the Mesh is node i + 1 of the file.
"""

from __future__ import annotations

import numpy as np

from qmesh.errors import QmeshError
from qmesh.io import metadata

_COMPONENTS = (1, 3, 9)  # what gmsh's data views hold: scalar, vector, tensor


def write(path, final, p) -> list:
    """Write Payload `p` to `path` as MSH 2.2 ASCII (to be renamed `final`)."""
    extra = set(p.cell_data) - {"quality"}
    if extra:
        raise QmeshError(f"cell data {sorted(extra)}: gmsh 2.2 files keep no cell data that meshio reads "
                         "back; write .vtu, or .msh with version='4.1'")
    for what, data in (("point data", p.point_data),):
        for name, a in data.items():
            k = 1 if a.ndim == 1 else a.shape[1]
            if k not in _COMPONENTS or '"' in name or "\n" in name:
                raise QmeshError(f"{what}[{name!r}]: gmsh keeps data of 1, 3 or 9 components under a name "
                                 f"without quotes or newlines, got {k} components")
    n, m, k = len(p.points), len(p.triangles), len(p.edges)
    with open(path, "w", encoding="ascii", newline="\n") as f:
        f.write("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n")
        groups = [(1, t, name) for t, name in sorted(p.tag_ids.items())]
        groups += [(2, r + p.offset, name) for r, name in sorted(p.region_ids.items())]
        f.write(f"$PhysicalNames\n{len(groups)}\n")
        f.writelines(f'{dim} {tag} "{name}"\n' for dim, tag, name in groups)
        f.write("$EndPhysicalNames\n")

        f.write(f"$Nodes\n{n}\n")
        _rows(f, np.column_stack([np.arange(1, n + 1), p.points]), "%d %.17g %.17g 0\n")
        f.write("$EndNodes\n")

        f.write(f"$Elements\n{k + m}\n")
        lines = np.column_stack([np.arange(1, k + 1), np.ones(k, int), np.full(k, 2), p.tags, p.tags, p.edges + 1])
        _rows(f, lines.astype(np.int64), "%d %d %d %d %d %d %d\n")
        cells = p.cell_tags
        tris = np.column_stack([np.arange(k + 1, k + m + 1), np.full(m, 2), np.full(m, 2), cells, cells,
                                p.triangles + 1])
        _rows(f, tris.astype(np.int64), "%d %d %d %d %d %d %d %d\n")
        f.write("$EndElements\n")

        for name, a in {"fixed": p.fixed, **p.point_data}.items():
            _data(f, "NodeData", name, np.arange(1, n + 1), a)
        f.write(metadata.section(p.meta))
    return [(path, final)]


def _data(f, section: str, name: str, ids: np.ndarray, a: np.ndarray) -> None:
    a = a.reshape(len(a), -1)
    f.write(f'${section}\n1\n"{name}"\n1\n0.0\n3\n0\n{a.shape[1]}\n{len(a)}\n')
    integer = a.dtype.kind in "iub"
    row = "%d" + (" %d" if integer else " %.17g") * a.shape[1] + "\n"
    _rows(f, np.column_stack([ids, a]) if integer else np.column_stack([ids.astype(float), a]), row)
    f.write(f"$End{section}\n")


def _rows(f, a: np.ndarray, row: str, chunk: int = 65536) -> None:
    """Write the rows of `a` with the printf format `row`, a chunk of rows per formatting call."""
    for start in range(0, len(a), chunk):
        block = a[start:start + chunk]
        f.write((row * len(block)) % tuple(block.ravel().tolist()))
