"""The `qmesh` command line, run in-process through qmesh.cli.main (one test runs the installed script)."""

import json
import shutil
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

import qmesh
from qmesh import io
from qmesh.cli import main

from cli_run import run

ROOT = Path(__file__).resolve().parents[2]


def test_mesh_writes_a_readable_file_and_a_summary(tmp_path, capsys):
    out_file = tmp_path / "disk32.vtu"
    code, out, err = run(capsys, "mesh", "--disk", 32, "--target-vertices", 101, "-o", out_file)
    assert code == 0, err
    m = io.read(out_file)
    assert abs(m.n_vertices - 101) <= 10
    assert m.fixed.sum() == 32
    line, = out.splitlines()
    assert f"N={m.n_vertices} " in line and f"triangles={m.n_triangles} " in line
    assert "q_ij>=0: " in line and "iterations=" in line and "time=" in line
    assert err == ""  # stderr is not a terminal and --progress was not given


def test_mesh_json_summary_matches_the_file(tmp_path, capsys):
    out_file = tmp_path / "m.msh"
    code, out, _ = run(capsys, "mesh", "--principal", 10, 0.1, 90, "--disk", 24, "--target-vertices", 80,
                       "--seed", 3, "--json", "-o", out_file)
    assert code == 0
    summary = json.loads(out)
    m = io.read(out_file)
    assert summary["n_vertices"] == m.n_vertices and summary["n_triangles"] == m.n_triangles
    assert summary["iterations"] >= 1 and summary["seconds"] > 0
    # --principal 10 0.1 90 is the chapter's Q = diag(0.1, 10) rotated onto itself
    chapter = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    q = qmesh.measure.quality(m, chapter)
    assert summary["min_quality"] == pytest.approx(q.min(), rel=1e-9)
    assert summary["mean_quality"] == pytest.approx(q.mean(), rel=1e-9)
    assert summary["q_nonnegative_fraction"] == qmesh.measure.q_nonnegative_fraction(m, chapter)


def test_progress_lines_on_request_only(tmp_path, capsys):
    args = ("mesh", "--disk", 16, "--target-vertices", 60, "-o", tmp_path / "m.vtu")  # 40: no interior vertex, a warning
    code, _, err = run(capsys, *args, "--progress")
    assert code == 0
    lines = err.splitlines()
    assert len(lines) >= 3 and lines[0].split()[2] == "triangulate"
    assert {line.split()[2] for line in lines} <= {"triangulate", "adjust", "insert"}
    assert all("N=" in line and "E=" in line and "min q=" in line for line in lines)
    code, _, err = run(capsys, *args, "--progress", "--quiet")
    assert code == 0 and err == ""


def test_mesh_polygon_csv_with_header(tmp_path, capsys):
    csv = tmp_path / "square.csv"
    csv.write_text("x,y\n0,0\n1,0\n1,1\n0,1\n")
    code, _, err = run(capsys, "mesh", "--polygon", csv, "--Q", 1, 0, 1, "--target-vertices", 30,
                       "-o", tmp_path / "sq.mesh")
    assert code == 0, err
    m = io.read(tmp_path / "sq.mesh")
    corners = m.points[m.fixed]
    assert sorted(map(tuple, corners.round(12).tolist())) == [(0, 0), (0, 1), (1, 0), (1, 1)]
    assert np.all((m.points >= -1e-12) & (m.points <= 1 + 1e-12))


def test_report_text_and_json(tmp_path, capsys, delaunay_mesh, chapter_anisotropy):
    path = tmp_path / "made_elsewhere.vtk"
    io.write(path, delaunay_mesh)
    code, out, _ = run(capsys, "report", path, "--json")
    assert code == 0
    rep = json.loads(out)
    expected = qmesh.measure.report(delaunay_mesh, chapter_anisotropy)
    assert rep["file"] == str(path)
    assert rep["n_vertices"] == delaunay_mesh.n_vertices
    assert rep["kappa2"] == pytest.approx(expected["kappa2"], rel=1e-9)
    code, out, _ = run(capsys, "report", path, "--Q", 1, 0, 1)
    assert code == 0
    rows = dict(line.split() for line in out.splitlines()[1:])
    laplace = qmesh.measure.report(delaunay_mesh, qmesh.Anisotropy.constant(np.eye(2)))
    assert float(rows["kappa2"]) == pytest.approx(laplace["kappa2"], rel=1e-5)
    assert int(rows["n_triangles"]) == delaunay_mesh.n_triangles
    assert rows["monotonicity"] == laplace["monotonicity"] == "M-matrix"    # Delaunay, Q = I
    assert rep["monotonicity"] == expected["monotonicity"]


def test_table_delegates_to_compare(monkeypatch, capsys):
    calls = []

    def run_table(vb, out, peers, solve, progress=None, scheduler=None, workers=None):
        calls.append((vb, out, peers, solve, scheduler, workers))
        return "| VB | N |\n|---|---|\n| 32 | 101 |"

    table = types.ModuleType("qmesh.compare.table")
    table.run_table = run_table
    compare = types.ModuleType("qmesh.compare")
    compare.table = table
    monkeypatch.setitem(sys.modules, "qmesh.compare", compare)
    monkeypatch.setitem(sys.modules, "qmesh.compare.table", table)
    code, out, _ = run(capsys, "table", "--vb", 32, 45, "--out", "somewhere", "--peers", "--workers", 3)
    assert code == 0
    assert calls == [([32, 45], "somewhere", True, False, None, 3)]
    assert out == run_table(None, None, None, None) + "\n"


def test_installed_console_script():
    exe = shutil.which("qmesh")
    assert exe is not None, "the qmesh console script is not installed (pip install -e .)"
    done = subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0
    assert all(cmd in done.stdout for cmd in ("mesh", "report", "table"))


def test_every_package_folder_is_installed():
    """pyproject lists packages explicitly (app/ installs as qmesh_view): a new folder must be added."""
    tomllib = pytest.importorskip("tomllib")
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(config["packages"])
    roots = {"qmesh": ROOT / "qmesh", **{k: ROOT / v for k, v in config["package-dir"].items()}}
    found = {root_name + "".join("." + p for p in init.parent.relative_to(folder).parts)
             for root_name, folder in roots.items() for init in folder.rglob("__init__.py")}
    assert found <= listed, f"add to [tool.setuptools] packages: {sorted(found - listed)}"


def test_cli_meshes_through_the_api_and_refuses_a_target_it_cannot_meet(tmp_path, capsys):
    """The CLI runs qmesh.mesh (progress through its callback): a target that keeping q_ij ≥ 0
    would overshoot by more than 10% is refused as in the API, with no file."""
    out = tmp_path / "m.vtu"
    assert main(["mesh", "--disk", "8", "--principal", "1", "5", "0", "--target-vertices", "9",
                 "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "target_vertices = 9" in err and err.count("\n") == 1
    assert not out.exists()


@pytest.mark.parametrize("argv", [["--version"], ["--vers"], ["--bogus", "--version"]])
def test_version_loads_neither_the_mesher_nor_numpy(argv):
    """`qmesh --version` answers from a fresh interpreter without importing what meshing needs."""
    heavy = ("numpy", "scipy", "scipy.sparse.linalg", "sympy", "meshio", "qmesh.meshing", "qmesh.io")
    code = ("import sys; from qmesh.cli import main; code = main(%r); "
            "print(code, [m for m in %r if m in sys.modules])" % (argv, heavy))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                          cwd=ROOT)
    assert done.stdout.splitlines() == [f"qmesh {qmesh.__version__}", "0 []"], done.stderr


def test_the_package_imports_its_public_names_on_first_use():
    """`import qmesh` alone loads no NumPy; each public name still resolves to its object."""
    code = ("import sys, qmesh; before = 'numpy' in sys.modules; "
            "names = [getattr(qmesh, n) for n in qmesh.__all__]; "
            "print(before, all(n is not None for n in names), qmesh.io.read is qmesh.io.formats.read)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                          cwd=ROOT)
    assert done.stdout.split() == ["False", "True", "True"], done.stderr
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        qmesh.nothing
    done = subprocess.run([sys.executable, "-c", "import qmesh; print(qmesh.geometry.__name__)"],
                          capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert done.stdout.split() == ["qmesh.geometry"], done.stderr
