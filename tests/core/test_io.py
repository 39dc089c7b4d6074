"""qmesh.io: every format round-trips through meshio; files from other programs read cleanly."""

import re

import meshio
import numpy as np
import pytest

import qmesh
from qmesh import io
from qmesh.errors import QmeshError
from qmesh.geometry.folds import folded_triangles
from qmesh.io.formats import _load
from qmesh.io.registry import REGISTRY


def file_view(path):
    """The meshio mesh of a file as qmesh reads it (meshio cannot read the DOLFINx .xdmf layout)."""
    return _load(path, REGISTRY[path.suffix])


@pytest.mark.parametrize("ext", sorted(io.FORMATS))
def test_round_trip(tmp_path, delaunay_mesh, ext):
    path = tmp_path / f"m{ext}"
    io.write(path, delaunay_mesh)
    back = io.read(path)
    np.testing.assert_allclose(back.points, delaunay_mesh.points, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(back.triangles, delaunay_mesh.triangles)
    expected_fixed = delaunay_mesh.fixed if ext in io.KEEPS_FIXED else np.zeros(delaunay_mesh.n_vertices, bool)
    np.testing.assert_array_equal(back.fixed, expected_fixed)
    expected = ({path.name, "m.h5", "m_facets.xdmf", "m_facets.h5"} if ext == ".xdmf"   # xdmf: its
                else {path.name})                           # HDF5 and the facet tags' companion
    assert {p.name for p in tmp_path.iterdir()} == expected  # no temporary file left behind


@pytest.mark.parametrize("ext", sorted(io.KEEPS_DATA))
def test_quality_and_extra_data_are_written(tmp_path, delaunay_mesh, chapter_anisotropy, ext):
    path = tmp_path / f"m{ext}"
    height = delaunay_mesh.points[:, 1]
    label = np.arange(delaunay_mesh.n_triangles) % 3
    io.write(path, delaunay_mesh, anisotropy=chapter_anisotropy,
             point_data={"height": height}, cell_data={"label": label})
    m = file_view(path)
    np.testing.assert_allclose(m.cell_data["quality"][0], qmesh.measure.quality(delaunay_mesh, chapter_anisotropy),
                               rtol=1e-12)
    np.testing.assert_allclose(np.ravel(m.point_data["height"]), height, rtol=1e-12)
    np.testing.assert_array_equal(np.ravel(m.cell_data["label"][0]), label)


def test_no_quality_without_anisotropy(tmp_path, delaunay_mesh):
    io.write(tmp_path / "m.vtu", delaunay_mesh)
    assert "quality" not in meshio.read(tmp_path / "m.vtu").cell_data


def test_read_orients_drops_z_and_unused_points_and_other_cells(tmp_path):
    # A file as another program writes it: 3-D points, clockwise triangles, line cells,
    # and a point that no triangle uses.
    P = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [5, 5, 0]], float)
    cells = [("line", np.array([[0, 1], [1, 2]])), ("triangle", np.array([[0, 1, 2][::-1], [0, 2, 3][::-1]]))]
    meshio.write(tmp_path / "other.vtu", meshio.Mesh(P, cells))
    m = io.read(tmp_path / "other.vtu")
    assert m.points.shape == (4, 2)
    np.testing.assert_array_equal(m.points, P[:4, :2])
    assert np.all(qmesh.geometry.triangles.signed_areas(m.points, m.triangles) > 0)  # clockwise as a whole
    assert {frozenset(t) for t in m.triangles.tolist()} == {frozenset({0, 1, 2}), frozenset({0, 2, 3})}
    assert not m.fixed.any() and folded_triangles(m) == 0


def test_read_keeps_a_fold_for_report_to_see(tmp_path):
    """One triangle turning the other way than the rest is a fold: kept, not re-oriented."""
    P = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    meshio.write(tmp_path / "fold.vtu", meshio.Mesh(P, [("triangle", np.array([[0, 1, 2], [0, 3, 2], [0, 1, 2]]))]))
    m = io.read(tmp_path / "fold.vtu")
    assert (qmesh.geometry.triangles.signed_areas(m.points, m.triangles) < 0).sum() == 1
    assert folded_triangles(m) >= 2  # the clockwise one and the duplicate


GMSH22_FROM_ANOTHER_PROGRAM = """$MeshFormat
2.2 0 8
$EndMeshFormat
$Nodes
5
1 0 0 0
2 2 0 0
3 2 1 0
4 0 1 0
5 1 0.5 0
$EndNodes
$Elements
8
1 15 2 0 1 1
2 1 2 0 1 1 2
3 2 2 0 1 1 2 5
4 2 2 0 1 2 3 5
5 2 2 0 1 3 4 5
6 2 2 0 1 5 4 1
7 1 2 0 2 2 3
8 1 2 0 3 3 4
$EndElements
"""


def test_read_hand_written_gmsh22(tmp_path):
    path = tmp_path / "rect.msh"
    path.write_text(GMSH22_FROM_ANOTHER_PROGRAM)
    m = io.read(path)
    assert m.n_vertices == 5 and m.n_triangles == 4
    assert np.all(qmesh.geometry.triangles.signed_areas(m.points, m.triangles) > 0)
    assert folded_triangles(m) == 0
    assert m.boundary.sum() == 4 and not m.boundary[4]


def test_read_rejects_non_planar(tmp_path):
    P = np.array([[0, 0, 0], [1, 0, 0.5], [0, 1, 0]], float)
    meshio.write(tmp_path / "tilted.vtu", meshio.Mesh(P, [("triangle", np.array([[0, 1, 2]]))]))
    with pytest.raises(QmeshError, match="not a planar mesh"):
        io.read(tmp_path / "tilted.vtu")


def test_read_rejects_file_without_triangles(tmp_path):
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    meshio.write(tmp_path / "lines.vtu", meshio.Mesh(P, [("line", np.array([[0, 1], [1, 2]]))]))
    with pytest.raises(QmeshError, match="no triangle cells.*line"):
        io.read(tmp_path / "lines.vtu")


@pytest.mark.parametrize("name, content, message", [
    ("missing.vtu", None, "no such mesh file"),
    ("garbage.vtu", "this is not xml", "cannot read"),
    ("garbage.msh", "$MeshFormat\n9.9 0 8\n", "cannot read"),
    ("empty.mesh", "", "cannot read"),
    ("mesh.txt", "1 2 3", "unknown mesh file extension"),
])
def test_read_errors(tmp_path, name, content, message):
    path = tmp_path / name
    if content is not None:
        path.write_text(content)
    with pytest.raises(QmeshError, match=message):
        io.read(path)


def test_large_vtu_is_written_uncompressed_and_reads_back_the_same(tmp_path, delaunay_mesh,
                                                                   chapter_anisotropy, monkeypatch):
    from qmesh.io import meshio_writers
    small, large = tmp_path / "small.vtu", tmp_path / "large.vtu"
    io.write(small, delaunay_mesh, anisotropy=chapter_anisotropy)
    monkeypatch.setattr(meshio_writers, "ZLIB_MAX", delaunay_mesh.n_vertices - 1)
    io.write(large, delaunay_mesh, anisotropy=chapter_anisotropy)
    assert b"vtkZLibDataCompressor" in small.read_bytes()
    assert b"vtkZLibDataCompressor" not in large.read_bytes()
    a, b = io.read(small), io.read(large)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.triangles, b.triangles)
    assert np.array_equal(b.triangles, delaunay_mesh.triangles)
    cells = meshio.read(large).cells_dict["triangle"]
    assert np.array_equal(cells, delaunay_mesh.triangles)


def test_large_vtu_is_meshio_uncompressed_layout_byte_for_byte(tmp_path, delaunay_mesh,
                                                                chapter_anisotropy, monkeypatch):
    """Past ZLIB_MAX qmesh writes the .vtu itself (vtu_raw): the same bytes as meshio's
    uncompressed writer and the metadata edit give, but for the comment naming the writer;
    point and cell data of every kind included."""
    from qmesh.io import meshio_writers
    n, m = delaunay_mesh.n_vertices, delaunay_mesh.n_triangles
    data = dict(point_data={"u": np.arange(n, dtype=np.float32), "grad": np.ones((n, 2))},
                cell_data={"k": np.arange(m), "flag": np.ones(m, bool)})
    real = meshio.vtu.write
    monkeypatch.setattr(meshio.vtu, "write",
                        lambda f, mesh, compression: real(f, mesh, compression=None))
    monkeypatch.setattr(meshio_writers, "ZLIB_MAX", 10 * n)          # meshio, uncompressed
    io.write(tmp_path / "meshio.vtu", delaunay_mesh, anisotropy=chapter_anisotropy, **data)
    monkeypatch.setattr(meshio.vtu, "write", None)                   # not called any more
    monkeypatch.setattr(meshio_writers, "ZLIB_MAX", n - 1)
    io.write(tmp_path / "raw.vtu", delaunay_mesh, anisotropy=chapter_anisotropy, **data)
    comment = re.compile(rb"<!--This file was created by [^>]*-->")
    raw = (tmp_path / "raw.vtu").read_bytes()
    assert b"created by qmesh" in raw and b"vtkZLibDataCompressor" not in raw
    assert comment.sub(b"", raw) == comment.sub(b"", (tmp_path / "meshio.vtu").read_bytes())
    back = io.read(tmp_path / "raw.vtu")
    assert np.array_equal(back.points, delaunay_mesh.points)
    assert np.array_equal(back.triangles, delaunay_mesh.triangles)


@pytest.mark.parametrize("head", [8, 600, 1 << 16])
@pytest.mark.parametrize("ext", [".vtu", ".vtk", ".msh", ".mesh"])
def test_metadata_lands_the_same_whatever_the_head_read(tmp_path, delaunay_mesh, chapter_anisotropy,
                                                        monkeypatch, head, ext):
    """The metadata and the vtu's FieldData are put into the file's head without reading the
    whole file (metadata.edit_head); a mark beyond the head falls back to the whole file."""
    from qmesh.io import metadata
    whole = tmp_path / f"whole{ext}"
    io.write(whole, delaunay_mesh, anisotropy=chapter_anisotropy)
    monkeypatch.setattr(metadata, "HEAD", head)
    part = tmp_path / f"part{ext}"
    io.write(part, delaunay_mesh, anisotropy=chapter_anisotropy)
    assert part.read_bytes() == whole.read_bytes()
    np.testing.assert_array_equal(io.read_anisotropy(part).H, chapter_anisotropy.H)


def test_write_errors_leave_no_file(tmp_path, delaunay_mesh):
    cases = [
        (tmp_path / "m.stl", {}, "unknown mesh file extension"),
        (tmp_path / "no" / "m.vtu", {}, "does not exist"),
        (tmp_path / "m.vtu", {"point_data": {"h": np.zeros(3)}}, "must have 56 rows"),
        (tmp_path / "m.vtu", {"cell_data": {"quality": np.zeros(delaunay_mesh.n_triangles)}}, "reserved"),
        # meshio itself refuses (gmsh allows 1, 3 or 9 components): the error surfaces, no file stays
        (tmp_path / "m.msh", {"point_data": {"v": np.zeros((delaunay_mesh.n_vertices, 2))}}, "1, 3 or 9 components"),
        (tmp_path / "m.msh", {"cell_data": {"c": np.zeros(delaunay_mesh.n_triangles)}}, "version='4.1'"),
    ]
    for path, kwargs, message in cases:
        with pytest.raises(QmeshError, match=message):
            io.write(path, delaunay_mesh, **kwargs)
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(QmeshError, match="qmesh.Mesh"):
        io.write(tmp_path / "m.vtu", "not a mesh")


# --------------------------------------------------------------------------- the stored conductivity

from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import json  # noqa: E402

from qmesh.io import conductivity as file_conductivity  # noqa: E402
from qmesh.io import metadata  # noqa: E402

ROTATED = qmesh.Anisotropy.principal(1, 100, 30)


def _with_expression(text):
    """An Anisotropy carrying `expression` as Anisotropy.from_expression's will (s itself unused here)."""
    a = qmesh.Anisotropy.constant(np.eye(2))
    object.__setattr__(a, "expression", text)
    return a


@pytest.mark.parametrize("ext", sorted(io.KEEPS_CONDUCTIVITY))
def test_constant_q_comes_back_exactly(tmp_path, delaunay_mesh, ext):
    path = tmp_path / f"m{ext}"
    io.write(path, delaunay_mesh, anisotropy=ROTATED)
    back = io.read_anisotropy(path)
    assert back.is_constant
    np.testing.assert_array_equal(back.H, ROTATED.H)  # bit for bit: the record holds repr(float)
    np.testing.assert_array_equal(io.read(path).points, io.read(path).points)
    assert io.read(path).n_triangles == delaunay_mesh.n_triangles  # the record does not disturb the mesh


@pytest.mark.parametrize("ext", sorted(io.FORMATS))
def test_no_conductivity_without_anisotropy(tmp_path, delaunay_mesh, ext):
    path = tmp_path / f"m{ext}"
    io.write(path, delaunay_mesh)
    assert io.read_anisotropy(path) is None


@pytest.mark.parametrize("ext", [".vtu", ".msh", ".mesh"])
def test_file_from_another_program_has_no_conductivity(tmp_path, delaunay_mesh, ext):
    P = np.column_stack([delaunay_mesh.points, np.zeros(delaunay_mesh.n_vertices)])
    other = meshio.Mesh(P, [("triangle", delaunay_mesh.triangles)])
    if ext == ".msh":  # meshio.write would take .msh for ANSYS
        meshio.gmsh.write(tmp_path / f"other{ext}", other, binary=True)
    else:
        meshio.write(tmp_path / f"other{ext}", other)
    assert io.read_anisotropy(tmp_path / f"other{ext}") is None


@settings(max_examples=40, deadline=None, derandomize=True)
@given(k1=st.floats(1e-6, 1e6), k2=st.floats(1e-6, 1e6), angle=st.floats(-360, 360))
def test_any_spd_q_record_round_trips_exactly(k1, k2, angle):
    a = qmesh.Anisotropy.principal(k1, k2, angle)
    back = file_conductivity.from_json(json.loads(json.dumps(file_conductivity.to_json(a))), "test")
    np.testing.assert_array_equal(back.H, a.H)


EXPRESSION = "x**2 + 0.5*y**4 + exp(-x) * (x < y) & 1 + π"  # <, &, non-ASCII: escaping is exercised


@pytest.mark.parametrize("ext", sorted(io.KEEPS_CONDUCTIVITY))
def test_expression_is_stored_as_text(tmp_path, delaunay_mesh, ext, monkeypatch):
    path = tmp_path / f"m{ext}"
    io.write(path, delaunay_mesh, anisotropy=_with_expression(EXPRESSION))
    assert metadata.read(path, REGISTRY[ext].metadata, "test")["conductivity"] == {"s": EXPRESSION}
    seen = []
    monkeypatch.setattr(qmesh.Anisotropy, "from_expression",
                        classmethod(lambda cls, text: seen.append(text) or ROTATED), raising=False)
    assert io.read_anisotropy(path) is ROTATED and seen == [EXPRESSION]


def test_expression_needs_from_expression_to_be_read(tmp_path, delaunay_mesh, monkeypatch):
    path = tmp_path / "m.vtu"
    io.write(path, delaunay_mesh, anisotropy=_with_expression("x**2 + y**2"))
    monkeypatch.delattr(qmesh.Anisotropy, "from_expression", raising=False)
    with pytest.raises(QmeshError, match="stores s\\(x, y\\) = x\\*\\*2 \\+ y\\*\\*2"):
        io.read_anisotropy(path)


def test_callable_s_is_not_stored(tmp_path, delaunay_mesh):
    s = qmesh.Anisotropy.from_s(lambda P: (P ** 4).sum(1), lambda P: 4 * P ** 3,
                                lambda P: np.einsum("ni,ij->nij", 12 * P ** 2 + 1, np.eye(2)))
    io.write(tmp_path / "m.vtu", delaunay_mesh, anisotropy=s)
    assert io.read_anisotropy(tmp_path / "m.vtu") is None


@pytest.mark.parametrize("ext", sorted(io.KEEPS_MEANS))
def test_a_field_meshs_conductivity_comes_back_as_its_element_means(tmp_path, delaunay_mesh, ext):
    """A mesh made for a TensorField stores no formula, only its means: read_anisotropy gives
    those, one Q per triangle, and the measures take them as the conductivity."""
    F = qmesh.TensorField.from_expressions("1 + x**2", "0.3*x*y", "2 + y")
    m = qmesh.Mesh(delaunay_mesh.points, delaunay_mesh.triangles, delaunay_mesh.fixed,
                   conductivity=F.means(delaunay_mesh.points, delaunay_mesh.triangles))
    path = tmp_path / f"m{ext}"
    io.write(path, m)
    back, Q = io.read(path), io.read_anisotropy(path)
    assert Q.shape == (m.n_triangles, 2, 2)
    np.testing.assert_array_equal(Q, back.conductivity)
    np.testing.assert_allclose(Q, F.means(back.points, back.triangles), rtol=1e-12)  # each its own
    assert qmesh.measure.report(back, Q) == qmesh.measure.report(back)


def test_records_a_format_cannot_hold_are_refused(tmp_path, delaunay_mesh):
    with pytest.raises(QmeshError, match=".vtk keeps qmesh's metadata in its title line, at most 256"):
        io.write(tmp_path / "m.vtk", delaunay_mesh, anisotropy=_with_expression("x**2 + " * 50 + "y**2"))
    assert list(tmp_path.iterdir()) == []
    io.write(tmp_path / "m.msh", delaunay_mesh, anisotropy=_with_expression("x**2 + y**2 # 'a\"'"))  # JSON escapes
    assert metadata.read(tmp_path / "m.msh", "section", "t")["conductivity"] == {"s": "x**2 + y**2 # 'a\"'"}


def test_bad_stored_record_is_a_clear_error(tmp_path, delaunay_mesh):
    path = tmp_path / "m.obj"
    io.write(path, delaunay_mesh)
    body = path.read_text().split("\n", 1)[1]
    path.write_text('# qmesh {"qmesh": 1, "conductivity": {"Q": [[1.0, 0.0], [0.0, -1.0]]}}\n' + body)
    with pytest.raises(QmeshError, match="m.obj.*stored conductivity is not valid"):
        io.read_anisotropy(path)
    path.write_text('# qmesh {"qmesh": 1, "conductivity": {"Q": "the identity"}}\n' + body)
    with pytest.raises(QmeshError, match="stored conductivity Q must be 2×2 finite numbers"):
        io.read_anisotropy(path)
    path.write_text('# qmesh {"qmesh": 1, "conductivity": ' + "[" * 100000 + "\n" + body)
    with pytest.raises(QmeshError, match="unreadable qmesh metadata"):
        io.read_anisotropy(path)


@pytest.mark.parametrize("call, message", [
    (lambda p, m: io.write(123, m), "path must be a file name"),
    (lambda p, m: io.write(None, m), "path must be a file name"),
    (lambda p, m: io.write(p / "m.vtu", m.points), "mesh must be a qmesh.Mesh"),
    (lambda p, m: io.write(p / "m.vtu", m, anisotropy=np.eye(2)), "anisotropy must be a qmesh.Anisotropy"),
    (lambda p, m: io.write(p / "m.vtu", m, anisotropy={1: ROTATED}), "no conductivity for region tags \\[0\\]"),
    (lambda p, m: io.write(p / "m.msh", m, version="3"), "version must be one of"),
    (lambda p, m: io.write(p / "m.vtu", m, point_data=[1, 2]), "point data must be a dict"),
    (lambda p, m: io.write(p / "m.vtu", m, point_data={1: np.zeros(m.n_vertices)}), "names must be non-empty strings"),
    (lambda p, m: io.write(p / "m.vtu", m, point_data={"s": ["a"] * m.n_vertices}), "point data\\['s'\\] must hold real numbers"),
    (lambda p, m: io.write(p / "m.vtu", m, cell_data={"c": np.zeros(m.n_triangles, complex)}), "real numbers"),
    (lambda p, m: io.write(p / "m.vtu", m, cell_data={"c": np.zeros((m.n_triangles, 2, 2))}), "must have 94 rows"),
    (lambda p, m: io.write(p / "m.vtu", m, point_data={"r": [[1], [1, 2]]}), "is not an array"),
    (lambda p, m: io.read(3.5), "path must be a file name"),
    (lambda p, m: io.read_anisotropy(["m.vtu"]), "path must be a file name"),
    (lambda p, m: io.read_anisotropy(p / "none.vtu"), "no such mesh file"),
    (lambda p, m: io.check_writable(object()), "path must be a file name"),
])
def test_every_argument_is_checked(tmp_path, delaunay_mesh, call, message):
    with pytest.raises(QmeshError, match=message):
        call(tmp_path, delaunay_mesh)
    assert list(tmp_path.iterdir()) == []
