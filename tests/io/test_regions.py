"""Regions and a conductivity per region go into every format that keeps them and come back."""

import meshio
import numpy as np
import pytest

import qmesh
from qmesh import io
from qmesh.errors import QmeshError

A_LEFT, A_RIGHT = qmesh.Anisotropy.principal(1, 50, 30), qmesh.Anisotropy.constant([[2.0, 0.5], [0.5, 1.0]])


@pytest.mark.parametrize("ext", sorted(io.KEEPS_REGIONS))
def test_regions_and_their_names_round_trip(tmp_path, two_regions, ext):
    path = tmp_path / f"r{ext}"
    io.write(path, two_regions, anisotropy={1: A_LEFT if ext != ".vtk" else A_RIGHT, 4: A_RIGHT})
    back = io.read(path)
    np.testing.assert_array_equal(back.region_tags, two_regions.region_tags)
    assert back.region_names == {1: "left part", 4: "right"}
    np.testing.assert_array_equal(back.boundary_tags, two_regions.boundary_tags)
    stored = io.read_anisotropy(path)
    assert set(stored) == {1, 4}
    np.testing.assert_array_equal(stored[1].matrix, (A_LEFT if ext != ".vtk" else A_RIGHT).matrix)  # bit for bit
    np.testing.assert_array_equal(stored[4].matrix, A_RIGHT.matrix)


def test_vtk_title_line_has_room_for_one_record_only(tmp_path, two_regions):
    with pytest.raises(QmeshError, match="at most 256 characters; this one has .*write .vtu instead"):
        io.write(tmp_path / "r.vtk", two_regions, anisotropy={1: A_LEFT, 4: A_RIGHT})
    assert list(tmp_path.iterdir()) == []


def test_gmsh_has_a_named_2d_group_per_region(tmp_path, two_regions):
    io.write(tmp_path / "r.msh", two_regions)
    m = meshio.gmsh.read(tmp_path / "r.msh")
    groups = {k: v.tolist() for k, v in m.field_data.items()}
    # region 1 would share its number with the edges of tag 1: the file shifts the regions past them
    assert groups == {"wall": [1, 1], "hole": [2, 1], "left_part": [3, 2], "right": [6, 2]}
    assert io.read(tmp_path / "r.msh").region_names == {1: "left part", 4: "right"}  # exact, shifted back


def test_quality_is_measured_in_each_region_s_metric(tmp_path, two_regions):
    io.write(tmp_path / "r.vtu", two_regions, anisotropy={1: A_LEFT, 4: A_RIGHT})
    q = np.ravel(meshio.read(tmp_path / "r.vtu").cell_data["quality"][0])
    left = two_regions.region_tags == 1
    np.testing.assert_allclose(q[left], qmesh.measure.quality(two_regions, A_LEFT)[left])
    np.testing.assert_allclose(q[~left], qmesh.measure.quality(two_regions, A_RIGHT)[~left])


def test_mapping_must_cover_every_region(tmp_path, two_regions):
    with pytest.raises(QmeshError, match=r"no conductivity for region tags \[4\]"):
        io.write(tmp_path / "r.vtu", two_regions, anisotropy={1: A_LEFT})
    with pytest.raises(QmeshError, match="anisotropy\\[1\\] must be a qmesh.Anisotropy"):
        io.write(tmp_path / "r.vtu", two_regions, anisotropy={1: np.eye(2), 4: A_RIGHT})
    assert list(tmp_path.iterdir()) == []


def test_xdmf_is_one_grid_with_facet_tags_beside_it(tmp_path, two_regions):
    """r.xdmf: one grid "mesh" (Triangle, XY) with the region tags as "cell_tags"; r_facets.xdmf:
    grid "facet_tags"; each with its HDF5 beside it, without compression."""
    h5py = pytest.importorskip("h5py")
    import xml.etree.ElementTree as ET
    io.write(tmp_path / "r.xdmf", two_regions)
    assert {p.name for p in tmp_path.iterdir()} == {"r.xdmf", "r.h5", "r_facets.xdmf", "r_facets.h5"}
    domain = ET.parse(tmp_path / "r.xdmf").getroot().find("Domain")
    assert [g.get("Name") for g in domain] == ["mesh"]
    grid = domain.find("Grid")
    assert grid.find("Topology").get("TopologyType") == "Triangle"
    assert grid.find("Geometry").get("GeometryType") == "XY"
    attributes = [a.get("Name") for a in grid.findall("Attribute")]
    assert {"cell_tags", "skfem:s:left_part", "skfem:s:right", "skfem:b:wall", "skfem:b:hole"} <= set(attributes)
    facets = ET.parse(tmp_path / "r_facets.xdmf").getroot().find("Domain")
    assert [g.get("Name") for g in facets] == ["facet_tags"]
    assert facets.find("Grid/Attribute").get("Name") == "facet_tags"
    with h5py.File(tmp_path / "r.h5") as f:
        assert f["/Mesh/mesh/geometry"].shape == (two_regions.n_vertices, 2)
        np.testing.assert_array_equal(f["/MeshTags/cell_tags/Values"][()], two_regions.region_tags)
        assert all(f[k].compression is None for k in ("/Mesh/mesh/topology", "/MeshTags/cell_tags/Values"))
    with h5py.File(tmp_path / "r_facets.h5") as f:
        assert f["/MeshTags/facet_tags/Values"].compression is None
        assert sorted(f["/MeshTags/facet_tags/Values"][()].tolist()) == sorted(two_regions.boundary_tags.tolist())


def test_meshio_and_skfem_read_the_xdmf(tmp_path, two_regions):
    """meshio reads both files (one grid each); scikit-fem finds the named boundaries and regions."""
    skfem = pytest.importorskip("skfem")
    io.write(tmp_path / "r.xdmf", two_regions)
    m = meshio.read(tmp_path / "r.xdmf")
    assert [c.type for c in m.cells] == ["triangle"] and len(m.points) == two_regions.n_vertices
    np.testing.assert_array_equal(m.cell_data["cell_tags"][0], two_regions.region_tags)
    lines = meshio.read(tmp_path / "r_facets.xdmf")
    assert [c.type for c in lines.cells] == ["line"] and len(lines.cells[0].data) == len(two_regions.boundary_edges)
    loaded = skfem.Mesh.load(tmp_path / "r.xdmf")
    adapted = io.to_skfem(two_regions)
    assert set(loaded.boundaries) == {"wall", "hole"} and set(loaded.subdomains) == {"left_part", "right"}
    np.testing.assert_array_equal(loaded.p, adapted.p)
    for name in ("wall", "hole"):
        np.testing.assert_array_equal(np.sort(loaded.boundaries[name]), np.sort(adapted.boundaries[name]))
    for name in ("left_part", "right"):
        np.testing.assert_array_equal(np.sort(loaded.subdomains[name]), np.sort(adapted.subdomains[name]))
    back = io.read(tmp_path / "r.xdmf")
    np.testing.assert_array_equal(back.triangles, two_regions.triangles)
    np.testing.assert_array_equal(back.region_tags, two_regions.region_tags)
    np.testing.assert_array_equal(back.boundary_tags, two_regions.boundary_tags)
    assert back.tag_names == {1: "wall", 2: "hole"} and back.region_names == {1: "left part", 4: "right"}


def test_gmsh_41_by_option_keeps_regions(tmp_path, two_regions):
    io.write(tmp_path / "r.msh", two_regions, version="4.1")
    assert (tmp_path / "r.msh").read_bytes().startswith(b"$MeshFormat\n4.1 1 8\n")
    back = io.read(tmp_path / "r.msh")
    np.testing.assert_array_equal(back.region_tags, two_regions.region_tags)
    np.testing.assert_array_equal(back.points, two_regions.points)


def test_matrix_of_a_constant_q_and_refusal_of_a_varying_one():
    np.testing.assert_array_equal(A_RIGHT.matrix, [[2.0, 0.5], [0.5, 1.0]])
    with pytest.raises(QmeshError, match="varies over the domain"):
        qmesh.Anisotropy.from_expression("x**2 + y**2 + x**4").matrix
