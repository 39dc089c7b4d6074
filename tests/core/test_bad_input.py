"""Bad input: one QmeshError type, a message naming the problem, nothing written."""

import re

import numpy as np
import pytest

import qmesh
from qmesh import QmeshError
from qmesh.cli import main

# Corners of simple test polygons, as CSV text (no code under test made them).
SQUARE = "0,0\n1,0\n1,1\n0,1\n"
NON_CONVEX = "0,0\n2,0\n2,2\n1,1\n0,2\n"                      # reflex corner at (1, 1)
PENTAGRAM = "\n".join(f"{np.cos(a):.17g},{np.sin(a):.17g}"           # winds twice, every turn to the left
                      for a in np.deg2rad([90, 234, 18, 162, 306]))
CLOCKWISE = "0,0\n0,1\n1,1\n1,0\n"


@pytest.mark.parametrize("args, message", [
    (["--Q", "1", "2", "1"], "positive definite"),
    (["--Q", "-1", "0", "1"], "positive definite"),
    (["--Q", "nan", "0", "1"], "non-finite"),
    (["--Q", "1", "inf", "1"], "non-finite"),
    (["--principal", "0", "1", "0"], "k1 must be a finite number > 0, got 0.0"),
    (["--principal", "1", "-2", "30"], "k2 must be a finite number > 0, got -2.0"),
    (["--principal", "1", "1", "nan"], "angle_deg must be a finite number, got nan"),
    (["--disk", "2"], "VB must be at least 3"),
    (["--polygon", "{pentagram}"], "the outline intersects itself: segment 0 .* meets segment 2"),
    (["--polygon", "{three_columns}"], "two columns"),
    (["--polygon", "{words}"], "not a CSV of x,y numbers"),
    (["--polygon", "{missing}"], "cannot read polygon file"),
    (["--polygon", "{header_only}"], "has no points"),
    (["--polygon", "{two_points}"], "at least 3 points"),
    # metric area π·√det Q / (√3/4 · 1e-12) / 2 ≈ 3.6e12 vertices
    (["--size", "1e-6"], r"about 3\.\d+e\+12 vertices.*of memory"),
    (["--target-vertices", "1000000000"], r"1e\+09 vertices.*of memory"),
    (["--size", "0"], "size must be a finite number > 0"),
    (["--size", "nan"], "size must be a finite number > 0"),
    (["--alpha", "1.5"], r"alpha must be in \(0, 1\]"),
    (["--target-vertices", "10"], "must exceed the 64 input points"),
])
def test_mesh_bad_input(tmp_path, capsys, args, message):
    files = {"non_convex": NON_CONVEX, "pentagram": PENTAGRAM, "clockwise": CLOCKWISE,
             "three_columns": "0,0,0\n1,0,0\n0,1,0\n", "words": "x,y\na,b\nc,d\n",
             "header_only": "x,y\n", "two_points": "0,0\n1,0\n"}
    for name, text in files.items():
        (tmp_path / f"{name}.csv").write_text(text)
    args = [a.format(missing=tmp_path / "missing.csv", **{k: tmp_path / f"{k}.csv" for k in files}) for a in args]
    out = tmp_path / "out.vtu"
    before = sorted(tmp_path.iterdir())

    code = main(["mesh", *args, "-o", str(out)])

    _, err = capsys.readouterr()
    assert code == 2
    assert err.startswith("qmesh: error: ") and err.count("\n") == 1, err   # one line, no traceback
    assert re.search(message, err), err
    assert sorted(tmp_path.iterdir()) == before                          # nothing written


def test_mesh_bad_output_name_fails_before_meshing(tmp_path, capsys):
    for out, message in [(tmp_path / "m.stl", "unknown mesh file extension '.stl'"),
                         (tmp_path / "nowhere" / "m.vtu", "does not exist")]:
        assert main(["mesh", "--disk", "8", "-o", str(out)]) == 2
        assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name, content, message", [
    ("missing.vtu", None, "no such mesh file"),
    ("broken.vtu", "<VTKFile", "cannot read"),
    ("binary.msh", b"\x00\xff\x00garbage", "cannot read"),
    ("mesh.csv", "0,0\n", "unknown mesh file extension"),
])
def test_report_unreadable_file(tmp_path, capsys, name, content, message):
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif content is not None:
        path.write_text(content)
    assert main(["report", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.startswith("qmesh: error: ") and message in err and err.count("\n") == 1


def test_argument_errors_exit_2(capsys):
    assert main(["mesh", "--disk", "8"]) == 2                           # -o is required
    assert main(["mesh", "--disk", "8", "--polygon", "x.csv", "-o", "m.vtu"]) == 2
    assert main(["mesh", "--Q", "1", "0", "-o", "m.vtu"]) == 2
    assert main(["mesh", "--seed", "-1", "-o", "m.vtu"]) == 2
    assert "error" in capsys.readouterr().err


# ----------------------------------------------------------------------------- the API raises the same type

@pytest.mark.parametrize("build, message", [
    (lambda: qmesh.Anisotropy.constant([[1, 2], [2, 1]]), "positive definite"),
    (lambda: qmesh.Anisotropy.constant([[1, 0.5], [0, 1]]), "symmetric"),
    (lambda: qmesh.Anisotropy.constant([[np.nan, 0], [0, 1]]), "non-finite"),
    (lambda: qmesh.Anisotropy.constant([1, 2, 3]), r"Q must have shape \(2, 2\)"),
    (lambda: qmesh.Anisotropy.principal(-1, 1, 0), "k1 must be a finite number > 0"),
    (lambda: qmesh.Anisotropy.principal(1, 1, np.inf), "angle_deg must be a finite number"),
    (lambda: qmesh.Disk(2), "at least 3"),
    (lambda: qmesh.Disk(3.5), "integer"),
    (lambda: qmesh.Disk(8, radius=0), "radius"),
    (lambda: qmesh.Polygon(np.loadtxt(PENTAGRAM.splitlines(), delimiter=",")), "intersects itself"),
    (lambda: qmesh.Polygon([[0, 0], [1, 0]]), "at least 3"),
    (lambda: qmesh.Polygon([[0, 0], [1, 0], [1, 0], [0, 1]]), "repeated"),
    (lambda: qmesh.Polygon([[0, 0], [1, np.nan], [0, 1]]), "finite"),
])
def test_api_errors(build, message):
    with pytest.raises(QmeshError, match=message) as info:
        build()
    assert isinstance(info.value, ValueError)


TRIANGLE = ([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])


@pytest.mark.parametrize("build, message", [
    (lambda: qmesh.Mesh(*TRIANGLE, region_tags=[2**63]), "region_tags must be integers below 2\\*\\*63"),
    (lambda: qmesh.Mesh(*TRIANGLE, boundary_edges=[[0, 1]], boundary_tags=[2**63]), "boundary_tags must be"),
    (lambda: qmesh.Mesh(*TRIANGLE, region_tags=[1e30]), "region_tags must be an array of integers"),
    (lambda: qmesh.Domain.from_cells([0, 1], [0, 1], [[10**400]], 1), "k1 holds an integer beyond any float"),
    (lambda: qmesh.Domain.from_cells([0, 1], [0, 1], [[1 + 1j]], 1), "k1 must hold real numbers, got a complex"),
    (lambda: qmesh.Domain.from_cells([False, True], [0, 1], 1, 1), "x must hold real numbers, got a boolean"),
])
def test_integers_a_cast_would_wrap_and_values_it_would_change_are_refused(build, message):
    """2**63 as an int64 tag is −2**63, 1e30 as one is garbage, 10**400 overflows, a complex
    k1 loses its imaginary part: each is refused, naming the argument."""
    with pytest.raises(QmeshError, match=message):
        build()


def test_square_csv_is_accepted():
    """The CSV fixtures above are rejected for their defect, not for their form: a square passes."""
    P = np.loadtxt(SQUARE.splitlines(), delimiter=",")
    assert qmesh.Polygon(P).area == pytest.approx(1.0)


# ----------------------------------------------------------------------------- every option of mesh()



@pytest.mark.parametrize("option, value, message", [
    ("target_vertices", 10**30, r"target_vertices = 1e\+30 asks for about 1e\+30 vertices"),
    ("target_vertices", 10**400, r"target_vertices = 1e\+300 asks for about 1e\+300 vertices"),
    ("target_vertices", 100.0, "target_vertices must be an integer >= 1, got 100.0"),
    ("target_vertices", 0, "target_vertices must be an integer >= 1, got 0"),
    ("max_iterations", 10**30, r"max_iterations must be an integer >= 0 and <= 1e\+06, got about 1e\+30"),
    ("max_iterations", 40.0, "max_iterations must be an integer"),
    ("max_iterations", None, r"max_iterations must be an integer >= 0 and <= 1e\+06, got None"),
    ("seed", -1, "seed must be an integer >= 0, got -1"),
    ("seed", 1.0, "seed must be an integer >= 0, got 1.0"),
    ("alpha", None, r"alpha must be in \(0, 1\], got None"),
    ("alpha", 0, r"alpha must be in \(0, 1\], got 0"),
    ("quality_threshold", 1, r"quality_threshold must be in \[0, 1\), got 1"),
    ("quality_threshold", None, r"quality_threshold must be in \[0, 1\), got None"),
    ("min_area", -1e-3, "min_area must be a finite number >= 0, got -0.001"),
    ("size", -1, "size must be a finite number > 0, got -1"),
    ("boundary_refinement", None, "boundary_refinement must be True or False, got None"),
    ("boundary_refinement", 1, "boundary_refinement must be True or False, got 1"),
    ("boundary_refinement", "no", "boundary_refinement must be True or False, got 'no'"),
])
def test_mesh_option_messages(option, value, message):
    with pytest.raises(QmeshError, match=message):
        qmesh.mesh(qmesh.Disk(8), qmesh.Anisotropy.constant(np.eye(2)), **{option: value})


def test_mesh_names_unknown_keywords():
    with pytest.raises(QmeshError, match=r"mesh\(\) got unknown options 'target', 'vb'; its options "
                                         r"are target_vertices, size, alpha") as info:
        qmesh.mesh(qmesh.Disk(8), qmesh.Anisotropy.constant(np.eye(2)), target=30, vb=8)
    assert isinstance(info.value, TypeError)


def test_target_and_size_together():
    with pytest.raises(QmeshError, match="give either target_vertices or size, not both"):
        qmesh.mesh(qmesh.Disk(8), qmesh.Anisotropy.constant(np.eye(2)), target_vertices=30, size=0.1)


def test_numpy_integers_and_bools_are_valid_options():
    A = qmesh.Anisotropy.constant(np.eye(2))
    m = qmesh.mesh(qmesh.Disk(8), A, target_vertices=np.int64(30), seed=np.uint8(3),
                   max_iterations=np.int32(5), boundary_refinement=np.bool_(True))
    assert abs(m.n_vertices - 30) <= 3


# ----------------------------------------------------------------------------- Anisotropy constructors

@pytest.mark.parametrize("build, message", [
    (lambda: qmesh.Anisotropy.constant("diag(1, 2)"), "Q must be an array of real numbers"),
    (lambda: qmesh.Anisotropy.constant(None), "Q must be an array of real numbers"),
    (lambda: qmesh.Anisotropy.constant([["1", "0"], ["0", "1"]]), "Q must be an array of real numbers"),
    (lambda: qmesh.Anisotropy.constant([[1, 0], [0, np.inf]]), "Q has non-finite entries"),
    (lambda: qmesh.Anisotropy.constant(np.eye(3)), r"Q must have shape \(2, 2\), got shape \(3, 3\)"),
    (lambda: qmesh.Anisotropy.principal("1", 2), "k1 must be a finite number > 0, got '1' \\(str\\)"),
    (lambda: qmesh.Anisotropy.principal(1, None), "k2 must be a finite number > 0, got None"),
    (lambda: qmesh.Anisotropy.principal(1, True), "k2 must be a finite number > 0, got True"),
    (lambda: qmesh.Anisotropy.principal(1, 2, "30"), "angle_deg must be a finite number, got '30'"),
    (lambda: qmesh.Anisotropy.principal(10**400, 2), "k1 must be a finite number > 0, got .*too large"),
    (lambda: qmesh.Anisotropy.principal(1e300, 1e-300), "k1 = 1e.300 and k2 = 1e-300 are too far apart"),
    (lambda: qmesh.Anisotropy.principal(1, 1e-16, 30), "k1 = 1 and k2 = 1e-16 are too far apart"),
    (lambda: qmesh.Anisotropy.from_s(None, np.sin, np.sin), "s must be a callable, got None"),
    (lambda: qmesh.Anisotropy.from_s(np.sin, "P", np.sin), "grad must be a callable, got 'P'"),
    (lambda: qmesh.Anisotropy.from_s(np.sin, np.sin, np.eye(2)), "hessian must be a callable"),
    (lambda: qmesh.Anisotropy.from_s(np.sin, np.sin, np.sin, label=None), "label must be a string"),
])
def test_anisotropy_refuses(build, message):
    with pytest.raises(QmeshError, match=message) as info:
        build()
    assert isinstance(info.value, TypeError) and isinstance(info.value, ValueError)


@pytest.mark.parametrize("c", [1e-200, 1e-30, 1.0, 1e30, 1e200])
def test_the_size_of_q_does_not_decide_whether_it_is_spd(c):
    A = qmesh.Anisotropy.constant(c * np.array([[2.0, 0.5], [0.5, 1.0]]))
    assert np.allclose(A.Q(np.zeros((1, 2)))[0] / c, [[2.0, 0.5], [0.5, 1.0]], rtol=1e-12)
    assert qmesh.Anisotropy.principal(c, 3 * c, 30).is_constant


@pytest.mark.parametrize("text, area", [(NON_CONVEX, 3.0), (CLOCKWISE, 1.0)])
def test_non_convex_and_clockwise_polygons_mesh(tmp_path, capsys, text, area):
    """Non-convex outlines and either orientation are domains now."""
    (tmp_path / "p.csv").write_text(text)
    out = tmp_path / "p.vtu"
    assert main(["mesh", "--polygon", str(tmp_path / "p.csv"), "--target-vertices", "60",
                 "-o", str(out), "--quiet"]) == 0
    assert out.exists()
    m = qmesh.io.read(out)
    from qmesh.geometry.triangles import signed_areas
    assert signed_areas(m.points, m.triangles).sum() == pytest.approx(area, rel=1e-12)
