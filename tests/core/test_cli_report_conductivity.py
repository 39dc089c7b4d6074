"""`qmesh report` measures with the conductivity the file stores, and always says which one."""

import json

import meshio
import numpy as np
import pytest

import qmesh
from qmesh import io
from qmesh.io import conductivity as file_conductivity

from cli_run import run


@pytest.fixture
def rotated_mesh_file(tmp_path, capsys):
    """A mesh that `qmesh mesh` made for a rotated Q."""
    path = tmp_path / "rotated.vtu"
    code, _, err = run(capsys, "mesh", "--principal", 1, 100, 30, "-o", path)
    assert code == 0, err
    return path


def test_report_uses_the_stored_q(rotated_mesh_file, capsys):
    code, out, _ = run(capsys, "report", rotated_mesh_file, "--json")
    assert code == 0
    rep = json.loads(out)
    assert rep["conductivity_source"] == "file"
    rotated = qmesh.Anisotropy.principal(1, 100, 30)
    assert rep["conductivity"] == file_conductivity.record_of(rotated).split(": ", 1)[1]
    assert rep["n_interior"] > 0 and rep["q_nonnegative_fraction"] == 1.0
    # measured with the chapter's Q instead, the same mesh loses that
    code, out, _ = run(capsys, "report", rotated_mesh_file, "--json", "--Q", 0.1, 0, 10)
    rep = json.loads(out)
    assert rep["conductivity_source"] == "command line" and rep["conductivity"] == "Q = [[0.1, 0.0], [0.0, 10.0]]"
    assert rep["q_nonnegative_fraction"] < 0.9


def test_report_text_names_the_conductivity(rotated_mesh_file, capsys):
    code, out, _ = run(capsys, "report", rotated_mesh_file)
    first = out.splitlines()[0]
    assert code == 0 and first.startswith(f"{rotated_mesh_file}: conductivity Q = [[25.7")
    assert first.endswith("(stored in the file)")
    code, out, _ = run(capsys, "report", rotated_mesh_file, "--principal", 2, 3, 0)
    assert out.splitlines()[0].endswith(": conductivity Q = [[2.0, 0.0], [0.0, 3.0]] (from the command line)")


def test_report_says_when_it_falls_back_to_the_chapter_q(tmp_path, capsys, delaunay_mesh):
    path = tmp_path / "other.vtu"
    P = np.column_stack([delaunay_mesh.points, np.zeros(delaunay_mesh.n_vertices)])
    meshio.write(path, meshio.Mesh(P, [("triangle", delaunay_mesh.triangles)]))
    code, out, _ = run(capsys, "report", path)
    assert code == 0
    assert out.splitlines()[0] == (f"{path}: conductivity Q = [[0.1, 0.0], [0.0, 10.0]] "
                                   "(the chapter's default: the file stores none)")
    code, out, _ = run(capsys, "report", path, "--json")
    assert json.loads(out)["conductivity_source"] == "default"


def test_report_of_a_file_with_a_broken_record_is_one_error_line(tmp_path, capsys, delaunay_mesh):
    path = tmp_path / "m.obj"
    io.write(path, delaunay_mesh)
    body = path.read_text().split("\n", 1)[1]
    path.write_text('# qmesh {"qmesh": 1, "conductivity": {"Q": [[1.0, 2.0], [2.0, 1.0]]}}\n' + body)
    code, out, err = run(capsys, "report", path)
    assert code == 2 and out == ""
    assert err.startswith("qmesh: error: ") and "stored conductivity is not valid" in err and err.count("\n") == 1


def test_report_text_gives_a_rotated_q_to_six_digits(rotated_mesh_file, capsys):
    """--principal's Q is a rotation's cosines and sines: the table shows 6 significant digits
    (25.75, −99·cos 30°·sin 30° = −42.8683, 75.25); --json keeps the exact record."""
    code, out, _ = run(capsys, "report", rotated_mesh_file, "--principal", 1, 100, 30)
    first = out.splitlines()[0]
    assert code == 0 and first.endswith(": conductivity Q = [[25.75, -42.8683], [-42.8683, 75.25]] "
                                        "(from the command line)"), first
    code, out, _ = run(capsys, "report", rotated_mesh_file, "--principal", 1, 100, 30, "--json")
    exact = file_conductivity.record_of(qmesh.Anisotropy.principal(1, 100, 30)).split(": ", 1)[1]
    assert json.loads(out)["conductivity"] == exact and len(exact) > len(first.split("conductivity ")[1])


def test_a_min_q_within_the_shares_tolerance_prints_as_zero(rotated_mesh_file, capsys, monkeypatch):
    """A min_q_ij_relative of −5e-15 (rounding) is counted as q_ij ≥ 0 by the shares: the table
    prints it as 0 beside a share of 1, and prints −2e-9, beyond the tolerance, as it is."""
    real = qmesh.measure.report

    def rounded(*a, **k):
        rep = real(*a, **k)
        rep.update(min_q_ij_relative=-5e-15, min_q_ij_relative_boundary=-2e-9)
        return rep

    monkeypatch.setattr(qmesh.measure, "report", rounded)
    code, out, _ = run(capsys, "report", rotated_mesh_file)
    rows = dict(line.split() for line in out.splitlines()[1:])
    assert code == 0 and rows["q_nonnegative_fraction"] == "1"
    assert rows["min_q_ij_relative"] == "0" and rows["min_q_ij_relative_boundary"] == "-2e-09"
    code, out, _ = run(capsys, "report", rotated_mesh_file, "--json")
    assert json.loads(out)["min_q_ij_relative"] == -5e-15


@pytest.mark.parametrize("bad", [[[0.0, 0.0], [0.0, 0.0]], [[1.0, 2.0], [2.0, 1.0]], [[-1.0, 0.0], [0.0, 1.0]]])
def test_report_refuses_stored_means_that_are_not_positive_definite(tmp_path, capsys, delaunay_mesh, bad):
    """Means Q11 Q12 Q22 written by any program are measured only when each is SPD, as qmesh
    mesh refuses such a Q: zeros, an indefinite or a negative one is one error line naming the
    triangle, exit 2."""
    Q = np.broadcast_to(np.eye(2), (delaunay_mesh.n_triangles, 2, 2)).copy()
    Q[3] = bad
    path = tmp_path / "means.vtu"
    io.write(path, qmesh.Mesh(delaunay_mesh.points, delaunay_mesh.triangles, delaunay_mesh.fixed,
                              conductivity=Q))
    code, out, err = run(capsys, "report", path)
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith(f"qmesh: error: {path}: the element means") and "the first that of triangle 3:" in err
    Q[3] = np.eye(2)
    io.write(path, qmesh.Mesh(delaunay_mesh.points, delaunay_mesh.triangles, delaunay_mesh.fixed,
                              conductivity=Q))
    assert run(capsys, "report", path)[0] == 0
