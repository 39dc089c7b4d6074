"""`qmesh.io.to_modflow6` checked without the mf6 program: the simulation it writes is loaded back
by flopy, and MODFLOW 6's horizontal conductance — written out below from its source
(gwf-npf.f90 `calc_condsat`, GwfConductanceUtils.f90 `condmean`, harmonic mean) — equals
q_ij × thickness on every edge with q_ij > 0; the cells tile the domain; bad input is one
QmeshError and leaves nothing in the workspace."""

import os

import flopy
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from modflow_cases import CASES
from scipy.spatial import Delaunay

import qmesh
from qmesh import io
from qmesh.errors import QmeshError
from qmesh.geometry.median_dual import median_dual

TOP, BOTTOM = 3.0, -0.5


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request):
    return CASES[request.param]()


@pytest.fixture(scope="module")
def written(case, tmp_path_factory):
    """The case written and loaded back by flopy: (case, the model's packages, q per edge)."""
    folder = tmp_path_factory.mktemp("mf6") / "sim"
    io.to_modflow6(case.mesh, folder, case.conductivity, name="case", top=TOP, bottom=BOTTOM)
    sim = flopy.mf6.MFSimulation.load(sim_ws=str(folder), verbosity_level=0)
    gwf = sim.get_model("case")
    return case, gwf, sim


def modflow_conductance(disu, npf):
    """(n, m, C) for each connection n < m, by MODFLOW 6's formula for confined cells:
    C = HWVA · T_n T_m / (T_n · CL2 + T_m · CL1), T = K · (TOP − BOT), CL1 the entry of n's row,
    CL2 the entry of m's row (the distances from each cell's centre to the face)."""
    iac, ja = disu.iac.array, disu.ja.array
    cl12, hwva = disu.cl12.array, disu.hwva.array
    row = np.repeat(np.arange(len(iac)), iac)
    diagonal = np.concatenate([[0], np.cumsum(iac)[:-1]])
    assert np.array_equal(ja[diagonal], np.arange(len(iac)))         # each row starts with itself
    off = np.ones(len(ja), bool)
    off[diagonal] = False
    n, m, cl, w = row[off], ja[off], cl12[off], hwva[off]
    key_nm, key_mn = n * len(iac) + m, m * len(iac) + n
    back = np.argsort(key_nm)[np.searchsorted(np.sort(key_nm), key_mn)]   # the m–n entry of each n–m
    assert np.array_equal(w, w[back])                                    # HWVA is symmetric
    thick = disu.top.array - disu.bot.array
    K = np.broadcast_to(npf.k.array, thick.shape)
    t = K * thick
    up = n < m
    n, m, cl1, cl2, w = n[up], m[up], cl[up], cl[back][up], w[up]
    return n, m, w * t[n] * t[m] / (t[n] * cl2 + t[m] * cl1)


def test_conductances_are_q_times_thickness(written):
    case, gwf, _ = written
    n, m, C = modflow_conductance(gwf.disu, gwf.npf)
    assert gwf.npf.k22.array is None and gwf.npf.k33.array is None and not gwf.npf.xt3doptions.get_data()
    assert np.all(gwf.npf.icelltype.array == 0)
    edges, q, _ = qmesh.measure.edge_q(case.mesh, case.conductivity)
    positive = q > 0
    assert np.all(C > 0) and len(C) == positive.sum()
    N = case.mesh.n_vertices
    order = np.argsort(n * N + m)
    np.testing.assert_array_equal(np.column_stack([n, m])[order], edges[positive])   # i < j, sorted
    expected = q[positive] * (TOP - BOTTOM)
    assert np.max(np.abs(C[order] - expected) / expected) <= 1e-12


def test_cells_tile_the_domain(written):
    case, gwf, _ = written
    disu = gwf.disu
    area = disu.area.array
    assert disu.nodes.get_data() == case.mesh.n_vertices and np.all(area > 0)
    assert area.sum() == pytest.approx(case.area, rel=1e-12)
    # each CELL2D polygon, clockwise, has the cell's AREA and its centre at its vertex
    V = np.array([(x, y) for _, x, y in disu.vertices.array])
    for k, x, y, count, *corners in disu.cell2d.array:
        ring = V[np.array(corners[:count], dtype=int)]
        shoelace = 0.5 * np.sum(ring[:, 0] * np.roll(ring[:, 1], -1) - np.roll(ring[:, 0], -1) * ring[:, 1])
        assert shoelace == pytest.approx(-area[k], rel=1e-9, abs=1e-15)
        assert (x, y) == tuple(case.mesh.points[k])


def test_the_face_normals_point_from_cell_to_cell(written):
    """ANGLDEGX of n–m is the normal of the dual face: within 90° of the edge n → m, opposite for m–n."""
    case, gwf, _ = written
    disu = gwf.disu
    iac, ja, angle = disu.iac.array, disu.ja.array, np.radians(disu.angldegx.array)
    row = np.repeat(np.arange(len(iac)), iac)
    off = ja != row
    d = case.mesh.points[ja[off]] - case.mesh.points[row[off]]
    assert np.all(d[:, 0] * np.cos(angle[off]) + d[:, 1] * np.sin(angle[off]) > 0)


def test_the_simulation_holds_its_packages(written):
    _, gwf, sim = written
    assert sim.tdis.nper.get_data() == 1 and gwf.get_package("sto") is None                # steady
    assert sim.ims.linear_acceleration.get_data().lower() == "cg"
    assert gwf.oc.head_filerecord.get_data()[0][0] == "case.hds"
    assert np.all(gwf.ic.strt.array == TOP)


def test_the_mesh_means_are_taken_when_no_conductivity_is_given(tmp_path):
    case = CASES["raster"]()
    folders = tmp_path / "none", tmp_path / "given"
    io.to_modflow6(case.mesh, folders[0])
    io.to_modflow6(case.mesh, folders[1], np.array(case.mesh.conductivity))
    texts = [[ln for ln in (f / "qmesh.disu").read_text().splitlines() if not ln.startswith("#")]
             for f in folders]                                  # flopy's first line has the time
    assert texts[0] == texts[1] and len(texts[0]) > 1000


# --------------------------------------------------------------------------- cell ids

def test_cells_of_tags_and_points(written):
    case, _, _ = written
    mesh = case.mesh
    left = io.modflow_cells(mesh, tags="left")
    np.testing.assert_array_equal(left, io.modflow_cells(mesh, tags=4))
    np.testing.assert_array_equal(left, np.flatnonzero(mesh.points[:, 0] == 0))
    both = io.modflow_cells(mesh, tags=["left", 2])
    x_max = mesh.points[:, 0].max()
    np.testing.assert_array_equal(both, np.flatnonzero((mesh.points[:, 0] == 0) | (mesh.points[:, 0] == x_max)))
    k = np.array([5, 0, len(mesh.points) - 1])
    np.testing.assert_array_equal(io.modflow_cells(mesh, points=mesh.points[k] + 1e-9), k)


def test_cells_refuse_unknown_tags_and_ambiguous_calls(written):
    mesh = written[0].mesh
    with pytest.raises(QmeshError, match="tags: 'nowhere' is no boundary tag"):
        io.modflow_cells(mesh, tags="nowhere")
    with pytest.raises(QmeshError, match="tags: 99"):
        io.modflow_cells(mesh, tags=[1, 99])
    with pytest.raises(QmeshError, match="exactly one of tags= and points="):
        io.modflow_cells(mesh)
    with pytest.raises(QmeshError, match="points"):
        io.modflow_cells(mesh, points=[[np.nan, 0]])


# --------------------------------------------------------------------------- bad input

@pytest.fixture(scope="module")
def disk():
    """A small qmesh mesh for Q = I (every q_ij ≥ 0)."""
    return qmesh.mesh(qmesh.Disk(16), qmesh.Anisotropy.constant(np.eye(2)), target_vertices=60)


def _left_behind(parent):
    return sorted(p.name for p in parent.iterdir())


def test_a_negative_q_is_refused_naming_the_edge(tmp_path, delaunay_mesh):
    A = qmesh.Anisotropy.principal(1, 1e-3, 30)
    edges, q, _ = qmesh.measure.edge_q(delaunay_mesh, A)
    worst = np.argmin(q)
    assert q[worst] < 0
    i, j = edges[worst]
    with pytest.raises(QmeshError, match=rf"edge \({i}, {j}\) .* has q_ij = {q[worst]:.6g} < 0"):
        io.to_modflow6(delaunay_mesh, tmp_path / "sim", A)
    assert _left_behind(tmp_path) == []


def test_a_mesh_without_means_needs_a_conductivity(tmp_path, delaunay_mesh):
    with pytest.raises(QmeshError, match=r"anisotropy must be given .* \(mesh.conductivity is None\)"):
        io.to_modflow6(delaunay_mesh, tmp_path / "sim")
    assert _left_behind(tmp_path) == []


def test_a_workspace_that_is_a_file_is_refused(tmp_path, delaunay_mesh):
    (tmp_path / "sim").write_text("mine")
    with pytest.raises(QmeshError, match="workspace .* is an existing file"):
        io.to_modflow6(delaunay_mesh, tmp_path / "sim", qmesh.Anisotropy.constant(np.eye(2)))
    assert (tmp_path / "sim").read_text() == "mine" and _left_behind(tmp_path) == ["sim"]


@pytest.mark.parametrize("kwargs, match", [({"name": "two words"}, "name must be"),
                                           ({"name": "x" * 17}, "name must be"),
                                           ({"top": 0.0}, "bottom must be"),
                                           ({"exe_name": 3}, "exe_name")])
def test_bad_options_are_refused(tmp_path, delaunay_mesh, kwargs, match):
    with pytest.raises(QmeshError, match=match):
        io.to_modflow6(delaunay_mesh, tmp_path / "sim", qmesh.Anisotropy.constant(np.eye(2)), **kwargs)
    assert _left_behind(tmp_path) == []


def test_a_failed_write_leaves_nothing(tmp_path, disk, monkeypatch):
    def fail(self, *args, **kwargs):
        raise OSError("disk full")
    monkeypatch.setattr(flopy.mf6.MFSimulation, "write_simulation", fail)
    with pytest.raises(QmeshError, match="cannot write the MODFLOW 6 simulation .* disk full"):
        io.to_modflow6(disk, tmp_path / "sim", qmesh.Anisotropy.constant(np.eye(2)))
    assert _left_behind(tmp_path) == []


def test_an_existing_folder_keeps_its_other_files(tmp_path, disk):
    folder = tmp_path / "sim"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    io.to_modflow6(disk, folder, qmesh.Anisotropy.constant(np.eye(2)), name="m")
    names = set(os.listdir(folder))
    assert {"notes.txt", "mfsim.nam", "m.nam", "m.disu", "m.npf"} <= names
    assert _left_behind(tmp_path) == ["sim"]


# --------------------------------------------------------------------------- the median dual

@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(4, 60))
def test_median_dual_cells_are_their_lumped_masses(seed, n):
    """On scipy's Delaunay triangulation of random points, each cell's polygon is
    counter-clockwise with the area Σ_T |T|/3, and the cells add up to the triangles."""
    rng = np.random.default_rng(seed)
    P = rng.random((n, 2)) * [3.0, 0.5]
    T = Delaunay(P).simplices
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    doubled = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    cw = doubled < 0
    T[cw] = T[cw][:, [0, 2, 1]]
    mesh = qmesh.Mesh(P, T)
    edges, _, _ = qmesh.measure.edge_q(mesh)
    dual = median_dual(P, T, edges, io.boundary.boundary_of(mesh)[0])
    areas = []
    for k in range(n):
        ring = dual.points[dual.corners[dual.offsets[k]:dual.offsets[k + 1]]]
        areas.append(0.5 * np.sum(ring[:, 0] * np.roll(ring[:, 1], -1) - np.roll(ring[:, 0], -1) * ring[:, 1]))
    assert np.allclose(areas, dual.areas, rtol=1e-9, atol=1e-15) and np.all(dual.areas > 0)
    assert dual.areas.sum() == pytest.approx(0.5 * np.abs(doubled).sum(), rel=1e-12)
