"""Each FEM client installed reads qmesh's files with its own reader, finds the names, and
solves −div(Q∇u) = 1 (u = 0 on "wall") to scikit-fem's solution on the Mesh's own arrays; and
solves the guide's two problems ("From conductivity to solution": examples/ngsolve_solve.py,
dolfinx_solve.py) with the element means to scikit-fem's u_h and L2 error on the same mesh.

scikit-fem, gmsh and NGSolve are installed by `.[all,peers]`; DOLFINx needs Python >= 3.12 and
runs in a venv of its own (`dolfinx_env`: built once where such a Python exists, cached)."""

import json
import runpy
import sys
import tempfile
from pathlib import Path

import dolfinx_env
import numpy as np
import pytest
import scipy.sparse as sp
from means_reference import assert_assembles_the_means
from scipy.spatial import cKDTree

import qmesh
from qmesh import io

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
sys.path.insert(0, str(EXAMPLES))
import fem_problem  # noqa: E402
import solve_problems  # noqa: E402

GUIDE_N = 1500           # the guide's problems at the page's N (each meshed in about a second)


@pytest.fixture(scope="module")
def guide_problems():
    """{name: (problem, mesh, scikit-fem's u_h, its L2 error, its positive off-diagonals)}."""
    pytest.importorskip("skfem")
    out = {}
    for name, problem, mesh in solve_problems.meshed(GUIDE_N):
        sk = solve_problems.skfem_solve(mesh, problem)
        out[name] = problem, mesh, sk.u, solve_problems.l2_error(mesh, problem, sk.u), sk.positive
    return out


def assert_as_skfem(name, guide_problems, u, error, positive, at=slice(None)):
    """The same u_h (u at mesh vertices `at`) and L2 error as scikit-fem's, to rounding: all three
    codes integrate f φ_i and (u_h − u)² by the same 12-point rule of degree 6; and no positive
    off-diagonal (the mesh's certificate)."""
    _, mesh, u_sk, error_sk, positive_sk = guide_problems[name]
    np.testing.assert_allclose(u, u_sk[at], rtol=0, atol=1e-10 * np.ptp(u_sk))
    assert error == pytest.approx(error_sk, rel=1e-10) and error_sk > 1e-4
    assert positive == positive_sk == 0


@pytest.fixture(scope="module")
def mesh():
    return fem_problem.make_mesh(400)


@pytest.fixture(scope="module")
def reference(mesh):
    pytest.importorskip("skfem")
    return fem_problem.reference(mesh)


@pytest.mark.parametrize("ext", [".msh", ".vtu"])
def test_skfem_loads_the_file_as_written(tmp_path, mesh, reference, ext):
    skfem = pytest.importorskip("skfem")
    io.write(tmp_path / f"plate{ext}", mesh, anisotropy=fem_problem.ANISOTROPY)
    loaded = skfem.MeshTri.load(tmp_path / f"plate{ext}")
    assert set(loaded.boundaries) == {"wall", "hole"} and set(loaded.subdomains) == {"domain"}
    adapted = io.to_skfem(mesh)
    for name in ("wall", "hole"):
        np.testing.assert_array_equal(np.sort(loaded.boundaries[name]), np.sort(adapted.boundaries[name]))
    Q = io.read_anisotropy(tmp_path / f"plate{ext}").matrix
    np.testing.assert_array_equal(Q, fem_problem.ANISOTROPY.matrix)


def test_skfem_subdomains_by_region_name(tmp_path, mesh):
    skfem = pytest.importorskip("skfem")
    x = mesh.points[mesh.triangles].mean(axis=1)[:, 0]
    regioned = qmesh.Mesh(mesh.points, mesh.triangles, mesh.fixed, boundary_edges=mesh.boundary_edges,
                          boundary_tags=mesh.boundary_tags, tag_names=mesh.tag_names,
                          region_tags=np.where(x < 1, 1, 2), region_names={1: "left", 2: "right"})
    for ext in (".msh", ".vtu"):
        io.write(tmp_path / f"r{ext}", regioned)
        loaded = skfem.MeshTri.load(tmp_path / f"r{ext}")
        assert set(loaded.boundaries) == {"wall", "hole"}
        np.testing.assert_array_equal(np.sort(loaded.subdomains["left"]), np.flatnonzero(x < 1))
    adapted = io.to_skfem(regioned)
    np.testing.assert_array_equal(adapted.subdomains["right"], np.flatnonzero(x >= 1))


def test_gmsh_opens_the_file(tmp_path, mesh):
    gmsh = pytest.importorskip("gmsh")
    io.write(tmp_path / "plate.msh", mesh)
    gmsh.initialize(["-v", "0"])
    try:
        gmsh.open(str(tmp_path / "plate.msh"))
        groups = {gmsh.model.getPhysicalName(*g): g for g in gmsh.model.getPhysicalGroups()}
        n_nodes = len(gmsh.model.mesh.getNodes()[0])
        triangles = gmsh.model.mesh.getElements(2)[1][0]
    finally:
        gmsh.finalize()
    assert set(groups) == {"wall", "hole", "domain"} and groups["wall"] == (1, 1) and groups["hole"] == (1, 2)
    assert n_nodes == mesh.n_vertices and len(triangles) == mesh.n_triangles


def test_ngsolve_reads_the_msh_and_solves_as_skfem(mesh, reference):
    pytest.importorskip("ngsolve")
    example = runpy.run_path(str(EXAMPLES / "fem_ngsolve.py"), run_name="fem_ngsolve")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "plate.msh"
        io.write(path, mesh, anisotropy=fem_problem.ANISOTROPY)
        result = example["solve"](path)
    assert result["boundaries"] == ["hole", "wall"] and result["materials"] == ["domain"]
    assert result["n_vertices"] == mesh.n_vertices
    np.testing.assert_allclose(result["u"], reference, rtol=0, atol=1e-12 * np.abs(reference).max())
    skfem = pytest.importorskip("skfem")
    basis = skfem.Basis(io.to_skfem(mesh), skfem.ElementTriP1())
    free = np.setdiff1d(np.arange(mesh.n_vertices), mesh.boundary_edges[mesh.boundary_tags == 1].ravel())
    from skfem.helpers import dot, grad
    Q = fem_problem.ANISOTROPY.matrix
    A = skfem.BilinearForm(lambda u, v, w: dot(np.einsum("ij,j...->i...", Q, grad(u)), grad(v))).assemble(basis)
    assert result["positive_off_diagonals"] == fem_problem.positive_off_diagonals(A, free)


def test_ngsolve_adapter_has_the_names_and_the_area(mesh):
    ngsolve = pytest.importorskip("ngsolve")
    m = io.to_ngsolve(mesh)
    assert set(m.GetBoundaries()) == {"wall", "hole"} and list(m.GetMaterials()) == ["domain"]
    assert ngsolve.Integrate(1, m) == pytest.approx(2 - 0.16, rel=1e-12)
    assert ngsolve.Integrate(1, m, definedon=m.Boundaries("hole")) == pytest.approx(1.6, rel=1e-12)


def test_ngsolve_solves_the_guide_problems_as_skfem(guide_problems, capsys):
    """examples/ngsolve_solve.py meshes the guide's problems itself: the same meshes, scikit-fem's
    solution, and the lines it prints give scikit-fem's L2 errors."""
    pytest.importorskip("ngsolve")
    example = runpy.run_path(str(EXAMPLES / "ngsolve_solve.py"), run_name="ngsolve_solve")
    results = example["main"](GUIDE_N)
    printed = capsys.readouterr().out
    for name, (_, mesh, _, error, _) in guide_problems.items():
        result = results[name]
        assert_as_skfem(name, guide_problems, result.u, result.error, result.positive)
        assert f"NGSolve, {name}: N={mesh.n_vertices}, L2 error {error:.4g}, 0 positive off-diagonals" in printed


@pytest.fixture(scope="module")
def dolfinx_python():
    """The python of DOLFINx's venv (`dolfinx_env`: built once and cached), or a skip saying why there is none."""
    python, note = dolfinx_env.venv()
    if python is None:
        pytest.skip(note)
    return python


def _run(python, args, timeout=600):
    out = dolfinx_env.run(python, [str(a) for a in args], timeout=timeout)
    assert out.returncode == 0, out.stderr[-3000:]
    return out


@pytest.mark.slow(60)   # builds DOLFINx's venv on a machine's first run (about 60 s); 3 s once cached
def test_dolfinx_reads_the_xdmf_and_solves_as_skfem(tmp_path, reference, dolfinx_python):
    """DOLFINx reads plate.xdmf and plate_facets.xdmf with its own reader (examples/fem_dolfinx.py)."""
    out = tmp_path / "result.json"
    _run(dolfinx_python, [EXAMPLES / "fem_dolfinx.py", "400", "--out", tmp_path, "--json", out])
    result = json.loads(out.read_text())
    assert result["gdim"] == 2 and result["facet_tags"] == [1, 2]
    assert result["names"] == {"1": "wall", "2": "hole"}
    assert result["adapter"]["cells"] == result["expected"]["cells"]            # qmesh.io.to_dolfinx
    assert result["adapter"]["facet_tags"] == result["expected"]["facet_tags"]
    assert result["adapter"]["names"] == {"1": "wall", "2": "hole"}
    mesh = io.read(tmp_path / "plate.xdmf")                     # the mesh DOLFINx solved on
    expected = fem_problem.reference(mesh)
    _, at = cKDTree(mesh.points).query(np.array(result["points"]))
    np.testing.assert_allclose(result["u"], expected[at], rtol=0, atol=1e-10 * np.abs(expected).max())


@pytest.mark.slow(3)
def test_dolfinx_assembles_the_element_means(tmp_path, with_means, dolfinx_python):
    """DOLFINx reads the .xdmf (mesh, cell tags, facet tags from name_facets.xdmf); the means as a
    DG0 tensor Function, from the file and from `to_dolfinx`, assemble qmesh's stiffness matrix."""
    io.write(tmp_path / "r.xdmf", with_means)
    out = tmp_path / "result.json"
    _run(dolfinx_python, [Path(dolfinx_env.__file__).with_name("dolfinx_means_check.py"), tmp_path / "r.xdmf", out])
    result = json.loads(out.read_text())
    n = with_means.n_vertices
    for source in ("file", "adapter"):
        K = sp.coo_matrix((result[source]["vals"], (result[source]["rows"], result[source]["cols"])), shape=(n, n))
        assert_assembles_the_means(K, with_means)
    assert result["adapter_value_shape"] == [2, 2] and result["adapter_name"] == "Q"
    regions = np.full(with_means.n_triangles, -1)
    regions[result["cells"]] = result["cell_values"]
    np.testing.assert_array_equal(regions, with_means.region_tags)
    tagged = sorted(zip(map(tuple, result["facets"]), result["facet_values"]))
    expected = sorted(zip(map(tuple, np.sort(with_means.boundary_edges, axis=1).tolist()),
                          with_means.boundary_tags.tolist()))
    assert tagged == expected


@pytest.mark.slow(10)
def test_dolfinx_solves_the_guide_problems_as_skfem(tmp_path, guide_problems, dolfinx_python):
    """examples/dolfinx_solve.py, run in DOLFINx's venv, meshes the guide's problems itself: the
    same meshes (every dof on a vertex of the mesh meshed here), scikit-fem's solution, and the
    lines the guide shows it printing."""
    out = tmp_path / "result.json"
    done = _run(dolfinx_python, [EXAMPLES / "dolfinx_solve.py", GUIDE_N, "--json", out])
    page = (ROOT / "docs" / "guide" / "solve.md").read_text()
    shown = [line for line in page.splitlines() if line.startswith("DOLFINx, ")]
    assert len(shown) == 2 and all(line in done.stdout.splitlines() for line in shown)   # the page's output
    results = json.loads(out.read_text())
    for name, (_, mesh, _, error, _) in guide_problems.items():
        result = results[name]
        assert result["n_vertices"] == mesh.n_vertices and len(result["u"]) == mesh.n_vertices
        distance, at = cKDTree(mesh.points).query(np.array(result["points"]))
        assert distance.max() <= 1e-14 and len(set(at.tolist())) == mesh.n_vertices
        assert_as_skfem(name, guide_problems, result["u"], result["error"], result["positive"], at)
        assert f"DOLFINx, {name}: N={mesh.n_vertices}, L2 error {error:.4g}, 0 positive off-diagonals" in done.stdout
