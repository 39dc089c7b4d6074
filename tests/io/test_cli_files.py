"""The CLI on files that could fool it: folds are reported, hostile inputs end in one error
line with exit 2, and a closed stdout ends quietly."""

import os
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest

import qmesh
from qmesh import io

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "core"))
from cli_run import run  # noqa: E402


def _report_lines(out):
    return dict(line.split(None, 1) for line in out.splitlines()[1:])


def test_report_counts_a_fold_and_a_duplicate(tmp_path, capsys):
    """A folded 5-vertex mesh (one clockwise triangle) and a doubled triangle."""
    P = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0], [1, 0.5, 0]], float)
    T = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [1, 4, 2]])  # the last: [1, 2, 4] turned
    meshio.write(tmp_path / "fold.vtu", meshio.Mesh(P, [("triangle", T)]))
    code, out, err = run(capsys, "report", tmp_path / "fold.vtu")
    rep = _report_lines(out)
    assert code == 0 and int(rep["inverted_triangles"]) == 1 and int(rep["folded_triangles"]) == 2


def test_report_of_a_valid_mesh_has_no_folds(tmp_path, capsys, plate):
    io.write(tmp_path / "plate.msh", plate)
    code, out, _ = run(capsys, "report", tmp_path / "plate.msh")
    assert code == 0 and _report_lines(out)["folded_triangles"] == "0"


@pytest.mark.parametrize("name, content", [
    ("deep.geojson", "[" * 100000),
    ("digits400.geojson", '{"type": "Polygon", "coordinates": [[[0, 0], [' + "9" * 400 + ', 0], [0, 1]]]}'),
    ("digits5000.geojson", '{"type": "Polygon", "coordinates": [[[0, 0], [' + "9" * 5000 + ', 0], [0, 1]]]}'),
    ("huge.csv", "0,0\n1e300,0\n0,1\n"),
    ("nan.geojson", '{"type": "Polygon", "coordinates": [[[0, 0], [NaN, 0], [0, 1]]]}'),
    ("typo.csv", "1O,0\n1,0\n1,1\n0,1\n"),
])
def test_hostile_polygon_files_are_one_error_line(tmp_path, capsys, name, content):
    (tmp_path / name).write_text(content)
    code, out, err = run(capsys, "mesh", "--polygon", tmp_path / name, "--target-vertices", 30,
                         "-o", tmp_path / "m.vtu", "--quiet")
    assert code == 2 and out == "" and err.startswith("qmesh: error: ") and err.count("\n") == 1
    assert not (tmp_path / "m.vtu").exists()


def test_truncated_mesh_file_is_one_error_line(tmp_path, capsys, plate):
    io.write(tmp_path / "plate.msh", plate)
    text = (tmp_path / "plate.msh").read_text()
    (tmp_path / "cut.msh").write_text(text[: len(text) // 2])
    code, out, err = run(capsys, "report", tmp_path / "cut.msh")
    assert code == 2 and out == "" and err.startswith("qmesh: error: ") and err.count("\n") == 1


@pytest.mark.parametrize("old, new", [
    ("\n1 ", "\n1 1e300 "),                  # a node beyond any sane coordinate
    ("\n1 ", "\n1 nan "),                    # NaN
    ("\n1 ", "\n1 " + "9" * 5000 + " "),     # a 5000-digit number
    ("$EndNodes", "$EndNodes\n$Elements\n1\n1 99 2 1 1 1 2\n$EndElements"),  # an element type meshio has not
    ('{"qmesh": 1', "[" * 100000),            # qmesh's metadata deeply nested
])
def test_hostile_mesh_file_is_one_error_line(tmp_path, capsys, plate, old, new):
    io.write(tmp_path / "plate.msh", plate, anisotropy=qmesh.Anisotropy.principal(1, 50, 30))
    text = (tmp_path / "plate.msh").read_text()
    assert old in text
    (tmp_path / "bad.msh").write_text(text.replace(old, new, 1))
    code, out, err = run(capsys, "report", tmp_path / "bad.msh")
    assert code == 2 and out == "" and err.startswith("qmesh: error: ") and err.count("\n") == 1, err


def test_closed_stdout_ends_quietly(tmp_path, plate):
    io.write(tmp_path / "plate.vtu", plate)
    qmesh = Path(sys.executable).with_name("qmesh")
    proc = subprocess.Popen([str(qmesh), "report", str(tmp_path / "plate.vtu")], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env={**os.environ, "PYTHONUNBUFFERED": ""})
    proc.stdout.close()  # the reader has gone before qmesh writes (as `| head -0` would)
    err = proc.stderr.read()
    assert proc.wait(timeout=120) == 0 and err == b""
