"""`qmesh mesh --s TEXT` and `qmesh report --s TEXT`: s typed on the command line."""

import json

import numpy as np
import pytest

import qmesh
from qmesh import io

from cli_run import run


def test_mesh_and_report_with_s_as_text(tmp_path, capsys):
    out_file = tmp_path / "exp.vtu"
    code, out, err = run(capsys, "mesh", "--s", "exp(x) + y**2", "--disk", 32, "--target-vertices", 150,
                         "--seed", 3, "--json", "-o", out_file)
    assert code == 0, err
    summary = json.loads(out)
    m = io.read(out_file)
    A = qmesh.Anisotropy.from_expression("exp(x) + y**2")
    expected = qmesh.mesh(qmesh.Disk(32), A, target_vertices=150, seed=3)
    np.testing.assert_allclose(m.points, expected.points, atol=1e-12)
    assert summary["min_quality"] == pytest.approx(qmesh.measure.quality(m, A).min(), rel=1e-9)

    code, out, err = run(capsys, "report", out_file, "--s", "exp(x) + y**2", "--json")
    assert code == 0, err
    rep = json.loads(out)
    assert rep["kappa2"] == pytest.approx(qmesh.measure.report(m, A)["kappa2"], rel=1e-9)
    # without --s the file's stored expression is used; the chapter's constant Q measures
    # something else
    code, out, _ = run(capsys, "report", out_file, "--json")
    assert json.loads(out)["kappa2"] == pytest.approx(rep["kappa2"], rel=1e-9)
    code, out, _ = run(capsys, "report", out_file, "--Q", "0.1", "0", "10", "--json")
    assert json.loads(out)["kappa2"] != pytest.approx(rep["kappa2"], rel=1e-3)


@pytest.mark.parametrize("text, message", [
    ("__import__('os').system('touch X')", "__import__('os').system"),
    ("open('X', 'w')", "'open'"),
    ("(lambda: 1)()", "lambda"),
    ("[x for x in (1, 2)]", "comprehension"),
    ("globals()", "'globals'"),
    ("x.__class__", "attribute access"),
    (" + ".join(["x"] * 200_000), "characters long"),
    ("9**9**9**9", "overflows"),
    ("", "empty"),
    ("x**2 - y**2", "not strictly convex"),
    ("sqrt(x) + y**2", "finite"),                    # refused at mesh time (NaN Hessian)
])
def test_refused_text_exits_2_with_one_line_and_no_file(text, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out_file = tmp_path / "m.vtu"
    code, out, err = run(capsys, "mesh", f"--s={text}", "--disk", 16, "--target-vertices", 40, "-o", out_file)
    assert code == 2
    assert out == ""
    line, = err.splitlines()
    assert line.startswith("qmesh: error: ") and message in line
    assert list(tmp_path.iterdir()) == []          # neither the mesh nor the file X


def test_report_refuses_a_bad_text(tmp_path, capsys, delaunay_mesh):
    path = tmp_path / "m.vtu"
    io.write(path, delaunay_mesh)
    code, out, err = run(capsys, "report", path, "--s", "exp(x) + y.real")
    assert code == 2 and out == ""
    assert err.startswith("qmesh: error: ") and "'y.real': attribute access" in err


def test_s_excludes_a_constant_q(tmp_path, capsys):
    code, _, err = run(capsys, "mesh", "--s", "exp(x) + y**2", "--Q", 1, 0, 1, "-o", tmp_path / "m.vtu")
    assert code == 2 and "not allowed with argument" in err
    assert list(tmp_path.iterdir()) == []
