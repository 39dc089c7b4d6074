"""qmesh.io: every format round-trips through meshio; files from other programs read cleanly."""

import meshio
import numpy as np
import pytest

import qmesh
from qmesh import io
from qmesh.errors import QmeshError


@pytest.mark.parametrize("ext", sorted(io.FORMATS))
def test_round_trip(tmp_path, delaunay_mesh, ext):
    path = tmp_path / f"m{ext}"
    io.write(path, delaunay_mesh)
    back = io.read(path)
    np.testing.assert_allclose(back.points, delaunay_mesh.points, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(back.triangles, delaunay_mesh.triangles)
    expected_fixed = delaunay_mesh.fixed if ext in io.KEEPS_FIXED else np.zeros(delaunay_mesh.n_vertices, bool)
    np.testing.assert_array_equal(back.fixed, expected_fixed)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary file left behind


@pytest.mark.parametrize("ext", sorted(io.KEEPS_DATA))
def test_quality_and_extra_data_are_written(tmp_path, delaunay_mesh, chapter_anisotropy, ext):
    path = tmp_path / f"m{ext}"
    height = delaunay_mesh.points[:, 1]
    label = np.arange(delaunay_mesh.n_triangles) % 3
    io.write(path, delaunay_mesh, anisotropy=chapter_anisotropy,
             point_data={"height": height}, cell_data={"label": label})
    m = meshio.read(path)
    np.testing.assert_allclose(m.cell_data["quality"][0], qmesh.measure.quality(delaunay_mesh, chapter_anisotropy),
                               rtol=1e-12)
    np.testing.assert_allclose(np.ravel(m.point_data["height"]), height, rtol=1e-12)
    np.testing.assert_array_equal(np.ravel(m.cell_data["label"][0]), label)


def test_no_quality_without_anisotropy(tmp_path, delaunay_mesh):
    io.write(tmp_path / "m.vtu", delaunay_mesh)
    assert "quality" not in meshio.read(tmp_path / "m.vtu").cell_data


def test_read_orients_drops_z_and_unused_points_and_other_cells(tmp_path):
    # A file as another program writes it: 3-D points, a clockwise triangle, line cells,
    # and a point that no triangle uses.
    P = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [5, 5, 0]], float)
    cells = [("line", np.array([[0, 1], [1, 2]])), ("triangle", np.array([[0, 1, 2], [0, 2, 3][::-1]]))]
    meshio.write(tmp_path / "other.vtu", meshio.Mesh(P, cells))
    m = io.read(tmp_path / "other.vtu")
    assert m.points.shape == (4, 2)
    np.testing.assert_array_equal(m.points, P[:4, :2])
    assert np.all(qmesh.geometry.signed_areas(m.points, m.triangles) > 0)
    assert {frozenset(t) for t in m.triangles.tolist()} == {frozenset({0, 1, 2}), frozenset({0, 2, 3})}
    assert not m.fixed.any()


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
    assert np.all(qmesh.geometry.signed_areas(m.points, m.triangles) > 0)  # element 6 was clockwise
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


def test_write_errors_leave_no_file(tmp_path, delaunay_mesh):
    cases = [
        (tmp_path / "m.stl", {}, "unknown mesh file extension"),
        (tmp_path / "no" / "m.vtu", {}, "does not exist"),
        (tmp_path / "m.vtu", {"point_data": {"h": np.zeros(3)}}, "must have 56 rows"),
        (tmp_path / "m.vtu", {"cell_data": {"quality": np.zeros(delaunay_mesh.n_triangles)}}, "reserved"),
        # meshio itself refuses (gmsh allows 1, 3 or 9 components): the error surfaces, no file stays
        (tmp_path / "m.msh", {"point_data": {"v": np.zeros((delaunay_mesh.n_vertices, 2))}}, "cannot write"),
    ]
    for path, kwargs, message in cases:
        with pytest.raises(QmeshError, match=message):
            io.write(path, delaunay_mesh, **kwargs)
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(QmeshError, match="qmesh.Mesh"):
        io.write(tmp_path / "m.vtu", "not a mesh")
