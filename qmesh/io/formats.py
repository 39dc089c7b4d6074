"""Write a qmesh `Mesh` to a file and read any triangle mesh file back as one.

The format follows the file's extension (`qmesh.io.registry`: one record per format). What
travels with the mesh, where the format keeps it (`KEEPS_*`):

- the fixed seed flag, as point data "fixed" (medit: the vertex reference);
- the boundary edges with their tags, as line cells; the regions, as the triangles' tags;
  their names as plain identifiers in the file's own groups and exactly in qmesh's metadata;
- the conductivity (`anisotropy=`: an Anisotropy or {region tag: Anisotropy}) as JSON numbers
  in qmesh's metadata (`qmesh.io.metadata`), and the metric quality (2.94) as cell data;
- the element means Q̄_T of a mesh made for a tensor field (`Mesh.conductivity`) as three float
  cell data arrays "Q11" "Q12" "Q22", one value per triangle (`KEEPS_MEANS`; the formats without
  cell data drop them with a QmeshWarning);
- any extra `point_data` / `cell_data` the caller passes.

meshio (and h5py for .xdmf) is an optional dependency (`pip install qmesh[io]`), imported only
when a file is used.
"""

from __future__ import annotations

import contextlib
import io as _io
import os
import uuid
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, Union

import numpy as np
from numpy.typing import ArrayLike, NDArray

from qmesh.errors import QmeshError, QmeshWarning
from qmesh.domain.polygon_file import MAX_COORDINATE
from qmesh.geometry.folds import turns_clockwise
from qmesh.io import boundary, conductivity, metadata, sizes
from qmesh.io.meshio_writers import _meshio, restore_order
from qmesh.io.payload import MEANS, payload
from qmesh.io.registry import FORMATS, REGISTRY, Format
from qmesh.triangle_mesh import Mesh

if TYPE_CHECKING:
    from qmesh.conductivity.anisotropy import Anisotropy, Conductivity

PathLike = Union[str, bytes, "os.PathLike[str]"]
"""A file name: a str, bytes (decoded by os.fsdecode) or a path object."""

# errors a parser or a conversion raises on a malformed or hostile file: reported, not raised
_FILE_ERRORS = (ValueError, TypeError, IndexError, KeyError, AttributeError, OverflowError, RecursionError,
                EOFError, UnicodeDecodeError, AssertionError)


def _path(path: object, what: str = "path") -> Path:
    """`path` as a Path, or QmeshError naming the argument when it is not a file name."""
    if isinstance(path, bytes):
        path = os.fsdecode(path)
    if not isinstance(path, (str, os.PathLike)):
        raise QmeshError(f"{what} must be a file name (str or os.PathLike), got {type(path).__name__}")
    path = Path(path)
    if not str(path) or path.name in ("", ".", ".."):
        raise QmeshError(f"{what} must name a file, got {str(path)!r}")
    return path


def _format(path: Path) -> Format:
    fmt = REGISTRY.get(path.suffix.lower())
    if fmt is None:
        raise QmeshError(f"unknown mesh file extension {path.suffix or '(none)'!r} of {str(path)!r}; "
                         f"supported: {', '.join(FORMATS)}")
    return fmt


def check_writable(path: PathLike) -> Path:
    """`path` as a Path, or QmeshError unless its extension is known and its folder exists.

    The CLI calls it before meshing, so a bad output name fails at once, not after the run.
    """
    path = _path(path)
    _format(path)
    if not path.parent.is_dir():
        raise QmeshError(f"cannot write {str(path)!r}: folder {str(path.parent)!r} does not exist")
    if path.is_dir():
        raise QmeshError(f"cannot write {str(path)!r}: it is a folder")
    return path


def write(path: PathLike, mesh: Mesh, *, anisotropy: Conductivity | None = None,
          point_data: Mapping[str, ArrayLike] | None = None,
          cell_data: Mapping[str, ArrayLike] | None = None, version: str | None = None) -> None:
    """Write `mesh` to `path` in the format of its extension.

    `anisotropy` (an Anisotropy, or a mapping {region tag: Anisotropy}) is stored so that
    `read_anisotropy` gives it back (a varying s given only as callables has no text and is
    not stored), and the metric quality (2.94) is written as cell data "quality": quality is
    measured in the metric of a particular Q, and writing it for a guessed Q would mislead.
    The element means of a mesh made for a tensor field (`mesh.conductivity`) are written as
    cell data "Q11" "Q12" "Q22" where the format keeps them (`KEEPS_MEANS`); the others (medit
    `.mesh`, `.obj`) write the mesh without them and warn (QmeshWarning). `.xdmf` writes
    `name.xdmf` and its facet tags in `name_facets.xdmf`, each with its HDF5 (`name.h5`,
    `name_facets.h5`).
    `version` chooses a format's variant: "2.2" (default) or "4.1" for .msh. Everything is
    validated before the file is touched, and the file is written under a temporary name and
    then renamed, so an error leaves no file (and no half-written one) at `path`.
    """
    path = check_writable(path)
    fmt = _format(path)
    version = fmt.default_version if version is None else version
    if version not in fmt.writers:
        raise QmeshError(f"version must be one of {sorted(fmt.writers)} for {fmt.extension}, got {version!r}")
    p = payload(mesh, anisotropy, point_data, cell_data)
    if p.means and not fmt.keeps_means:
        warnings.warn(QmeshWarning(f"{str(path)!r}: {fmt.extension} keeps no cell data, so the mesh's element "
                                   "means (mesh.conductivity) are not written; write .vtu, .msh or .xdmf "
                                   "to keep them"), stacklevel=2)
    tmp = path.with_name(f".{path.stem}.{uuid.uuid4().hex[:12]}.part{fmt.extension}")
    written = [(tmp, path)]
    try:
        written = fmt.writers[version](tmp, path, p)
        for part, final in written:
            os.replace(part, final)
    except Exception as e:
        for part, _ in written:
            part.unlink(missing_ok=True)
        tmp.unlink(missing_ok=True)
        if isinstance(e, QmeshError):
            raise
        raise QmeshError(f"cannot write {str(path)!r}: {e}") from e


# --------------------------------------------------------------------------- reading

def _existing(path: PathLike) -> tuple[Path, Format]:
    path = _path(path)
    fmt = _format(path)
    if not path.is_file():
        raise QmeshError(f"no such mesh file: {str(path)!r}")
    return path, fmt


def _metadata(path: Path, fmt: Format) -> dict[str, Any] | None:
    try:
        return metadata.read(path, fmt.metadata, repr(str(path)))
    except OSError as e:
        raise QmeshError(f"cannot read {str(path)!r}: {e}") from e


def _load(path: Path, fmt: Format) -> Any:
    """The meshio mesh of a file, read by qmesh's own reader for its own layout, else by meshio."""
    try:
        if fmt.reader is not None and fmt.own_layout is not None and fmt.own_layout(path):
            return fmt.reader(path)
        sizes.check(path, fmt.meshio_name)   # what the file declares, before meshio allocates it
        with contextlib.redirect_stderr(_io.StringIO()):  # meshio prints its own warnings there
            m = getattr(_meshio(), fmt.meshio_name).read(path)  # meshio.read() calls sys.exit on a bad file
        restore_order(m)
        if fmt.more_cell_data is not None:
            fmt.more_cell_data(path, m)
        return m
    except QmeshError:
        raise
    except Exception as e:  # meshio's parsers raise many kinds of error on a bad file
        raise QmeshError(f"cannot read {str(path)!r} as {fmt.meshio_name}: {str(e)[:200] or type(e).__name__}") from e


def read_anisotropy(path: PathLike) -> Anisotropy | dict[int, Anisotropy] | NDArray[np.float64] | None:
    """The conductivity a mesh file holds: the one `write` stored (an Anisotropy, or a {region
    tag: Anisotropy} mapping); else the element means of a mesh made for a tensor field, one Q
    per triangle (M, 2, 2) in `read(path)`'s order, which every measure takes as a conductivity;
    else None.

    A constant Q comes back exactly; an s stored as text is rebuilt with
    `Anisotropy.from_expression`. Use it with `read`: `mesh, A = read(p), read_anisotropy(p)`.
    """
    path, fmt = _existing(path)
    doc = _metadata(path, fmt)
    if doc is not None and doc.get("conductivity") is not None:
        return conductivity.from_json(doc["conductivity"], repr(str(path)))
    if not fmt.keeps_means:                   # no cell data: no means to give back
        return None
    means = read(path).conductivity
    return None if means is None else np.array(means)


def read_names(path: PathLike) -> tuple[dict[int, str], dict[int, str]]:
    """(boundary tag names, region names) of a mesh file: from qmesh's metadata alone when the
    file has it (no mesh reader, no h5py: for a DOLFINx script), else as `read` finds them."""
    path, fmt = _existing(path)
    doc = _metadata(path, fmt)
    if doc is None:
        mesh = read(path)
        return mesh.tag_names, mesh.region_names
    return _names(None, doc, 0, repr(str(path)))


def read(path: PathLike) -> Mesh:
    """Read the triangles of a mesh file (written by qmesh or by any other program).

    Only triangle cells are kept (an error if there are none); points that no triangle uses
    are dropped; a z column must be zero and is dropped. A file whose triangles turn
    clockwise as a whole is turned counter-clockwise; single triangles that turn the other way
    than the rest are kept so (`qmesh.geometry.folds` counts them: `qmesh report` shows them).
    `fixed` comes from the point data "fixed" (medit: the vertex reference ≠ 0). The boundary
    edges are those of the triangles; each takes the tag of the file's line cell on it (tag 1
    where there is none); the regions come from the triangles' tags; names where the format
    keeps them. `conductivity`, the element means, comes from the triangles' float cell data
    "Q11" "Q12" "Q22" (all three or none; None when the file has none).
    """
    path, fmt = _existing(path)
    doc = _metadata(path, fmt)
    m = _load(path, fmt)
    try:
        return _mesh_of(m, fmt, doc, path)
    except QmeshError:
        raise
    except _FILE_ERRORS as e:
        raise QmeshError(f"cannot read {str(path)!r}: {str(e)[:200] or type(e).__name__}") from e


def _mesh_of(m: Any, fmt: Format, doc: dict[str, Any] | None, path: Path) -> Mesh:
    source = repr(str(path))
    P = np.asarray(m.points, dtype=float)
    if P.ndim != 2 or P.shape[1] not in (2, 3) or not np.all(np.isfinite(P)):
        raise QmeshError(f"{source}: points must be finite with 2 or 3 coordinates, got shape {P.shape}")
    if np.abs(P).max(initial=0.0) > MAX_COORDINATE:  # areas and metric lengths would overflow
        raise QmeshError(f"{source}: coordinates must lie within ±{MAX_COORDINATE:g}, "
                         f"got {np.abs(P).max():.3g}")
    triangle_blocks = [i for i, c in enumerate(m.cells) if c.type == "triangle"]
    if not triangle_blocks:
        found = sorted({c.type for c in m.cells}) or ["no cells"]
        raise QmeshError(f"{source} has no triangle cells (found: {', '.join(found)})")
    T = np.concatenate([np.asarray(m.cells[i].data, dtype=np.int64).reshape(-1, 3) for i in triangle_blocks])
    if T.size and (T.min() < 0 or T.max() >= len(P)):
        raise QmeshError(f"{source}: triangles refer to points that do not exist")
    if P.shape[1] == 3:
        extent = float(np.ptp(P[:, :2], axis=0).max()) if len(P) else 0.0
        if np.abs(P[:, 2]).max(initial=0.0) > 1e-9 * extent:
            raise QmeshError(f"{source} is not a planar mesh in the xy plane (z is not 0)")
        P = P[:, :2]

    flag = m.point_data.get("fixed", m.point_data.get("medit:ref"))
    fixed = np.zeros(len(P), bool)
    if flag is not None:
        flag = np.asarray(flag)
        if flag.ndim not in (1, 2) or flag.shape[0] != len(P) or flag.size != len(P):
            raise QmeshError(f"{source}: point data 'fixed' has shape {flag.shape}, "
                             f"expected one value per point ({len(P)})")
        fixed = flag.ravel() != 0

    offset = metadata.offset(doc)
    own_regions = "region" in m.cell_data
    region_data = _cell_values(m, "region" if own_regions else fmt.region_key, triangle_blocks, len(T), source)
    shift = offset if not own_regions and fmt.region_key_shifted else 0
    regions = np.zeros(len(T), np.int64) if region_data is None else region_data - shift
    if regions.min(initial=0) < 0:
        regions = np.where(regions < 0, 0, regions)  # gmsh's "no physical group"

    line_blocks = [i for i, c in enumerate(m.cells) if c.type == "line"]
    tag_key = "boundary_tag" if "boundary_tag" in m.cell_data else fmt.tag_key
    E: NDArray[np.int64] | None = None
    tags: NDArray[np.int64] | None = None
    if line_blocks and tag_key in m.cell_data:
        E = np.concatenate([np.asarray(m.cells[i].data, dtype=np.int64).reshape(-1, 2) for i in line_blocks])
        tags = _cell_values(m, tag_key, line_blocks, len(E), source)
        if E.size and (E.min() < 0 or E.max() >= len(P)):
            raise QmeshError(f"{source}: line cells refer to points that do not exist")

    tag_names, region_names = _names(m, doc, offset, source)

    used = np.zeros(len(P), bool)
    used[T.ravel()] = True
    if not used.all():
        renumber = np.cumsum(used) - 1
        P, fixed, T = P[used], fixed[used], renumber[T]
        if E is not None and tags is not None:
            keep = used[E].all(axis=1)
            E, tags = renumber[E[keep]], tags[keep]

    if turns_clockwise(P, T):  # a file that turns clockwise as a whole: its convention, not a fold
        T = T[:, [0, 2, 1]]
    means = _means(m, triangle_blocks, len(T), source)
    mesh = Mesh(P, T, fixed, region_tags=regions, region_names=region_names, conductivity=means)
    if E is None or tags is None:
        return mesh
    edges, on = boundary.tags_on(mesh, E, tags)
    return Mesh(P, T, fixed, boundary_edges=edges, boundary_tags=on, tag_names=tag_names,
                region_tags=regions, region_names=region_names, conductivity=means)


def _means(m: Any, blocks: list[int], n: int, source: str) -> NDArray[np.float64] | None:
    """The element means (n, 2, 2) from the triangles' cell data Q11 Q12 Q22, or None."""
    found = [name for name in MEANS if name in m.cell_data]
    if not found:
        return None
    if len(found) < len(MEANS):
        raise QmeshError(f"{source}: the element means need cell data {', '.join(MEANS)}; "
                         f"found only {', '.join(found)}")
    columns = []
    for name in MEANS:
        data = m.cell_data[name]
        if len(data) != len(m.cells):
            raise QmeshError(f"{source}: cell data {name!r} does not cover every cell block")
        a = [np.asarray(data[i]) for i in blocks]
        if any(b.dtype.kind not in "fiu" or b.size != len(m.cells[i].data) for b, i in zip(a, blocks)):
            raise QmeshError(f"{source}: cell data {name!r} is not one number per triangle")
        values = np.concatenate([b.reshape(-1) for b in a]).astype(np.float64)
        if len(values) != n or not np.all(np.isfinite(values)):
            raise QmeshError(f"{source}: cell data {name!r} is not one finite number per triangle")
        columns.append(values)
    q11, q12, q22 = columns
    return np.stack([np.stack([q11, q12], axis=-1), np.stack([q12, q22], axis=-1)], axis=-2)


def _cell_values(m: Any, key: str | None, blocks: list[int], n: int, source: str) -> NDArray[np.int64] | None:
    """Integer cell data `key` of the cell blocks `blocks`, one value per cell, or None."""
    data = m.cell_data.get(key) if key else None
    if data is None:
        return None
    values = np.concatenate([np.asarray(data[i]).reshape(-1) for i in blocks])
    if len(values) != n or not np.all(np.isfinite(values)) or np.abs(values).max(initial=0) >= 2**31:
        raise QmeshError(f"{source}: cell data {key!r} is not one integer per cell")
    return values.astype(np.int64)


def _names(m: Any, doc: dict[str, Any] | None, offset: int, source: str) -> tuple[dict[int, str], dict[int, str]]:
    """(tag names, region names): exact from qmesh's metadata, else the file's named groups."""
    if doc is not None:
        return (metadata.names(doc, "tag_names", source) or {}, metadata.names(doc, "region_names", source) or {})
    tag_names: dict[int, str] = {}
    region_names: dict[int, str] = {}
    for name, value in (m.field_data or {}).items():
        v = np.ravel(value)
        if len(v) == 2 and np.all(np.isfinite(v)):
            (tag_names if int(v[1]) == 1 else region_names if int(v[1]) == 2 else {})[int(v[0])] = str(name)
    return tag_names, region_names
