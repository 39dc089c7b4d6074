"""The results table: one row per job, as CSV or Parquet by the file's extension.

CSV is written with the standard library (floats in their exact shortest form, None as an empty
cell) and read back with the column types below; Parquet goes through pyarrow, which the
`sweep` extra installs. Every write replaces the whole file at once (a temporary file renamed
over it), so an interrupted sweep leaves the last complete table, never half a row.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

from qmesh.errors import QmeshError

COLUMNS = {
    "domain": str, "conductivity": str, "target_vertices": int, "seed": int,
    "n_vertices": int, "n_triangles": int, "n_boundary": int,
    "kappa2": float, "q_nonnegative_fraction": float, "q_nonnegative_fraction_boundary": float,
    "min_quality": float, "mean_quality": float, "l2_error": float, "h1_error": float,
    "seconds": float, "mesh": str, "worker": str, "warning": str, "error": str,
}
"""Column → type, in the table's order. `seconds` is the meshing time of `qmesh.mesh`."""

KEY = ("domain", "conductivity", "target_vertices", "seed")
SUFFIXES = (".csv", ".parquet")


def check_path(path) -> Path:
    """The table's path, refused before any job runs when its format or folder is wrong."""
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise QmeshError(f"the results table must end in .csv or .parquet, got {str(path)!r}")
    if not path.parent.is_dir():
        raise QmeshError(f"no folder {str(path.parent)!r} for the results table {str(path)!r}")
    if path.suffix.lower() == ".parquet":
        _pyarrow()
    return path


def row_key(row: dict) -> tuple:
    """What identifies a row's job (the same as `Job.key`)."""
    return tuple(row[k] for k in KEY)


def read_rows(path) -> list[dict]:
    """The rows of an existing table, typed as COLUMNS says; QmeshError if it is not one."""
    path = Path(path)
    if path.suffix.lower() == ".parquet":
        try:
            pq = _pyarrow()
            rows = pq.read_table(path).to_pylist()
        except QmeshError:
            raise
        except Exception as e:  # noqa: BLE001 — pyarrow's errors have no common base
            raise QmeshError(f"cannot read {str(path)!r} as a Parquet table: {e}") from e
        names = set(rows[0]) if rows else set(pq.read_schema(path).names)
    else:
        try:
            with open(path, newline="", encoding="utf-8") as f:
                reader = csv.DictReader(f)
                rows = [{k: _typed(k, v) for k, v in r.items() if k in COLUMNS} for r in reader]
                names = set(reader.fieldnames or ())
        except (UnicodeDecodeError, csv.Error, ValueError) as e:
            raise QmeshError(f"{str(path)!r} is not a results table of qmesh sweep: {e}") from e
    missing = [k for k in (*KEY, "mesh", "error") if k not in names]
    if missing:
        raise QmeshError(f"{str(path)!r} is not a results table of qmesh sweep (no column "
                         f"{', '.join(missing)}); choose another -o or remove it")
    return [{k: r.get(k) for k in COLUMNS} for r in rows]


def write_rows(path, rows: list[dict]) -> None:
    """Replace the table with `rows` (every column of COLUMNS, in its order)."""
    path = Path(path)
    partial = path.with_name(f".{path.name}.partial")
    if path.suffix.lower() == ".parquet":
        pa, pq = _pyarrow(with_arrow=True)
        kinds = {str: pa.string(), int: pa.int64(), float: pa.float64()}
        schema = pa.schema([(k, kinds[t]) for k, t in COLUMNS.items()])
        pq.write_table(pa.Table.from_pylist([{k: r.get(k) for k in COLUMNS} for r in rows], schema), partial)
    else:
        with open(partial, "w", newline="", encoding="utf-8") as f:
            w = csv.DictWriter(f, fieldnames=list(COLUMNS), extrasaction="ignore")
            w.writeheader()
            w.writerows({k: "" if r.get(k) is None else r.get(k) for k in COLUMNS} for r in rows)
    os.replace(partial, path)


def _typed(column: str, text: str | None):
    if text is None or text == "":
        return None
    return COLUMNS[column](text)


def _pyarrow(with_arrow: bool = False):
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as e:
        raise QmeshError(f"a .parquet table needs pyarrow (pip install 'qmesh[sweep]'); or write .csv: {e}") from e
    return (pa, pq) if with_arrow else pq
