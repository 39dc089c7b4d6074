"""qmesh's own writer of gmsh's MSH 2.2 ASCII format: the `.msh` every client reads.

gmsh itself, DOLFINx's gmsh reader (through the gmsh API), NGSolve's `ReadGmsh` (2.2 ASCII
only) and meshio all read it. Layout: `$PhysicalNames` (the boundary tags, dimension 1, and the
regions, dimension 2, named by plain identifiers); `$Nodes` (x y 0: the format has three
coordinates); `$Elements` (lines of boundary tag t: physical and elementary tag t; triangles of
region r: tag r + region_offset); `$NodeData` "fixed" and any extra point data;
no cell data (meshio 5.3 splits a 2.2 `$ElementData` wrongly whenever a file has more than one
cell block, and fails to read the file at all; the quality and extra cell data need
`version="4.1"`); the element means (`Mesh.conductivity`), when the mesh has them, in a section
`$QmeshElementMeans` (the number of triangles, then "Q11 Q12 Q22" per triangle in the order of
`$Elements`), which gmsh, NGSolve and meshio skip and `read_means` gives back; `$QmeshMetadata` (qmesh's JSON line,
which every other reader skips). Node i of the Mesh is node i + 1 of the file.
"""

from __future__ import annotations

import mmap
from pathlib import Path

import numpy as np

from qmesh.errors import QmeshError
from qmesh.io import metadata

MEANS_SECTION = "QmeshElementMeans"

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
        _int_rows(f, [np.arange(1, k + 1), 1, 2, p.tags, p.tags, p.edges + 1])
        _int_rows(f, [np.arange(k + 1, k + m + 1), 2, 2, p.cell_tags, p.cell_tags, p.triangles + 1])
        f.write("$EndElements\n")

        for name, a in {"fixed": p.fixed, **p.point_data}.items():
            _data(f, "NodeData", name, np.arange(1, n + 1), a)
        if p.means:
            f.write(f"${MEANS_SECTION}\n{m}\n")
            _rows(f, np.column_stack([p.means["Q11"], p.means["Q12"], p.means["Q22"]]), "%.17g %.17g %.17g\n")
            f.write(f"$End{MEANS_SECTION}\n")
        f.write(metadata.section(p.meta))
    return [(path, final)]


def read_means(path: Path, m) -> None:
    """Add the element means of a qmesh gmsh 2.2 file (its `$QmeshElementMeans`) to the meshio
    mesh `m` as cell data "Q11" "Q12" "Q22" (lines 0). The declared count must be the number of
    triangles before any row is read."""
    with open(path, "rb") as f:
        if not f.read(20).startswith(b"$MeshFormat\n2.2"):
            return
        f.seek(0)
        try:
            mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
        except (ValueError, OSError):  # an empty file
            return
        with mm:
            start = mm.rfind(f"\n${MEANS_SECTION}\n".encode())
            if start < 0:
                return
            start += len(MEANS_SECTION) + 3
            end = mm.find(f"$End{MEANS_SECTION}".encode(), start)
            line_end = mm.find(b"\n", start)
            if end < 0 or line_end < 0 or line_end > end:
                raise QmeshError(f"{str(path)!r}: ${MEANS_SECTION} has no end")
            count = mm[start:line_end].strip()
            blocks = [i for i, c in enumerate(m.cells) if c.type == "triangle"]
            n = sum(len(m.cells[i].data) for i in blocks)
            if not count.isdigit() or int(count) != n:
                raise QmeshError(f"{str(path)!r}: ${MEANS_SECTION} declares {count[:20]!r} rows for {n} triangles")
            values = np.array(mm[line_end + 1:end].split(), dtype=np.float64)
    if values.size != 3 * n:
        raise QmeshError(f"{str(path)!r}: ${MEANS_SECTION} holds {values.size} numbers, expected {3 * n}")
    values = values.reshape(n, 3)
    offsets = np.cumsum([0] + [len(m.cells[i].data) for i in blocks])
    for j, name in enumerate(("Q11", "Q12", "Q22")):
        data = [np.zeros(len(c.data)) for c in m.cells]
        for b, i in enumerate(blocks):
            data[i] = values[offsets[b]:offsets[b + 1], j]
        m.cell_data[name] = data


def _data(f, section: str, name: str, ids: np.ndarray, a: np.ndarray) -> None:
    a = a.reshape(len(a), -1)
    f.write(f'${section}\n1\n"{name}"\n1\n0.0\n3\n0\n{a.shape[1]}\n{len(a)}\n')
    integer = a.dtype.kind in "iub"
    row = "%d" + (" %d" if integer else " %.17g") * a.shape[1] + "\n"
    _rows(f, np.column_stack([ids, a]) if integer else np.column_stack([ids.astype(float), a]), row)
    f.write(f"$End{section}\n")


def _int_rows(f, columns: list) -> None:
    """Rows of integer columns (numbers, arrays (n,) or (n, c)) separated by spaces. A column
    holding one value throughout is written into the row's format rather than formatted on
    every row: the same text, and the triangles of a one-region mesh in 40% of the time."""
    cols = [np.asarray(c, dtype=np.int64) for c in columns]
    n = max(len(c) for c in cols if c.ndim)
    if n == 0:
        return
    fields, varying = [], []
    for c in cols:
        for col in ([c] if c.ndim < 2 else list(c.T)):
            if col.ndim == 0 or (col == col[0]).all():
                fields.append(str(int(col if col.ndim == 0 else col[0])))
            else:
                fields.append("%d")
                varying.append(col)
    row = " ".join(fields) + "\n"
    if varying:
        _rows(f, np.column_stack(varying), row)
    else:                                             # one row, or every row alike
        f.write(row * n)


def _rows(f, a: np.ndarray, row: str, chunk: int = 65536) -> None:
    """Write the rows of `a` with the printf format `row`, a chunk of rows per formatting call."""
    for start in range(0, len(a), chunk):
        block = a[start:start + chunk]
        f.write((row * len(block)) % tuple(block.ravel().tolist()))
