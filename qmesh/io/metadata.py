"""qmesh's own record in a mesh file: one JSON object in a place that other readers skip.

    {"qmesh": 1, "tag_names": {"1": "outer wall"}, "region_names": {...},
     "region_offset": 3, "conductivity": {"Q": [[...], [...]]}}

It keeps what a format has no exact place for: the names as the user wrote them (files name
their groups with plain identifiers, `names.identifier`), the shift from a region tag to the
file's cell tag (`region_offset`, gmsh and the "gmsh:physical" arrays) and the conductivity
(`qmesh.io.conductivity`). Where each format keeps it (`Format.metadata` in the registry):

- "section": a `$QmeshMetadata` section at the end of a `.msh` (gmsh and meshio skip unknown sections);
- "root": an attribute `qmesh` of the root element of a `.vtu`;
- "information": an `<Information Name="qmesh">` element of an `.xdmf`'s Domain;
- "title": the title line of a legacy `.vtk` (at most 256 characters);
- "comment": a first line `# qmesh {...}` of a medit `.mesh` or an `.obj`.
"""

from __future__ import annotations

import functools
import json
import os
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

from qmesh.errors import QmeshError

VERSION = 1
SECTION = "QmeshMetadata"
ATTRIBUTE = "qmesh"
VTK_TITLE_LIMIT = 256
_COMMENT = b"# qmesh "
_MAX_BYTES = 1 << 20


def dumps(document: dict) -> str:
    """One line of ASCII JSON (non-ASCII names escaped: every reader of the file stays ASCII-safe)."""
    return json.dumps({"qmesh": VERSION, **document}, ensure_ascii=True, separators=(", ", ": "))


def loads(text, source: str) -> dict:
    """The metadata object in `text`, or QmeshError (malformed, hostile or not an object)."""
    try:
        doc = json.loads(text)
    except (ValueError, RecursionError) as e:  # JSONDecodeError, int digit limit, deep nesting
        raise QmeshError(f"{source}: unreadable qmesh metadata: {str(e)[:120] or type(e).__name__}") from None
    if not isinstance(doc, dict) or doc.get("qmesh") != VERSION:
        raise QmeshError(f"{source}: the qmesh metadata is not a version-{VERSION} object")
    return doc


def names(doc: dict, key: str, source: str) -> dict[int, str] | None:
    """The {tag: name} mapping `key` of the metadata, or None when absent."""
    raw = doc.get(key)
    if raw is None:
        return None
    try:
        return {int(k): v for k, v in raw.items() if isinstance(v, str)}
    except (AttributeError, TypeError, ValueError):
        raise QmeshError(f"{source}: qmesh metadata {key!r} must map integer tags to names") from None


def offset(doc: dict | None) -> int:
    value = (doc or {}).get("region_offset", 0)
    return value if isinstance(value, int) and not isinstance(value, bool) and abs(value) < 2**31 else 0


# --------------------------------------------------------------------------- places

def section(text: str) -> str:
    return f"${SECTION}\n{text}\n$End{SECTION}\n"


# Each place: how to put the line into the bytes a writer made, and how to find it in a file.

def _add_section(data: bytes, text: str) -> bytes:
    return data + section(text).encode("ascii")


def _add_root(data: bytes, text: str) -> bytes:
    from xml.sax.saxutils import quoteattr        # here: it imports urllib and http; VTK files only
    start = data.index(b"<VTKFile")
    end = data.index(b">", start)
    return data[:end] + f" {ATTRIBUTE}={quoteattr(text)}".encode("ascii") + data[end:]


def _add_title(data: bytes, text: str) -> bytes:
    """Line 1 is "# vtk DataFile Version 5.1", line 2 the title."""
    if len(text) > VTK_TITLE_LIMIT:
        raise QmeshError(f".vtk keeps qmesh's metadata in its title line, at most {VTK_TITLE_LIMIT} "
                         f"characters; this one has {len(text)}: write .vtu instead")
    first = data.index(b"\n")
    second = data.index(b"\n", first + 1)
    return data[:first + 1] + text.encode("ascii") + data[second:]


def _add_comment(data: bytes, text: str) -> bytes:
    return _COMMENT + text.encode("ascii") + b"\n" + data


def _read_section(path: Path, source: str) -> str | None:
    with open(path, "rb") as f:
        f.seek(0, 2)
        f.seek(max(0, f.tell() - _MAX_BYTES))
        tail = f.read()
    start = tail.rfind(f"${SECTION}\n".encode())
    if start < 0:
        return None
    body = tail[start + len(SECTION) + 2:]
    end = body.find(f"\n$End{SECTION}".encode())
    return (body if end < 0 else body[:end]).decode("ascii", "replace")


def _read_xml(path: Path, source: str, root: bool) -> str | None:
    try:
        for _, elem in ET.iterparse(path, events=("start",)):
            if root:
                return elem.attrib.get(ATTRIBUTE)
            if elem.tag == "Information" and elem.attrib.get("Name") == ATTRIBUTE:
                return elem.attrib.get("Value")
    except (ET.ParseError, RecursionError) as e:
        raise QmeshError(f"cannot read {source}: {e}") from None
    return None


def _read_title(path: Path, source: str) -> str | None:
    with open(path, "rb") as f:
        f.readline()
        line = f.readline(VTK_TITLE_LIMIT + 2).strip()
    return line.decode("ascii", "replace") if line.startswith(b"{") else None


def _read_comment(path: Path, source: str) -> str | None:
    with open(path, "rb") as f:
        line = f.readline(_MAX_BYTES)
    return line[len(_COMMENT):].decode("ascii", "replace") if line.startswith(_COMMENT) else None


PLACES = {  # place → (add to a written file's bytes, or None: the writer puts it in itself; read)
    "section": (_add_section, _read_section),
    "root": (_add_root, lambda path, source: _read_xml(path, source, root=True)),
    "information": (None, lambda path, source: _read_xml(path, source, root=False)),
    "title": (_add_title, _read_title),
    "comment": (_add_comment, _read_comment),
}


def add(path: Path, place: str, text: str, head_edit=None) -> None:
    """Put the metadata line into a file a meshio writer has just written; `head_edit` (bytes →
    bytes), another change to the file's head, is made in the same pass over the file."""
    put = PLACES[place][0]
    if put is _add_section:
        with open(path, "ab") as f:                            # at the end: append
            f.write(section(text).encode("ascii"))
    edits = [e for e in (head_edit, None if put in (_add_section, None) else
                         lambda head: put(head, text)) if e is not None]
    if edits:
        edit_head(path, lambda head: functools.reduce(lambda data, edit: edit(data), edits, head))


HEAD = 1 << 16      # bytes read to edit a file's head (its root element, title or first line)


def edit_head(path: Path, edit) -> None:
    """Apply `edit` (bytes → bytes) to the first HEAD bytes of the file and copy the rest after
    it in blocks: a file of 1e6 vertices is 155 MB, which a whole read and write held twice."""
    tmp = path.with_name(path.name + ".head")
    with open(path, "rb") as src:
        head = src.read(HEAD)
        try:
            new = edit(head)
        except ValueError:                 # the mark is further in: edit the whole file
            new = edit(head + src.read())
        with open(tmp, "wb") as dst:
            dst.write(new)
            shutil.copyfileobj(src, dst, 1 << 20)
    os.replace(tmp, path)


def read(path: Path, place: str, source: str) -> dict | None:
    """The metadata object of the file at `path`, or None when the file has none."""
    text = PLACES[place][1](path, source)
    return None if text is None else loads(text, source)
