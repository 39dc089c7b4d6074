"""Boundary edges, tags and tag names go into mesh files and come back (qmesh.io, qmesh.io.boundary)."""

import meshio
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

import qmesh
from qmesh import io
from qmesh.errors import QmeshError

NAMES = {1: "outer wall", 2: "hole"}


def _ccw(P, T):
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    T[cw] = T[cw][:, [0, 2, 1]]
    return T


def tagged(P, T, fixed, edges, tags, names):
    return qmesh.Mesh(P, T, fixed, boundary_edges=edges, boundary_tags=tags, tag_names=names)


@pytest.fixture(scope="module")
def holed():
    """Delaunay mesh of [-1,1]² less the square hole [-0.3,0.3]²: outline tag 1, hole tag 2."""
    ring = lambda r, k: r * np.vstack([np.c_[np.linspace(-1, 1, k + 1)[:-1], -np.ones(k)],   # noqa: E731
                                       np.c_[np.ones(k), np.linspace(-1, 1, k + 1)[:-1]],
                                       np.c_[-np.linspace(-1, 1, k + 1)[:-1], np.ones(k)],
                                       np.c_[-np.ones(k), -np.linspace(-1, 1, k + 1)[:-1]]])
    outer, hole = ring(1, 8), ring(0.3, 4)
    X = np.random.default_rng(3).uniform(-0.95, 0.95, (200, 2))
    P = np.vstack([outer, hole, X[np.abs(X).max(1) > 0.4]])
    fixed = np.arange(len(P)) < len(outer) + len(hole)
    shuffle = np.random.default_rng(4).permutation(len(P))  # ring points not first: numbering matters
    P, fixed = P[shuffle], fixed[shuffle]
    T = Delaunay(P).simplices
    T = _ccw(P, T[np.abs(P[T].mean(1)).max(1) > 0.3 + 1e-9])
    E = qmesh.Mesh(P, T).boundary_edges
    tags = np.where(np.abs(P[E]).max(axis=(1, 2)) < 0.5, 2, 1)
    return tagged(P, T, fixed, E, tags, NAMES)


def _tag_of_edge(mesh):
    """{frozenset of the two end points' coordinates: tag}, independent of numbering and direction."""
    P = mesh.points
    return {frozenset(map(tuple, P[e].tolist())): int(t) for e, t in zip(mesh.boundary_edges, mesh.boundary_tags)}


@pytest.mark.parametrize("ext", sorted(io.KEEPS_TAGS))
def test_tags_round_trip(tmp_path, holed, ext):
    path = tmp_path / f"h{ext}"
    io.write(path, holed)
    back = io.read(path)
    assert _tag_of_edge(back) == _tag_of_edge(holed)
    assert np.bincount(back.boundary_tags).tolist() == [0, 32, 16]
    assert back.tag_names == (NAMES if ext in io.KEEPS_TAG_NAMES else {})


@pytest.mark.parametrize("ext", sorted(io.FORMATS))
def test_vertex_numbering_survives(tmp_path, holed, ext):
    """Same points in the same order, same triangles, same fixed flags (gmsh groups nodes by entity)."""
    io.write(tmp_path / f"h{ext}", holed)
    back = io.read(tmp_path / f"h{ext}")
    np.testing.assert_array_equal(back.points, holed.points)
    np.testing.assert_array_equal(back.triangles, holed.triangles)
    np.testing.assert_array_equal(back.fixed, holed.fixed if ext in io.KEEPS_FIXED else False)


def test_gmsh_node_data_is_aligned_for_any_meshio_reader(tmp_path, holed):
    io.write(tmp_path / "h.msh", holed)
    m = meshio.gmsh.read(tmp_path / "h.msh")
    fixed_points = m.points[np.ravel(m.point_data["fixed"]) != 0, :2]
    assert sorted(map(tuple, fixed_points.tolist())) == sorted(map(tuple, holed.points[holed.fixed].tolist()))


def test_obj_keeps_no_tags(tmp_path, holed):
    io.write(tmp_path / "h.obj", holed)
    assert [c.type for c in meshio.read(tmp_path / "h.obj").cells] == ["triangle"]
    back = io.read(tmp_path / "h.obj")
    assert len(back.boundary_edges) == 48 and set(back.boundary_tags.tolist()) == {1}


@pytest.mark.parametrize("ext", [".vtu", ".vtk"])
def test_vtk_family_has_line_cells_and_a_boundary_tag_array(tmp_path, holed, ext):
    io.write(tmp_path / f"h{ext}", holed, anisotropy=qmesh.Anisotropy.constant(np.eye(2)))
    m = meshio.read(tmp_path / f"h{ext}")
    assert [(c.type, len(c.data)) for c in m.cells] == [("triangle", holed.n_triangles), ("line", 48)]
    tri_tags, line_tags = (np.ravel(a) for a in m.cell_data["boundary_tag"])
    assert np.all(tri_tags == 0) and sorted(line_tags.tolist()) == [1] * 32 + [2] * 16
    assert np.ravel(m.cell_data["region"][0]).tolist() == [0] * holed.n_triangles
    # gmsh numbering: the triangles' group (3) differs from both edge tags
    assert np.unique(m.cell_data["gmsh:physical"][0]).tolist() == [3]
    assert np.isnan(np.ravel(m.cell_data["quality"][1])).all()  # lines have no quality
    # every line runs as in its triangle: the domain is on its left
    half = {tuple(e) for t in holed.triangles.tolist() for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    assert all(tuple(e) in half for e in m.cells[1].data.tolist())


def test_gmsh_physical_curves_and_names(tmp_path, holed):
    io.write(tmp_path / "h.msh", holed)
    assert (tmp_path / "h.msh").read_text().startswith("$MeshFormat\n2.2 0 8\n")  # ASCII 2.2: every client
    m = meshio.gmsh.read(tmp_path / "h.msh")
    assert [(c.type, len(c.data)) for c in m.cells] == [("line", 48), ("triangle", holed.n_triangles)]
    assert sorted(m.cell_data["gmsh:physical"][0].tolist()) == [1] * 32 + [2] * 16
    assert np.unique(m.cell_data["gmsh:physical"][1]).tolist() == [3]
    # plain identifiers: readers that cut a name at a space still get the whole name
    assert {k: v.tolist() for k, v in m.field_data.items()} == {"outer_wall": [1, 1], "hole": [2, 1], "domain": [3, 2]}
    assert io.read(tmp_path / "h.msh").tag_names == NAMES  # exact names from qmesh's metadata


def test_gmsh_file_opens_in_gmsh(tmp_path, holed):
    gmsh = pytest.importorskip("gmsh")
    io.write(tmp_path / "h.msh", holed, anisotropy=qmesh.Anisotropy.constant(np.eye(2)))
    gmsh.initialize(["-v", "0"])
    try:
        gmsh.open(str(tmp_path / "h.msh"))
        groups = {g: gmsh.model.getPhysicalName(*g) for g in gmsh.model.getPhysicalGroups()}
        lines = gmsh.model.mesh.getElements(1, 2)[1][0]
    finally:
        gmsh.finalize()
    assert groups == {(1, 1): "outer_wall", (1, 2): "hole", (2, 3): "domain"}
    assert len(lines) == 16


def test_medit_edges_carry_the_tag_as_reference(tmp_path, holed):
    io.write(tmp_path / "h.mesh", holed)
    m = meshio.read(tmp_path / "h.mesh")
    assert sorted(np.ravel(m.cell_data["medit:ref"][1]).tolist()) == [1] * 32 + [2] * 16


def test_untagged_mesh_writes_tag_1(tmp_path, delaunay_mesh):
    io.write(tmp_path / "m.vtu", delaunay_mesh)
    m = meshio.read(tmp_path / "m.vtu")
    assert np.ravel(m.cell_data["boundary_tag"][1]).tolist() == [1] * 16


GMSH22_TAGGED = """$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
2
1 5 "inlet"
2 9 "plate"
$EndPhysicalNames
$Nodes
6
1 0 0 0
2 2 0 0
3 2 1 0
4 0 1 0
5 1 0.5 0
6 7 7 0
$EndNodes
$Elements
8
1 2 2 9 1 1 2 5
2 2 2 9 1 2 3 5
3 2 2 9 1 3 4 5
4 2 2 9 1 5 4 1
5 1 2 5 2 4 1
6 1 2 5 2 3 2
7 1 2 7 3 1 5
8 1 2 7 3 5 6
$EndElements
"""


def test_gmsh_file_from_another_program(tmp_path):
    """Lines on the boundary give their tag; an interior line and one to an unused point are ignored."""
    path = tmp_path / "plate.msh"
    path.write_text(GMSH22_TAGGED)
    m = io.read(path)
    assert m.n_vertices == 5
    assert _tag_of_edge(m) == {frozenset({(0.0, 1.0), (0.0, 0.0)}): 5, frozenset({(2.0, 1.0), (2.0, 0.0)}): 5,
                               frozenset({(0.0, 0.0), (2.0, 0.0)}): 1, frozenset({(2.0, 1.0), (0.0, 1.0)}): 1}
    assert m.tag_names == {5: "inlet"}


@settings(max_examples=15, deadline=None, derandomize=True)
@given(data=st.data())
def test_any_tags_round_trip_through_msh_and_vtu(tmp_path_factory, holed, data):
    tags = np.array(data.draw(st.lists(st.integers(1, 6), min_size=48, max_size=48)))
    names = {t: f"part {t}" for t in data.draw(st.sets(st.sampled_from(sorted(set(tags.tolist())))))}
    mesh = tagged(holed.points, holed.triangles, holed.fixed, holed.boundary_edges, tags, names)
    for ext in (".msh", ".vtu"):
        path = tmp_path_factory.mktemp("tags") / f"m{ext}"
        io.write(path, mesh)
        back = io.read(path)
        assert _tag_of_edge(back) == _tag_of_edge(mesh) and back.tag_names == names


def test_gmsh_needs_a_vertex_per_entity(tmp_path):
    P, T = np.array([[0.0, 0], [1, 0], [0, 1]]), np.array([[0, 1, 2]])
    E = np.array([[0, 1], [1, 2], [2, 0]])
    io.write(tmp_path / "one.msh", tagged(P, T, None, E, [1, 1, 1], {}), version="4.1")  # a vertex moves to the surface
    assert io.read(tmp_path / "one.msh").n_triangles == 1
    with pytest.raises(QmeshError, match="too few vertices.*write gmsh 2.2 or .vtu"):
        io.write(tmp_path / "three.msh", tagged(P, T, None, E, [1, 2, 3], {}), version="4.1")
    io.write(tmp_path / "three.msh", tagged(P, T, None, E, [1, 2, 3], {}))  # 2.2 has no such limit
    assert sorted(io.read(tmp_path / "three.msh").boundary_tags.tolist()) == [1, 2, 3]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["one.msh", "three.msh"]


def test_one_name_for_two_tags_gets_two_groups(tmp_path, holed):
    mesh = tagged(holed.points, holed.triangles, holed.fixed, holed.boundary_edges, holed.boundary_tags,
                  {1: "wall", 2: 'the "wall"'})
    io.write(tmp_path / "h.msh", mesh)
    assert set(meshio.read(tmp_path / "h.msh").field_data) == {"wall", "the_wall", "domain"}
    io.write(tmp_path / "h.vtu", mesh)
    assert io.read(tmp_path / "h.msh").tag_names == io.read(tmp_path / "h.vtu").tag_names == {1: "wall", 2: 'the "wall"'}


@pytest.mark.parametrize("tags, names, ext, message", [
    ([0, 1, 1], {}, ".vtu", "boundary_tags must be integers from 1 to 2\\*\\*31 - 1"),
    ([1, 2**40, 1], {}, ".msh", "boundary_tags must be integers from 1"),
])
def test_bad_tags_are_refused(tmp_path, tags, names, ext, message):
    P, T = np.array([[0.0, 0], [1, 0], [0, 1]]), np.array([[0, 1, 2]])
    mesh = tagged(P, T, None, np.array([[0, 1], [1, 2], [2, 0]]), tags, names)
    with pytest.raises(QmeshError, match=message):
        io.write(tmp_path / f"m{ext}", mesh)
    assert list(tmp_path.iterdir()) == []
