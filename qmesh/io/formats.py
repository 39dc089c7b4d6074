"""Mesh files through meshio: write a qmesh `Mesh`, read any triangle mesh back as one.

The format follows the file's extension (`FORMATS`). What travels with the mesh:

- the fixed seed flag as integer point data "fixed" (medit .mesh: the vertex reference
  "medit:ref", the only per-vertex value that format holds);
- the metric quality (2.94) as cell data "quality", when `write` is given the anisotropy;
- the conductivity itself (a constant Q, or the text of s), when `write` is given the
  anisotropy, in every format (`qmesh.io.conductivity` says where); `read_anisotropy`
  gives it back;
- the boundary edges with their tags and tag names, as line cells (`qmesh.io.boundary`
  says how); `read` gives them back in `Mesh.boundary_edges`, `boundary_tags`, `tag_names`;
- any extra `point_data` / `cell_data` the caller passes.

medit keeps no data but the fixed flag and the tags; .obj holds points, triangles and the
conductivity only (`KEEPS_FIXED`, `KEEPS_DATA`, `KEEPS_TAGS`, `KEEPS_TAG_NAMES`,
`KEEPS_CONDUCTIVITY` say which formats keep what).
meshio is an optional dependency (`pip install qmesh[io]`), imported only when a file is used.
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from qmesh.io import boundary as file_boundary
from qmesh.io import conductivity as file_conductivity
from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.errors import QmeshError
from qmesh.geometry.triangles import signed_areas
from qmesh.measure import quality
from qmesh.mesh import Mesh

FORMATS = {  # each name is a meshio submodule with read() and write()
    ".vtu": "vtu",
    ".vtk": "vtk",
    ".msh": "gmsh",      # gmsh 4.1
    ".xdmf": "xdmf",
    ".mesh": "medit",
    ".obj": "obj",
}
"""Extension → meshio format name."""

KEEPS_FIXED = {".vtu", ".vtk", ".msh", ".xdmf", ".mesh"}
"""Extensions whose files keep the fixed seed flag."""
KEEPS_DATA = {".vtu", ".vtk", ".msh", ".xdmf"}
"""Extensions whose files keep the quality and any extra point and cell data."""
KEEPS_TAGS = file_boundary.KEEPS_TAGS
"""Extensions whose files keep the boundary edges and their tags (not .obj)."""
KEEPS_TAG_NAMES = file_boundary.KEEPS_NAMES
"""Extensions whose files also keep the tags' names."""
KEEPS_CONDUCTIVITY = set(FORMATS)
"""Extensions whose files keep the conductivity (all: see `qmesh.io.conductivity`)."""

_WRITE_OPTIONS = {
    # meshio's ASCII gmsh writer prints data as numpy reprs ("np.int32(1)") under NumPy 2.
    "gmsh": {"binary": True},
    # One self-contained file: "HDF" would write a side-car .h5 named after the file.
    "xdmf": {"data_format": "XML"},
}
_MEDIT_REF = "medit:ref"
_RESERVED = {"fixed", "quality", _MEDIT_REF, file_boundary.TAG_DATA, file_boundary.VERTEX_DATA,
             "gmsh:physical", "gmsh:geometrical", "gmsh:dim_tags"}


def _meshio():
    try:
        import meshio
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise QmeshError("reading and writing mesh files needs meshio: pip install qmesh[io]") from e
    return meshio


def _path(path, what: str = "path") -> Path:
    """`path` as a Path, or QmeshError naming the argument when it is not a file name."""
    if isinstance(path, bytes):
        path = os.fsdecode(path)
    if not isinstance(path, (str, os.PathLike)):
        raise QmeshError(f"{what} must be a file name (str or os.PathLike), got {type(path).__name__}")
    path = Path(path)
    if not str(path) or path.name in ("", ".", ".."):
        raise QmeshError(f"{what} must name a file, got {str(path)!r}")
    return path


def _extension(path: Path) -> str:
    ext = path.suffix.lower()
    if ext not in FORMATS:
        raise QmeshError(f"unknown mesh file extension {path.suffix or '(none)'!r} of {str(path)!r}; "
                         f"supported: {', '.join(FORMATS)}")
    return ext


def _per_item(data, n: int, what: str) -> dict[str, np.ndarray]:
    """Validate a name → numeric array mapping whose arrays have one row per vertex/triangle."""
    if data is None:
        return {}
    if not isinstance(data, Mapping):
        raise QmeshError(f"{what} must be a dict of name → array, got {type(data).__name__}")
    out = {}
    for name, values in data.items():
        if not isinstance(name, str) or not name.strip():
            raise QmeshError(f"{what} names must be non-empty strings, got {name!r}")
        try:
            a = np.asarray(values)
        except (ValueError, TypeError) as e:  # ragged lists
            raise QmeshError(f"{what}[{name!r}] is not an array: {e}") from e
        if a.dtype != bool and not np.issubdtype(a.dtype, np.number) or np.iscomplexobj(a):
            raise QmeshError(f"{what}[{name!r}] must hold real numbers, got dtype {a.dtype}")
        if a.ndim not in (1, 2) or a.shape[0] != n:
            raise QmeshError(f"{what}[{name!r}] must have {n} rows (shape ({n},) or ({n}, k)), got shape {a.shape}")
        if a.dtype == bool:
            a = a.astype(np.int32)
        out[name] = a
    return out


def check_writable(path) -> Path:
    """`path` as a Path, or QmeshError unless its extension is known and its folder exists.

    The CLI calls it before meshing, so a bad output name fails at once, not after the run.
    """
    path = _path(path)
    _extension(path)
    if not path.parent.is_dir():
        raise QmeshError(f"cannot write {str(path)!r}: folder {str(path.parent)!r} does not exist")
    if path.is_dir():
        raise QmeshError(f"cannot write {str(path)!r}: it is a folder")
    return path


def write(path, mesh: Mesh, *, anisotropy=None, point_data=None, cell_data=None) -> None:
    """Write `mesh` to `path` in the format of its extension.

    The fixed flag is written as point data "fixed" (int); the boundary edges with their tags
    (and tag names) as line cells (`qmesh.io.boundary` says how per format). When
    `anisotropy` is given, the file keeps it (`read_anisotropy` gives it back; a varying s
    given only as callables has no text and is not kept) and the metric quality (2.94) is
    written as cell data "quality": quality is measured in the metric of a particular Q, and
    writing it for a guessed Q would mislead. Line cells get NaN (floats) or 0 in per-triangle
    cell data. Everything is validated before the file is touched, and the file is written
    under a temporary name and then renamed, so an error leaves no file (and no half-written
    one) at `path`.
    """
    path = check_writable(path)
    ext = path.suffix.lower()
    fmt = FORMATS[ext]
    if not isinstance(mesh, Mesh):
        raise QmeshError(f"mesh must be a qmesh.Mesh, got {type(mesh).__name__}")
    if anisotropy is not None and not isinstance(anisotropy, Anisotropy):
        raise QmeshError(f"anisotropy must be a qmesh.Anisotropy or None, got {type(anisotropy).__name__}")
    record = file_conductivity.record_of(anisotropy) if anisotropy is not None else None
    if record is not None:
        file_conductivity.check_storable(record, fmt, path)
    pdata = _per_item(point_data, mesh.n_vertices, "point data")
    cdata = _per_item(cell_data, mesh.n_triangles, "cell data")
    reserved = (_RESERVED & pdata.keys()) | (_RESERVED & cdata.keys())
    if reserved:
        raise QmeshError(f"data names {sorted(reserved)} are reserved for qmesh's own fields")
    pdata["fixed"] = mesh.fixed.astype(np.int32)
    if fmt == "medit":
        pdata = {_MEDIT_REF: pdata["fixed"]}
    if anisotropy is not None:
        cdata["quality"] = quality(mesh, anisotropy)  # (2.94)
    points = mesh.points
    if fmt != "medit":  # medit stores a 2-D mesh as such; the others want x, y, z
        points = np.column_stack([points, np.zeros(len(points))])
    if fmt == "medit":
        cdata = {}  # medit keeps references only
    cells, cdata, extra_points, field_data, order = file_boundary.cells_for(fmt, mesh, cdata, record)
    if order is not None:  # gmsh: nodes sorted by entity
        points, pdata = points[order], {k: v[order] for k, v in pdata.items()}
    names = file_boundary.boundary_of(mesh)[2] if fmt in ("vtu", "xdmf") else {}
    meshio = _meshio()
    m = meshio.Mesh(points, cells, point_data={**pdata, **extra_points}, cell_data=cdata,
                    field_data=field_data)
    tmp = path.with_name(f".{path.stem}.{uuid.uuid4().hex[:12]}.part{ext}")
    try:
        getattr(meshio, fmt).write(tmp, m, **_WRITE_OPTIONS.get(fmt, {}))
        if record is not None:
            file_conductivity.add_to_file(tmp, fmt, record)
        file_boundary.add_names_to_file(tmp, fmt, names)
        os.replace(tmp, path)
    except Exception as e:
        tmp.unlink(missing_ok=True)
        raise QmeshError(f"cannot write {str(path)!r}: {e}") from e


def _read_meshio(path):
    """(meshio mesh, path, format name) of a mesh file, with qmesh's errors."""
    path = _path(path)
    ext = _extension(path)
    if not path.is_file():
        raise QmeshError(f"no such mesh file: {str(path)!r}")
    meshio = _meshio()
    try:  # the format's own reader: meshio.read() calls sys.exit on a bad file
        m = getattr(meshio, FORMATS[ext]).read(path)
    except Exception as e:  # meshio's parsers raise many kinds of error on a bad file
        raise QmeshError(f"cannot read {str(path)!r} as {FORMATS[ext]}: {str(e) or type(e).__name__}") from e
    if FORMATS[ext] == "gmsh":
        file_boundary.restore_gmsh_order(m)
    return m, path, FORMATS[ext]


def read_anisotropy(path) -> Anisotropy | None:
    """The conductivity stored in a mesh file by `write`, or None when the file has none.

    A constant Q comes back exactly; an s stored as text is rebuilt with
    `Anisotropy.from_expression`. Use it with `read`: `mesh, A = read(p), read_anisotropy(p)`.
    """
    path = _path(path)
    fmt = FORMATS[_extension(path)]
    if not path.is_file():
        raise QmeshError(f"no such mesh file: {str(path)!r}")
    field_data = _read_meshio(path)[0].field_data if fmt == "gmsh" else None
    try:
        record = file_conductivity.read_from_file(path, fmt, field_data)
    except OSError as e:
        raise QmeshError(f"cannot read {str(path)!r}: {e}") from e
    return None if record is None else file_conductivity.anisotropy_of(record, repr(str(path)))


def read(path) -> Mesh:
    """Read the triangles of a mesh file (written by qmesh or by any other program).

    Only triangle cells are kept (an error if there are none); points that no triangle uses
    are dropped; a z column must be zero and is dropped; triangles are re-oriented
    counter-clockwise. `fixed` comes from the point data "fixed" (medit: "medit:ref" ≠ 0)
    and is all False when the file has neither. The boundary edges are those of the
    triangles; each takes the tag of the file's tagged line cell on it (tag 1 where there is
    none), and the tag names come back where the format keeps them (`KEEPS_TAG_NAMES`).
    """
    m, path, fmt = _read_meshio(path)
    P = np.asarray(m.points, dtype=float)
    if P.ndim != 2 or P.shape[1] not in (2, 3) or not np.all(np.isfinite(P)):
        raise QmeshError(f"{str(path)!r}: points must be finite with 2 or 3 coordinates, got shape {P.shape}")
    blocks = [np.asarray(c.data, dtype=np.int64) for c in m.cells if c.type == "triangle"]
    if not blocks:
        found = sorted({c.type for c in m.cells}) or ["no cells"]
        raise QmeshError(f"{str(path)!r} has no triangle cells (found: {', '.join(found)})")
    T = np.concatenate(blocks)
    if T.size and (T.min() < 0 or T.max() >= len(P)):
        raise QmeshError(f"{str(path)!r}: triangles refer to points that do not exist")
    if P.shape[1] == 3:
        extent = float(np.ptp(P[:, :2], axis=0).max()) if len(P) else 0.0
        if np.abs(P[:, 2]).max(initial=0.0) > 1e-9 * extent:
            raise QmeshError(f"{str(path)!r} is not a planar mesh in the xy plane (z is not 0)")
        P = P[:, :2]

    flag = m.point_data.get("fixed", m.point_data.get(_MEDIT_REF))
    fixed = np.zeros(len(P), bool)
    if flag is not None:
        flag = np.asarray(flag)
        if flag.ndim not in (1, 2) or flag.shape[0] != len(P) or flag.size != len(P):
            raise QmeshError(f"{str(path)!r}: point data 'fixed' has shape {flag.shape}, "
                             f"expected one value per point ({len(P)})")
        fixed = flag.ravel() != 0

    tagged = file_boundary.boundary_from(m, fmt, path)
    used = np.zeros(len(P), bool)
    used[T.ravel()] = True
    if not used.all():
        renumber = np.cumsum(used) - 1
        P, fixed, T = P[used], fixed[used], renumber[T]
        if tagged is not None:
            E, tags, names = tagged
            keep = np.all((E >= 0) & (E < len(used)), axis=1)
            keep[keep] = used[E[keep]].all(axis=1)
            tagged = renumber[E[keep]], tags[keep], names

    flip = signed_areas(P, T) < 0
    T[flip] = T[flip][:, [0, 2, 1]]
    mesh = Mesh(P, T, fixed)
    if tagged is None:
        return mesh
    edges, tags = file_boundary.tags_on(mesh, *tagged[:2])
    return Mesh(P, T, fixed, boundary_edges=edges, boundary_tags=tags, tag_names=tagged[2])
