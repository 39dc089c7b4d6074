"""A raster field from a NumPy .npz file (`qmesh mesh --raster FILE.npz`), checked before it is
inflated.

numpy.savez writes one .npy member per array into a zip file. Each member's header declares
its shape and dtype ahead of the data, so a member holding objects (a pickle), strings, dates or
complex numbers, a negative or overflowing shape, data shorter than the header declares, or
arrays whose cells would not fit in memory is refused from the headers alone, with a QmeshError
naming the member, before any array is decompressed (a 3 MB file can declare gigabytes).
"""

from __future__ import annotations

import math
import zipfile
import zlib
import numpy as np

from qmesh import checks
from qmesh.conductivity.field import TensorField
from qmesh.errors import QmeshError
from qmesh.mesher import budget as memory


KEYS = ("x", "y", "k1", "k2")
"""The arrays a raster file must hold (and optionally "angle")."""
OPTIONAL = ("angle",)
BYTES_PER_CELL = 256
"""Peak bytes per raster cell of reading a file and building its field: the cells' three float
arrays (24) plus `TensorField.from_raster`'s tables and temporaries, 153 bytes per cell above its
inputs measured on a 1500 × 1500 raster, rounded up."""
MAX_HEADER = 10_000
"""numpy's own limit on a .npy header's length (numpy.lib.format, max_header_size)."""

_ZIP_ERRORS = (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, NotImplementedError)


def _refuse(path: str, text: str) -> QmeshError:
    return QmeshError(f"{path}: {text}")


def _header(archive: zipfile.ZipFile, info: zipfile.ZipInfo, path: str, key: str
            ) -> tuple[tuple[int, ...], bool, np.dtype]:
    """The member's declared (shape, fortran_order, dtype), read without its data."""
    try:
        with archive.open(info) as f:
            version = np.lib.format.read_magic(f)
            if version == (1, 0):
                return np.lib.format.read_array_header_1_0(f, max_header_size=MAX_HEADER)
            if version == (2, 0):
                return np.lib.format.read_array_header_2_0(f, max_header_size=MAX_HEADER)
    except _ZIP_ERRORS as e:
        raise _refuse(path, f"array {key} has no readable .npy header: {e}") from None
    raise _refuse(path, f"array {key} has .npy format version {version[0]}.{version[1]}; "
                  "numpy.savez writes 1.0 or 2.0")


def _declared_bytes(shape: tuple[int, ...], dtype: np.dtype, path: str, key: str) -> int:
    """The bytes the header declares, refusing negative sizes and non-numeric dtypes."""
    if any(n < 0 for n in shape):
        raise _refuse(path, f"array {key} declares the negative shape {shape}")
    try:
        checks.real_dtype(dtype, f"array {key}")
    except QmeshError as e:
        raise _refuse(path, str(e)) from None
    return math.prod(shape) * dtype.itemsize


def read_raster(path: str, budget: int | None = None) -> TensorField:
    """The raster field of a .npz holding x (nx+1,), y (ny+1,) (cell edges), k1, k2 (ny, nx)
    and optionally angle (ny, nx; degrees, default 0): what numpy.savez writes from the arrays a
    MODFLOW or geostatistics script already holds. Read without pickles; the headers are checked
    first, the cells' memory against `budget` bytes (default: `qmesh.mesher.budget`'s)."""
    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, EOFError, ValueError):
        raise _refuse(path, "not a NumPy .npz file (numpy.savez writes one from named arrays x, "
                      "y, k1, k2, angle)") from None
    with archive:
        members = {info.filename.removesuffix(".npy"): info for info in archive.infolist()}
        missing = [k for k in KEYS if k not in members]
        if missing:
            raise _refuse(path, f"a raster file needs arrays {', '.join(KEYS)} (and optionally "
                          f"angle); it has no {', '.join(missing)} (it has "
                          f"{', '.join(members) or 'no arrays'})")
        wanted = [k for k in (*KEYS, *OPTIONAL) if k in members]
        headers = {k: _header(archive, members[k], path, k) for k in wanted}
        sizes = {k: _declared_bytes(shape, dtype, path, k) for k, (shape, _, dtype) in headers.items()}
        cells = max(math.prod(headers[k][0]) for k in wanted)
        need = BYTES_PER_CELL * cells + sum(sizes.values())
        limit, whose = memory.default_budget_of() if budget is None else (budget, "the memory budget")
        if need > limit:
            raise _refuse(path, f"the raster's arrays declare {cells:.3g} cells, which need about "
                          f"{need / 2**30:.3g} GiB to read and build, more than {whose} "
                          f"({limit / 2**30:.3g} GiB); coarsen the raster")
        arrays = {}
        for k in wanted:
            with archive.open(members[k]) as f:
                try:
                    arrays[k] = np.lib.format.read_array(f, allow_pickle=False,
                                                         max_header_size=MAX_HEADER)
                except _ZIP_ERRORS as e:
                    raise _refuse(path, f"array {k} is truncated or corrupt: {e}") from None
    return TensorField.from_raster(arrays["x"], arrays["y"], arrays["k1"], arrays["k2"],
                                   arrays.get("angle", 0.0))
