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
from qmesh.io.printf_columns import write_rows

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
    with open(path, "wb") as out:
        def f(text: str) -> None:
            out.write(text.encode("ascii"))
        f("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n")
        groups = [(1, t, name) for t, name in sorted(p.tag_ids.items())]
        groups += [(2, r + p.offset, name) for r, name in sorted(p.region_ids.items())]
        f(f"$PhysicalNames\n{len(groups)}\n")
        f("".join(f'{dim} {tag} "{name}"\n' for dim, tag, name in groups))
        f("$EndPhysicalNames\n")

        f(f"$Nodes\n{n}\n")
        write_rows(out, [np.arange(1, n + 1), b" ", p.points[:, 0], b" ", p.points[:, 1], b" 0\n"], n)
        f("$EndNodes\n")

        f(f"$Elements\n{k + m}\n")
        _int_rows(out, [np.arange(1, k + 1), 1, 2, p.tags, p.tags, p.edges + 1])
        _int_rows(out, [np.arange(k + 1, k + m + 1), 2, 2, p.cell_tags, p.cell_tags, p.triangles + 1])
        f("$EndElements\n")

        for name, a in {"fixed": p.fixed, **p.point_data}.items():
            _data(out, "NodeData", name, np.arange(1, n + 1), a)
        if p.means:
            f(f"${MEANS_SECTION}\n{m}\n")
            write_rows(out, [p.means["Q11"], b" ", p.means["Q12"], b" ", p.means["Q22"], b"\n"], m)
            f(f"$End{MEANS_SECTION}\n")
        f(metadata.section(p.meta))
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


def _data(out, section: str, name: str, ids: np.ndarray, a: np.ndarray) -> None:
    a = a.reshape(len(a), -1)
    out.write(f'${section}\n1\n"{name}"\n1\n0.0\n3\n0\n{a.shape[1]}\n{len(a)}\n'.encode("ascii"))
    # integers as %d, floats as %.17g (`printf_columns`), the ids as %d either way
    parts: list = [ids]
    for column in a.T:
        parts += [b" ", column.astype(np.int64) if a.dtype.kind in "iub" else column]
    write_rows(out, parts + [b"\n"], len(a))
    out.write(f"$End{section}\n".encode("ascii"))


def _int_rows(out, columns: list) -> None:
    """Rows of integer columns (numbers, arrays (n,) or (n, c)) separated by spaces, written to
    the binary file `out`. A column holding one value throughout is written as text into every
    row rather than formatted on every row: the same text, less work."""
    cols = [np.asarray(c, dtype=np.int64) for c in columns]
    n = max(len(c) for c in cols if c.ndim)
    if n == 0:
        return
    parts: list = []
    for c in cols:
        for col in ([c] if c.ndim < 2 else list(c.T)):
            parts.append(b" ")
            if col.ndim == 0 or (col == col[0]).all():
                parts.append(str(int(col if col.ndim == 0 else col[0])).encode("ascii"))
            else:
                parts.append(col)
    parts[0] = b""
    parts.append(b"\n")
    # neighbouring texts as one part
    merged: list = []
    for part in parts:
        if isinstance(part, bytes) and merged and isinstance(merged[-1], bytes):
            merged[-1] += part
        else:
            merged.append(part)
    write_rows(out, [part for part in merged if not isinstance(part, bytes) or part], n)
