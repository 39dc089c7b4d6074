"""The results table reads back what was written, for CSV and Parquet alike: every column, its
type, None as None and floats to the last bit."""

import math

import pytest

from qmesh import QmeshError
from qmesh.sweep import COLUMNS, read_rows, write_rows

ROWS = [
    {**dict.fromkeys(COLUMNS), "domain": "disk", "conductivity": "s=exp(x) + y**2", "target_vertices": 300,
     "seed": 0, "n_vertices": 301, "kappa2": 1 / 3, "q_nonnegative_fraction": 0.1 + 0.2, "seconds": 1e-300,
     "mesh": "/tmp/m,1.vtu", "warning": 'a "quoted", line'},
    {**dict.fromkeys(COLUMNS), "domain": "L-shape", "conductivity": "Q=[[0.1, 0], [0, 10]]",
     "target_vertices": 10, "seed": 7, "error": "target_vertices = 10 must exceed the 6 input points"},
]


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_round_trip_keeps_types_and_values(tmp_path, suffix):
    path = tmp_path / f"r{suffix}"
    write_rows(path, ROWS)
    back = read_rows(path)
    assert back == ROWS
    assert isinstance(back[0]["n_vertices"], int) and isinstance(back[0]["kappa2"], float)
    assert list(back[0]) == list(COLUMNS)
    assert not any(p.name.endswith(".partial") for p in tmp_path.iterdir())


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_empty_table_round_trip(tmp_path, suffix):
    write_rows(tmp_path / f"r{suffix}", [])
    assert read_rows(tmp_path / f"r{suffix}") == []


def test_a_table_of_something_else_is_refused(tmp_path):
    (tmp_path / "r.csv").write_text("domain,seed\ndisk,0\n")
    with pytest.raises(QmeshError, match="no column conductivity, target_vertices, mesh, error"):
        read_rows(tmp_path / "r.csv")
    (tmp_path / "r.parquet").write_bytes(b"not parquet")
    with pytest.raises(QmeshError, match="cannot read .* as a Parquet table"):
        read_rows(tmp_path / "r.parquet")
    assert math.isclose(1 / 3, ROWS[0]["kappa2"])
