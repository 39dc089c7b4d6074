"""What a mesh file may make a reader allocate, checked before the reader allocates it.

A reader sizes its arrays from what the file declares: a count, a largest node number, a
dataset's shape, a compressed stream's length once inflated. A small file can declare
gigabytes. Before meshio (or qmesh's own XDMF reader) reads a file, the sizes it declares are
read here, cheaply, and refused when they exceed `allowance(path)`: RATIO bytes per byte of the
file (at least FLOOR), and never more than the memory budget (`qmesh.mesher.budget`, which
honours a process limit). A refusal is one QmeshError naming the file and what it declares.

- `.vtu`: every compressed data array's block header is read and each block inflated with a
  cap (at most the allowance in all, piece by piece, nothing kept), so a zlib or LZMA stream
  that inflates past it is refused however small its header says it is;
- gmsh `.msh`: the node count of `$Nodes` against the file's bytes, and the largest node
  number (meshio allocates an index of that length) against the allowance;
- `.xdmf`: each HDF5 dataset's declared size against its file and the allowance; a binary
  data file must lie beside the `.xdmf` and fit the allowance too.
"""

from __future__ import annotations

import base64
import binascii
import lzma
import mmap
import os
import re
import xml.etree.ElementTree as ET
import zlib
from pathlib import Path

import numpy as np

from qmesh.errors import QmeshError
from qmesh.io.meshio_writers import optional

RATIO = 64
"""Bytes a reader may allocate per byte of the file: a mesh's arrays compress far less than
this (coordinates and connectivity about 2-4×), a decompression bomb far more (zlib ~1000×)."""
FLOOR = 64 * 2**20
"""What any file may make a reader allocate, however small it is."""
_PIECE = 1 << 20          # bytes inflated at a time while counting a compressed block


def _mib(n: float) -> str:
    return f"{n / 2**20:.0f} MiB" if n < 2**30 else f"{n / 2**30:.1f} GiB"


def allowance(path: Path, extra_bytes: int = 0) -> int:
    """The most reading `path` (and `extra_bytes` of files beside it) may allocate."""
    from qmesh.mesher import budget
    size = Path(path).stat().st_size + extra_bytes
    return int(min(max(FLOOR, RATIO * size), budget.default_budget()))


def refuse(path: Path, declares: str, nbytes: float, limit: int) -> QmeshError:
    return QmeshError(f"{str(path)!r} declares {declares}, about {_mib(nbytes)} to read, more than a file of "
                      f"{Path(path).stat().st_size} bytes may make qmesh allocate ({_mib(limit)}); "
                      "the file is damaged or not a mesh")


def check(path: Path, meshio_name: str) -> None:
    """Refuse `path` when what it declares exceeds `allowance(path)` (formats meshio reads)."""
    if meshio_name == "vtu":
        vtu(path)
    elif meshio_name == "gmsh":
        gmsh(path)
    elif meshio_name == "xdmf":
        xdmf(path)


# --------------------------------------------------------------------------- .vtu

_HEADER = {"UInt32": np.dtype("<u4"), "UInt64": np.dtype("<u8")}


def _b64_chars(n: int) -> int:
    return -(-int(n) // 3) * 4


def vtu(path: Path) -> None:
    """Inflate every compressed data array of a VTK XML file with a cap, keeping nothing."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, RecursionError, OSError, UnicodeDecodeError, ValueError):
        return                                           # meshio's own error says what is wrong
    compressor = root.get("compressor")
    codec = {"vtkZLibDataCompressor": "zlib", "vtkLZMADataCompressor": "lzma"}.get(compressor or "")
    if codec is None:
        return                                           # uncompressed: bounded by the text itself
    header = _HEADER.get(root.get("header_type", "UInt32"))
    if header is None:
        return
    if root.get("byte_order") == "BigEndian":
        header = header.newbyteorder(">")
    appended_el = root.find("AppendedData")
    appended = (appended_el.text or "").strip()[1:] if appended_el is not None else ""
    limit = allowance(path)
    total = 0
    for da in root.iter("DataArray"):
        fmt = da.get("format", "ascii")
        if fmt == "binary":
            data = (da.text or "").strip()
        elif fmt == "appended":
            try:
                data = appended[int(da.get("offset", "0")):]
            except ValueError:
                continue
        else:
            continue
        name = da.get("Name", "?")
        total += _inflated(path, name, data, header, codec, limit - total, limit)


def _inflated(path: Path, name: str, data: str, header: np.dtype, codec: str, room: int, limit: int) -> int:
    """The bytes one compressed array inflates to (refused past `room`)."""
    item = header.itemsize
    try:
        first = base64.b64decode(data[:_b64_chars(item)])[:item]
        if len(first) < item:
            return 0
        blocks = int(np.frombuffer(first, header)[0])
    except (binascii.Error, ValueError):
        return 0                                         # meshio says what is wrong
    head_chars = _b64_chars(item * (3 + blocks))
    if head_chars > len(data):
        raise refuse(path, f"{blocks} compressed blocks in data array {name!r} whose text has "
                     f"{len(data)} characters", item * (3 + blocks), limit)
    try:
        head = np.frombuffer(base64.b64decode(data[:head_chars])[:item * (3 + blocks)], header)
    except (binascii.Error, ValueError):
        return 0
    head = np.minimum(head.astype(np.uint64), np.uint64(2**62)).astype(np.int64)
    block, last, sizes = int(head[1]), int(head[2]), head[3:]
    declared = max(blocks - 1, 0) * block + (last if last else block) if blocks else 0
    if declared > room:
        raise refuse(path, f"data array {name!r} of {declared} bytes uncompressed ({blocks} blocks)", declared, limit)
    try:
        stream = base64.b64decode(data[head_chars:head_chars + _b64_chars(int(sizes.clip(0).sum()))])
    except (binascii.Error, ValueError):
        return 0
    offsets = np.concatenate([[0], np.cumsum(sizes.clip(0))])
    out = 0
    for k in range(blocks):
        piece = stream[int(offsets[k]):int(offsets[k + 1])]
        d = zlib.decompressobj() if codec == "zlib" else lzma.LZMADecompressor()
        try:
            got = d.decompress(piece, _PIECE)
            while True:
                out += len(got)
                if out > room:
                    raise refuse(path, f"data array {name!r} whose compressed stream inflates past {_mib(room)} "
                                 f"(its header says {declared} bytes)", out, limit)
                if codec == "zlib":
                    rest = d.unconsumed_tail
                    if d.eof or not (rest or got):
                        break
                    got = d.decompress(rest, _PIECE)
                else:
                    if d.eof or d.needs_input:
                        break
                    got = d.decompress(b"", _PIECE)
        except (zlib.error, lzma.LZMAError, EOFError):
            return out                                   # a broken stream: meshio's error
    return out


# --------------------------------------------------------------------------- gmsh

def gmsh(path: Path) -> None:
    """The `$Nodes` count against the file's bytes and the largest node number against the
    allowance (meshio indexes the nodes by an array as long as the largest number)."""
    size = Path(path).stat().st_size
    if size == 0:
        return
    limit = allowance(path)
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as mm:
        head = mm[:64]
        version41 = head.startswith(b"$MeshFormat\n4")
        binary = re.match(rb"\$MeshFormat\r?\n\S+\s+1\s", head) is not None
        start = mm.find(b"$Nodes")
        if start < 0:
            return
        end = mm.find(b"$EndNodes", start)
        end = len(mm) if end < 0 else end
        line_end = mm.find(b"\n", start + 7)
        if line_end < 0:
            return
        words = mm[start + 6:line_end + 1].split() or [b""]
        if start + 6 == line_end or not words[0]:
            line2 = mm.find(b"\n", line_end + 1)
            words = mm[line_end + 1:line2 if line2 > 0 else len(mm)].split()
        try:
            numbers = [int(w) for w in words[:4]]
        except ValueError:
            return
        if version41:
            if len(numbers) < 4:
                return
            count, largest = numbers[1], numbers[3]
        else:
            if not numbers:
                return
            count, largest = numbers[0], None
        per_node = 28 if binary else 8                   # the shortest a node can be written
        if count * per_node > size:
            raise refuse(path, f"{count} nodes in $Nodes", count * 24, limit)
        if largest is None and not binary:
            largest = _largest_node(mm, line_end, end, limit)
        if largest is not None and (largest + 1) * 8 > limit:
            raise refuse(path, f"a node numbered {largest}", (largest + 1) * 8, limit)


def _largest_node(mm, start: int, end: int, limit: int) -> int | None:
    """The largest node number of an ASCII 2.2 `$Nodes` past what the allowance indexes, or None:
    only numbers with as many digits as the limit's are looked at."""
    digits = len(str(limit // 8))
    pattern = re.compile(rb"(?m)^[ \t]*\+?0*([1-9][0-9]{%d,})[ \t]" % (digits - 1))
    largest = None
    for m in pattern.finditer(mm, start, end):
        value = int(m.group(1))
        if (value + 1) * 8 > limit:
            return value
        largest = value if largest is None else max(largest, value)
    return largest


# --------------------------------------------------------------------------- .xdmf

def xdmf(path: Path) -> None:
    """Every DataItem's data: an HDF5 dataset or a binary file beside the `.xdmf`, of a declared
    size its file can hold and the allowance covers."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, RecursionError, OSError, UnicodeDecodeError, ValueError):
        return
    files = {}
    try:
        for el in root.iter("DataItem"):
            fmt, text = el.get("Format", "XML"), (el.text or "").strip()
            if fmt == "Binary":
                data = _beside(path, text, "binary data file")
                limit = allowance(path, data.stat().st_size)
                if data.stat().st_size > limit:
                    raise refuse(path, f"the binary data file {text!r} of {data.stat().st_size} bytes",
                                 data.stat().st_size, limit)
            elif fmt == "HDF" and ":" in text:
                name, key = text.split(":", 1)
                h5 = _beside(path, name, "HDF5 file")
                if h5 not in files:
                    try:
                        files[h5] = optional("h5py", "XDMF files").File(h5, "r")
                    except OSError as e:
                        raise QmeshError(f"{str(path)!r}: cannot open its HDF5 file {name!r}: {e}") from e
                dataset(path, files[h5], key, h5)
    finally:
        for f in files.values():
            f.close()


def _beside(path: Path, name: str, what: str) -> Path:
    if not name or os.path.basename(name) != name:
        raise QmeshError(f"{str(path)!r}: the {what} {name!r} must lie beside the .xdmf")
    full = Path(path).parent / name
    if not full.is_file():
        raise QmeshError(f"{str(path)!r}: its {what} {str(full)!r} does not exist")
    return full


def dataset(path: Path, h5file, key: str, h5: Path):
    """The HDF5 dataset `key` of `h5file`, refused unread when its declared size exceeds what its
    file holds (compressed chunks: up to 1024×) or the allowance of the `.xdmf` and its HDF5."""
    import h5py
    try:
        ds = h5file[key]
    except (KeyError, ValueError, TypeError) as e:
        raise QmeshError(f"{str(path)!r}: its HDF5 file has no dataset {key!r}") from e
    if not isinstance(ds, h5py.Dataset) or ds.dtype.kind not in "fiub":
        raise QmeshError(f"{str(path)!r}: {key!r} is not a numeric dataset")
    nbytes = ds.size * ds.dtype.itemsize
    h5_size = h5.stat().st_size
    limit = h5_size * (1 if ds.chunks is None else 1024)
    if nbytes > max(limit, 1 << 16):
        raise QmeshError(f"{str(path)!r}: dataset {key!r} declares {ds.size} values of shape {ds.shape}, "
                         f"more than its HDF5 file of {h5_size} bytes holds")
    most = allowance(path, h5_size)
    if nbytes > most:
        raise refuse(path, f"dataset {key!r} of shape {ds.shape}", nbytes, most)
    return ds
