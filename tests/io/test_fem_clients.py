"""Each FEM client installed reads qmesh's files with its own reader, finds the names, and
solves −div(Q∇u) = 1 (u = 0 on "wall") to scikit-fem's solution on the Mesh's own arrays.

scikit-fem, gmsh and NGSolve are installed by `.[all,peers]`; DOLFINx needs Python >= 3.12 and
runs in a venv of its own, built here only when such a Python is on the PATH."""

import json
import runpy
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

import qmesh
from qmesh import io

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
sys.path.insert(0, str(EXAMPLES))
import fem_problem  # noqa: E402


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


def _python_312():
    """A Python >= 3.12 that runs (a pyenv shim of a version not installed does not)."""
    for name in ("python3.14", "python3.13", "python3.12"):
        found = shutil.which(name)
        if not found:
            continue
        try:
            ok = subprocess.run([found, "-c", "import sys, venv; sys.exit(sys.version_info < (3, 12))"],
                                capture_output=True, timeout=60).returncode == 0
        except (OSError, subprocess.SubprocessError):
            ok = False
        if ok:
            return found
    return None


def test_dolfinx_reads_the_xdmf_and_solves_as_skfem(tmp_path, reference):
    """Builds (once, under the temp folder) a venv with qmesh[fem-dolfinx] and runs the example there."""
    python = _python_312()
    if python is None:
        pytest.skip("DOLFINx's wheels need Python >= 3.12 and no working python3.12/3.13/3.14 is on the PATH; "
                    "see the README's FEM adapters paragraph")
    venv = Path(tempfile.gettempdir()) / "qmesh-dolfinx-venv"
    bin_python = venv / "bin" / "python"
    if not bin_python.exists():
        subprocess.run([python, "-m", "venv", str(venv)], check=True)
        subprocess.run([str(bin_python), "-m", "pip", "install", "-q", "-e", f"{ROOT}[fem-dolfinx]"], check=True,
                       timeout=1800)
    out = tmp_path / "result.json"
    subprocess.run([str(bin_python), str(EXAMPLES / "fem_dolfinx.py"), "400", "--out", str(tmp_path),
                    "--json", str(out)], check=True, timeout=600)
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
