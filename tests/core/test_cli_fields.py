"""`qmesh mesh --field-Q / --field-principal / --raster`: a field from the command line, its mesh
file carrying the element means `qmesh report` measures with; bad rasters refused in one line."""

import io
import subprocess
import sys
import zipfile

import numpy as np
import pytest

import qmesh
from qmesh.cli import main

SQUARE = "0,0\n1,0\n1,1\n0,1\n"


@pytest.fixture
def square(tmp_path):
    path = tmp_path / "square.csv"
    path.write_text(SQUARE)
    return str(path)


def test_a_field_principal_meshes_and_the_file_keeps_its_means(tmp_path, square, capsys):
    out = tmp_path / "layers.vtu"
    assert main(["mesh", "--field-principal", "1", "0.001", "30*sin(pi*x)", "--polygon", square,
                 "--target-vertices", "600", "-o", str(out)]) == 0
    line = capsys.readouterr().out
    assert "q_ij>=0: interior 100.0% boundary 100.0%" in line
    m = qmesh.io.read(out)
    assert m.conductivity is not None and m.conductivity.shape == (m.n_triangles, 2, 2)
    assert main(["report", str(out), "--json"]) == 0
    assert '"q_nonnegative_fraction": 1.0' in capsys.readouterr().out


def test_progress_names_the_certified_mesh_and_no_energy_without_s(tmp_path, square, capsys):
    """A field's last Step is its certified mesh: --progress says so (not a second
    "triangulate"), with its N beyond the loop's when the repair added vertices, and never
    prints an energy a field does not have."""
    out = tmp_path / "layers.vtu"
    assert main(["mesh", "--field-principal", "1", "0.001", "30*sin(pi*x)", "--polygon", square,
                 "--target-vertices", "400", "--progress", "-o", str(out)]) == 0
    lines = capsys.readouterr().err.splitlines()
    stages = [line.split()[2] for line in lines if line.startswith("iteration")]
    assert stages[-1] == "certified" and "certified" not in stages[:-1]
    assert stages[-2] == "triangulate"
    assert not any("nan" in line for line in lines)
    assert lines[-1].split()[3] == f"N={qmesh.io.read(out).n_vertices}"


def test_a_raster_file_meshes_at_the_target_not_the_cells(tmp_path, square, capsys):
    rng = np.random.default_rng(3)
    path = tmp_path / "k.npz"
    np.savez(path, x=np.linspace(0, 1, 41), y=np.linspace(0, 1, 41),
             k1=np.exp(rng.normal(0, 1, (40, 40))), k2=np.exp(rng.normal(0, 1, (40, 40))),
             angle=rng.uniform(0, 180, (40, 40)))
    out = tmp_path / "k.msh"
    assert main(["mesh", "--raster", str(path), "--polygon", square, "--target-vertices", "300",
                 "-o", str(out)]) == 0
    m = qmesh.io.read(out)
    assert abs(m.n_vertices - 300) <= 30 < 1600        # 300 vertices for 1600 different cells
    assert m.conductivity is not None


def test_a_raster_without_a_domain_meshes_its_rectangle_and_a_disk_outside_it_is_refused(
        tmp_path, capsys):
    rng = np.random.default_rng(4)
    path = tmp_path / "k.npz"
    np.savez(path, x=np.linspace(2.0, 5.0, 13), y=np.linspace(-1.0, 1.0, 9),
             k1=np.exp(rng.normal(0, 1, (8, 12))), k2=np.exp(rng.normal(0, 1, (8, 12))))
    out = tmp_path / "k.vtu"
    assert main(["mesh", "--raster", str(path), "--target-vertices", "300", "-o", str(out)]) == 0
    assert "q_ij>=0: interior 100.0% boundary 100.0%" in capsys.readouterr().out
    m = qmesh.io.read(out)
    np.testing.assert_allclose([m.points.min(axis=0), m.points.max(axis=0)],
                               [[2.0, -1.0], [5.0, 1.0]], atol=1e-12)
    assert main(["mesh", "--raster", str(path), "--disk", "64", "-o", str(tmp_path / "d.vtu")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("qmesh: error: the domain [-1, 1] × [-1, 1] reaches outside the cells")
    assert "[2, 5] × [-1, 1]" in err and err.count("\n") == 1


@pytest.mark.parametrize("arrays, message", [
    ({"x": np.linspace(0, 1, 3)}, "needs arrays x, y, k1, k2"),
    (None, "not a NumPy .npz file"),
])
def test_bad_raster_files_are_one_line(tmp_path, square, capsys, arrays, message):
    path = tmp_path / "bad.npz"
    if arrays is None:
        path.write_text("x,y\n1,2\n")
    else:
        np.savez(path, **arrays)
    assert main(["mesh", "--raster", str(path), "--polygon", square, "-o",
                 str(tmp_path / "x.vtu")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("qmesh: error:") and message in err and err.count("\n") == 1
    assert not (tmp_path / "x.vtu").exists()


REGIONS = ('{"type": "FeatureCollection", "features": ['
           '{"type": "Feature", "properties": {"region": 0}, "geometry": {"type": "Polygon", '
           '"coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}}, '
           '{"type": "Feature", "properties": {"region": "lens", "Q": [10, 0, 1]}, "geometry": '
           '{"type": "Polygon", "coordinates": [[[0.3, 0.3], [0.6, 0.3], [0.6, 0.6], [0.3, 0.6], [0.3, 0.3]]]}}]}')


def test_a_field_with_regions_writes_its_file_with_the_means(tmp_path, capsys):
    """--field-Q on a region file: the regions without a Q of their own hold the field; the
    mesh is written, with each triangle's mean (the field's, or the region's constant Q)."""
    regions, out = tmp_path / "r.geojson", tmp_path / "fr.vtu"
    regions.write_text(REGIONS)
    code = main(["mesh", "--field-Q", "1 + x", "0", "1", "--regions", str(regions),
                 "--target-vertices", "300", "-o", str(out)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "interface 100.0%" in captured.out
    m = qmesh.io.read(out)
    lens = m.region_tags == 1
    assert lens.any() and (~lens).any()
    np.testing.assert_allclose(m.conductivity[lens], np.broadcast_to([[10, 0], [0, 1]], (lens.sum(), 2, 2)))
    field = qmesh.TensorField.from_expressions("1 + x", 0, 1)
    np.testing.assert_allclose(m.conductivity[~lens], field.means(m.points, m.triangles[~lens]), rtol=1e-9)


@pytest.mark.parametrize("ext", [".mesh", ".obj"])
def test_a_format_without_cell_data_warns_in_one_line_and_quiet_silences_it(tmp_path, ext):
    """The writer's warning (the means are dropped) is the command's own one line, and
    --quiet silences it (a fresh interpreter: the warning is printed as a user sees it)."""
    out = tmp_path / f"f{ext}"
    command = [sys.executable, "-m", "qmesh", "mesh", "--field-Q", "1 + x", "0", "1",
               "--target-vertices", "150", "-o", str(out)]
    loud = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert loud.returncode == 0 and out.exists()
    assert loud.stderr.startswith("qmesh: warning: ") and loud.stderr.count("\n") == 1, loud.stderr
    assert "element means" in loud.stderr and "QmeshWarning" not in loud.stderr
    quiet = subprocess.run(command + ["--quiet"], capture_output=True, text=True, timeout=120)
    assert quiet.returncode == 0 and quiet.stderr == ""


@pytest.mark.parametrize("option, values", [
    ("--field-principal", ["2", "1", "-30+10*x"]),
    ("--field-Q", ["1", "-0.2*x", "1"]),
    ("--field-Q", ["-x**2+2", "0", "1"]),
])
def test_a_field_text_starting_with_a_minus_is_a_value(tmp_path, square, capsys, option, values):
    out = tmp_path / "minus.vtu"
    assert main(["mesh", option, *values, "--polygon", square, "--target-vertices", "150",
                 "-o", str(out)]) == 0, capsys.readouterr().err
    assert qmesh.io.read(out).conductivity is not None
    assert main(["mesh", f"-o{tmp_path / 'short.vtu'}", "--target-vertices", "150"]) == 0   # -oOUT still


def test_the_field_options_help_says_how_to_write_a_leading_minus(capsys):
    assert main(["mesh", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert text.count("a text may start with - (e.g. '-1 + x', '-x**2'); write a lone -x as '(-x)'") == 2


def _npz(path, members):
    """A .npz written member by member: name → the bytes of its .npy, or an array (numpy's own)."""
    with zipfile.ZipFile(path, "w") as z:
        for name, value in members.items():
            if isinstance(value, np.ndarray):
                buffer = io.BytesIO()
                np.lib.format.write_array(buffer, value, allow_pickle=True)
                value = buffer.getvalue()
            z.writestr(f"{name}.npy", value)


def _header_only(shape, descr="<f8", data=b""):
    """The bytes of a .npy that declares `shape` and `descr` and holds `data`."""
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(buffer, {"descr": descr, "fortran_order": False, "shape": shape})
    return buffer.getvalue() + data


EDGES = {"x": np.linspace(0, 1, 5), "y": np.linspace(0, 1, 4), "k2": np.ones((3, 4))}


@pytest.mark.parametrize("k1, message", [
    (np.array([[object()] * 4] * 3, dtype=object), "array k1 must hold real numbers, got an object array"),
    (_header_only((3, 4), data=b"\0" * 40), "array k1 is truncated or corrupt"),
    (_header_only((-3, 4)), "array k1 declares the negative shape (-3, 4)"),
    (_header_only((2**62, 2**62)), "the raster's arrays declare 2.13e+37 cells"),
    (_header_only((100_000, 100_000), data=b"\0" * 1000), "declare 1e+10 cells, which need about"),
    (np.ones((3, 4), dtype=complex), "got a complex array"),
    (np.ones((3, 4), dtype="datetime64[s]"), "got a datetime64 array"),
    (b"not a .npy", "array k1 has no readable .npy header"),
])
def test_hostile_raster_members_are_refused_from_their_headers(tmp_path, square, capsys, k1, message,
                                                                 monkeypatch):
    """Each member's header declares its shape and dtype before its data: a raster file that
    would inflate past the memory budget, hold objects, or end early is one error line, exit 2,
    and its data is never read (read_array is not called for a member refused by its header)."""
    read, real = [], np.lib.format.read_array
    monkeypatch.setattr(np.lib.format, "read_array", lambda f, **k: read.append(1) or real(f, **k))
    path = tmp_path / "hostile.npz"
    _npz(path, {**EDGES, "k1": k1})
    assert main(["mesh", "--raster", str(path), "--polygon", square, "-o", str(tmp_path / "x.vtu")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"qmesh: error: {path}: ") and message in err and err.count("\n") == 1, err
    assert "truncated" in message or read == []


def test_a_bad_field_text_names_its_component(tmp_path, capsys):
    assert main(["mesh", "--field-Q", "1", "0", "__import__('os')", "-o",
                 str(tmp_path / "x.vtu")]) == 2
    assert "q22(x, y)" in capsys.readouterr().err


def test_a_medium_prints_its_warnings(tmp_path, capsys):
    """A thin region pushes N past the target: the command says so, as the API warns."""
    regions = tmp_path / "thin.geojson"
    regions.write_text('{"type": "FeatureCollection", "features": ['
                       '{"type": "Feature", "properties": {"region": 0}, "geometry": {"type": "Polygon", '
                       '"coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}},'
                       '{"type": "Feature", "properties": {"region": "thin", "principal": [1, 100, 45]}, '
                       '"geometry": {"type": "Polygon", "coordinates": [[[0, 0.5], [1, 0.5], [1, 0.502], '
                       '[0, 0.502], [0, 0.5]]]}}]}')
    assert main(["mesh", "--regions", str(regions), "--target-vertices", "100", "-o",
                 str(tmp_path / "m.vtu")]) == 0
    err = capsys.readouterr().err
    assert qmesh.io.read(tmp_path / "m.vtu").n_vertices > 1000          # the thin region's need
    assert "qmesh: warning: target_vertices = 100: the mesh has" in err
    assert "qmesh: warning: region 1 (thin):" in err
