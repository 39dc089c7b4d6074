"""Where each mesh file format keeps the conductivity the mesh was made for.

A mesh is Q-adapted for one Q: measuring it with another (κ2, the share of q_ij ≥ 0) says
little. So `qmesh.io.write` stores the conductivity as one line of text, a *record*:

    qmesh conductivity: Q = [[0.1, 0.0], [0.0, 10.0]]        (a constant Q, exact floats)
    qmesh conductivity: s(x, y) = x**2 + 0.1*y**4            (a varying s given as text)

and each format keeps it in the place it offers for free text, chosen so that meshio reads
the file unchanged and other programs ignore it:

- `.msh` (gmsh): the physical name ($PhysicalNames) of the triangles' physical surface, so it
  also survives a meshio read → write;
- `.vtu`, `.xdmf`: an attribute `qmesh_conductivity` of the root XML element;
- `.vtk` (legacy): the header's title line (at most 256 characters);
- `.mesh` (medit), `.obj`: a `#` comment line at the top of the file.

Only the gmsh record survives a conversion by meshio (read, then write): meshio 5.3 has no
place for free text in the other formats, and its .vtu/.vtk/.xdmf writers drop field data.
A varying s given as Python callables (`Anisotropy.from_s`) has no text and is not stored.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from qmesh.conductivity.anisotropy import Anisotropy, adj2
from qmesh.errors import QmeshError

PREFIX = "qmesh conductivity: "
ATTRIBUTE = "qmesh_conductivity"
VTK_TITLE_LIMIT = 256
_ROOT_TAGS = {"vtu": b"<VTKFile", "xdmf": b"<Xdmf"}
_FLOAT = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|[-+]?inf|nan"
_Q_RECORD = re.compile(rf"Q = \[\[({_FLOAT}), ({_FLOAT})\], \[({_FLOAT}), ({_FLOAT})\]\]")
_S_RECORD = re.compile(r"s\(x, y\) = (.+)")
_COMMENT_SCAN_LINES = 64


# --------------------------------------------------------------------------- record ↔ Anisotropy

def record_of(anisotropy) -> str | None:
    """The one-line record for `anisotropy`, or None when it has no text form (a callable s)."""
    expression = getattr(anisotropy, "expression", None)
    if expression is not None:
        text = " ".join(str(expression).split())  # one line: newlines are only whitespace
        return f"{PREFIX}s(x, y) = {text}"
    if anisotropy.is_constant:
        Q = adj2(np.asarray(anisotropy.H, dtype=float)).tolist()  # adj(adj Q) = Q exactly
        return f"{PREFIX}Q = [[{Q[0][0]!r}, {Q[0][1]!r}], [{Q[1][0]!r}, {Q[1][1]!r}]]"
    return None


def anisotropy_of(record: str, source: str) -> Anisotropy:
    """The Anisotropy a record describes; `source` names the file in error messages."""
    body = record[len(PREFIX):] if record.startswith(PREFIX) else record
    m = _Q_RECORD.fullmatch(body)
    if m:
        q11, q12, q21, q22 = (float(g) for g in m.groups())
        try:
            return Anisotropy.constant([[q11, q12], [q21, q22]])
        except QmeshError as e:
            raise QmeshError(f"{source}: the stored conductivity is not valid: {e}") from e
    m = _S_RECORD.fullmatch(body)
    if m:
        from_expression = getattr(Anisotropy, "from_expression", None)
        if from_expression is None:
            raise QmeshError(f"{source} stores s(x, y) = {m.group(1)}, but this qmesh cannot read "
                             "expressions (Anisotropy.from_expression is missing)")
        try:
            return from_expression(m.group(1))
        except QmeshError as e:
            raise QmeshError(f"{source}: the stored s(x, y) = {m.group(1)} is not valid: {e}") from e
    raise QmeshError(f"{source}: unreadable conductivity record {record!r}")


# --------------------------------------------------------------------------- per format

def check_storable(record: str, fmt: str, path: Path) -> None:
    """QmeshError (naming `anisotropy`) when `fmt` cannot hold this record."""
    if fmt == "vtk" and len(record) > VTK_TITLE_LIMIT:
        raise QmeshError(f"anisotropy: .vtk keeps a conductivity of at most {VTK_TITLE_LIMIT} characters "
                         f"in its title line, this one has {len(record)}; write {path.stem}.vtu instead")
    if fmt == "gmsh" and ('"' in record or "'" in record):
        raise QmeshError("anisotropy: a gmsh physical name cannot hold quotes; the conductivity "
                         f"{record[len(PREFIX):]!r} has some")


def gmsh_field_data(record: str, tag: int) -> dict:
    """meshio field_data naming the triangles' physical surface `tag` with the record."""
    return {record: np.array([tag, 2])}


def set_root_attribute(data: bytes, fmt: str, name: str, value: str) -> bytes:
    """The XML text `data` of a .vtu/.xdmf file with attribute `name`="value" on its root element."""
    start = data.index(_ROOT_TAGS[fmt])
    end = data.index(b">", start)
    attr = f" {name}={quoteattr(value)}".encode("ascii", "xmlcharrefreplace")
    return data[:end] + attr + data[end:]


def root_attribute(path: Path, fmt: str, name: str) -> str | None:
    """Attribute `name` of the root element of a .vtu/.xdmf file, or None."""
    try:
        for _, elem in ET.iterparse(path, events=("start",)):
            return elem.attrib.get(name)  # the root element comes first
    except ET.ParseError as e:
        raise QmeshError(f"cannot read {str(path)!r} as {fmt}: {e}") from e
    return None


def add_to_file(path: Path, fmt: str, record: str) -> None:
    """Put `record` into the file meshio just wrote (all formats but gmsh, which has it already)."""
    if fmt == "gmsh":
        return
    data = path.read_bytes()
    if fmt in _ROOT_TAGS:
        data = set_root_attribute(data, fmt, ATTRIBUTE, record)
    elif fmt == "vtk":  # line 1 "# vtk DataFile Version 5.1", line 2 the title
        first = data.index(b"\n")
        second = data.index(b"\n", first + 1)
        data = data[:first + 1] + record.encode("unicode_escape") + data[second:]
    else:  # medit, obj: a comment line first
        data = b"# " + record.encode("utf-8") + b"\n" + data
    path.write_bytes(data)


def read_from_file(path: Path, fmt: str, field_data: dict | None = None) -> str | None:
    """The record stored in the file at `path`, or None. gmsh needs meshio's `field_data`."""
    if fmt == "gmsh":
        found = [name for name in (field_data or {}) if str(name).startswith(PREFIX)]
        return found[0] if found else None
    if fmt in _ROOT_TAGS:
        return root_attribute(path, fmt, ATTRIBUTE)
    with open(path, "rb") as f:
        if fmt == "vtk":
            f.readline()
            try:
                title = f.readline().rstrip(b"\r\n").decode("unicode_escape")
            except UnicodeDecodeError:  # another program's title with a stray backslash
                return None
            return title if title.startswith(PREFIX) else None
        for _ in range(_COMMENT_SCAN_LINES):
            line = f.readline()
            if not line.startswith(b"#"):
                break
            text = line[1:].strip().decode("utf-8", "replace")
            if text.startswith(PREFIX):
                return text
    return None
