"""The element means Q̄_T (`Mesh.conductivity`) go into every format that keeps cell data as
Q11 Q12 Q22, come back bit for bit with `qmesh.io.read`, and reach scikit-fem and NGSolve as
what they assemble: the stiffness matrix K_ij = Σ_T |T| ∇φ_iᵀ Q̄_T ∇φ_j."""

import warnings

import meshio
import numpy as np
import pytest
import scipy.sparse as sp
from means_reference import assert_assembles_the_means

import qmesh
from qmesh import io
from qmesh.errors import QmeshError, QmeshWarning

KEEPERS = sorted(io.KEEPS_MEANS)


def test_the_registry_says_which_formats_keep_them():
    assert set(io.KEEPS_MEANS) == {".vtu", ".vtk", ".msh", ".xdmf"}
    assert set(io.FORMATS) - io.KEEPS_MEANS == {".mesh", ".obj"}


@pytest.mark.parametrize("ext, version", [(ext, None) for ext in KEEPERS] + [(".msh", "4.1")])
def test_means_round_trip_bit_for_bit(tmp_path, with_means, ext, version):
    path = tmp_path / f"m{ext}"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        io.write(path, with_means, version=version)
    back = io.read(path)
    np.testing.assert_array_equal(back.conductivity, with_means.conductivity)
    np.testing.assert_array_equal(back.region_tags, with_means.region_tags)
    np.testing.assert_array_equal(back.boundary_tags, with_means.boundary_tags)


@pytest.mark.parametrize("ext", [".vtu", ".xdmf"])
def test_meshio_sees_them_as_cell_data(tmp_path, with_means, ext):
    io.write(tmp_path / f"m{ext}", with_means)
    m = meshio.read(tmp_path / f"m{ext}")
    block = [c.type for c in m.cells].index("triangle")
    for name, (i, j) in (("Q11", (0, 0)), ("Q12", (0, 1)), ("Q22", (1, 1))):
        np.testing.assert_array_equal(np.ravel(m.cell_data[name][block]), with_means.conductivity[:, i, j])


def test_every_client_still_reads_a_msh_with_means(tmp_path, with_means):
    """gmsh 2.2 keeps them in a section meshio, scikit-fem, gmsh and NGSolve skip."""
    path = tmp_path / "m.msh"
    io.write(path, with_means)
    assert b"$QmeshElementMeans\n" in path.read_bytes()
    m = meshio.read(path)
    assert sum(len(c.data) for c in m.cells if c.type == "triangle") == with_means.n_triangles
    skfem = pytest.importorskip("skfem")
    assert set(skfem.MeshTri.load(path).boundaries) == {"wall", "hole"}


@pytest.mark.parametrize("ext", sorted(set(io.FORMATS) - io.KEEPS_MEANS))
def test_formats_without_cell_data_drop_them_and_say_so(tmp_path, with_means, ext):
    with pytest.warns(QmeshWarning, match=f"{ext} keeps no cell data.*element means"):
        io.write(tmp_path / f"m{ext}", with_means)
    assert io.read(tmp_path / f"m{ext}").conductivity is None


@pytest.mark.parametrize("ext", sorted(io.FORMATS))
def test_a_mesh_without_means_writes_none(tmp_path, two_regions, ext):
    path = tmp_path / f"m{ext}"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        io.write(path, two_regions)
    assert io.read(path).conductivity is None
    if ext == ".msh":
        assert b"QmeshElementMeans" not in path.read_bytes()
    if ext in (".vtu", ".vtk", ".xdmf"):
        assert not {"Q11", "Q12", "Q22"} & set(meshio.read(path).cell_data)


def test_unsymmetric_means_are_refused(tmp_path, two_regions):
    Q = np.tile(np.array([[2.0, 0.5], [0.4, 1.0]]), (two_regions.n_triangles, 1, 1))
    m = qmesh.Mesh(two_regions.points, two_regions.triangles, conductivity=Q)
    with pytest.raises(QmeshError, match=r"conductivity\[0\] is not symmetric"):
        io.write(tmp_path / "m.vtu", m)
    assert list(tmp_path.iterdir()) == []


def test_the_names_are_reserved(tmp_path, two_regions):
    with pytest.raises(QmeshError, match="reserved"):
        io.write(tmp_path / "m.vtu", two_regions, cell_data={"Q12": np.zeros(two_regions.n_triangles)})


def test_a_file_with_part_of_them_is_one_error(tmp_path, two_regions):
    P = np.column_stack([two_regions.points, np.zeros(two_regions.n_vertices)])
    m = meshio.Mesh(P, [("triangle", two_regions.triangles)],
                    cell_data={"Q11": [np.ones(two_regions.n_triangles)], "Q22": [np.ones(two_regions.n_triangles)]})
    meshio.write(tmp_path / "other.vtu", m)
    with pytest.raises(QmeshError, match="need cell data Q11, Q12, Q22; found only Q11, Q22"):
        io.read(tmp_path / "other.vtu")


def test_means_of_another_program_are_read(tmp_path, two_regions):
    n = two_regions.n_triangles
    P = np.column_stack([two_regions.points, np.zeros(two_regions.n_vertices)])
    m = meshio.Mesh(P, [("triangle", two_regions.triangles)],
                    cell_data={"Q11": [np.full(n, 2.0)], "Q12": [np.full(n, 0.5)], "Q22": [np.full(n, 1.0)]})
    meshio.write(tmp_path / "other.vtu", m)
    np.testing.assert_array_equal(io.read(tmp_path / "other.vtu").conductivity, np.tile([[2.0, 0.5], [0.5, 1.0]], (n, 1, 1)))


@pytest.mark.parametrize("edit", ["count", "rows", "end"])
def test_a_broken_means_section_is_one_error(tmp_path, with_means, edit):
    path = tmp_path / "m.msh"
    io.write(path, with_means)
    data = path.read_bytes()
    head = b"$QmeshElementMeans\n"
    start = data.index(head) + len(head)
    if edit == "count":
        data = data[:start] + b"99999999999" + data[data.index(b"\n", start):]
    elif edit == "rows":
        line = data.index(b"\n", data.index(b"\n", start) + 1)
        data = data[:line] + b" 7" + data[line:]
    else:
        data = data.replace(b"$EndQmeshElementMeans", b"$EndQmesh")
    path.write_bytes(data)
    with pytest.raises(QmeshError, match="QmeshElementMeans"):
        io.read(path)


# --------------------------------------------------------------------------- adapters

def test_skfem_assembles_the_means(with_means):
    skfem = pytest.importorskip("skfem")
    from skfem.helpers import dot, grad, mul
    m, Q = io.to_skfem(with_means, with_means=True)
    assert Q.shape == (2, 2, with_means.n_triangles, 1)
    np.testing.assert_array_equal(m.t, np.sort(with_means.triangles.T, axis=0))  # element e is triangle e
    basis = skfem.Basis(m, skfem.ElementTriP1())
    K = skfem.BilinearForm(lambda u, v, w: dot(mul(w.Q, grad(u)), grad(v))).assemble(basis, Q=Q)
    assert_assembles_the_means(K, with_means)


def test_skfem_without_means(two_regions):
    skfem = pytest.importorskip("skfem")
    assert isinstance(io.to_skfem(two_regions), skfem.MeshTri)
    m, Q = io.to_skfem(two_regions, with_means=True)
    assert isinstance(m, skfem.MeshTri) and Q is None


def test_ngsolve_assembles_the_means(with_means):
    ngsolve = pytest.importorskip("ngsolve")
    m, Q = io.to_ngsolve(with_means, with_means=True)
    assert tuple(Q.dims) == (2, 2) and set(m.GetMaterials()) == {"left_part", "right"}
    fes = ngsolve.H1(m, order=1)          # dof i is vertex i: to_ngsolve adds the points in order
    u, v = fes.TnT()
    a = ngsolve.BilinearForm(fes)
    a += (Q * ngsolve.grad(u)) * ngsolve.grad(v) * ngsolve.dx
    a.Assemble()
    rows, cols, vals = a.mat.COO()
    K = sp.coo_matrix((np.asarray(vals), (np.asarray(rows), np.asarray(cols))), shape=(fes.ndof, fes.ndof))
    assert_assembles_the_means(K, with_means)


def test_ngsolve_without_means(two_regions):
    ngsolve = pytest.importorskip("ngsolve")
    assert isinstance(io.to_ngsolve(two_regions), ngsolve.Mesh)
    assert io.to_ngsolve(two_regions, with_means=True).conductivity is None
