"""One job → one row: the row holds what a direct `qmesh.mesh` call and `qmesh.measure.report`
give, the mesh file it names reads back as that mesh, and a failure is a row with its error."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh.sweep import COLUMNS, Job, run_job
from qmesh.sweep.job import failed_row


def job(tmp_path, domain="disk", conductivity="principal=[1, 100, 30]", n=200, seed=0, file=None, name="m.vtu"):
    return Job(domain, file, conductivity, n, seed, str(tmp_path / name))


def direct(domain, anisotropy, n, seed):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(domain, anisotropy, target_vertices=n, seed=seed)
    return m, qmesh.measure.report(m, anisotropy)


@settings(max_examples=5, deadline=None, derandomize=True)
@given(k1=st.floats(0.1, 10), k2=st.floats(0.1, 10), angle=st.floats(0, 180), n=st.integers(120, 300),
       seed=st.integers(0, 3))
def test_row_equals_a_direct_mesh_call(tmp_path_factory, k1, k2, angle, n, seed):
    folder = tmp_path_factory.mktemp("job")
    row = run_job(job(folder, conductivity=f"principal=[{k1!r}, {k2!r}, {angle!r}]", n=n, seed=seed))
    try:
        m, rep = direct(qmesh.domains.disk(), qmesh.Anisotropy.principal(k1, k2, angle), n, seed)
    except qmesh.QmeshError as e:       # a refused target is refused in the row as well
        assert row["error"] == str(e) and row["mesh"] is None
        return
    assert row["error"] is None and set(row) == set(COLUMNS)
    assert row["n_vertices"] == m.n_vertices and row["n_triangles"] == m.n_triangles
    assert row["kappa2"] == pytest.approx(rep["kappa2"], rel=1e-9)
    for k in ("q_nonnegative_fraction", "q_nonnegative_fraction_boundary", "min_quality", "l2_error"):
        assert row[k] == pytest.approx(rep[k], rel=1e-9)
    assert row["seconds"] > 0 and row["worker"] is None          # called here, not on a Dask worker
    back = qmesh.io.read(row["mesh"])
    assert np.allclose(back.points, m.points) and back.n_triangles == m.n_triangles


def test_varying_s_on_a_polygon_file(tmp_path):
    (tmp_path / "tri.csv").write_text("x,y\n0,0\n2,0\n0,1\n")
    row = run_job(job(tmp_path, domain="tri.csv", conductivity="s=exp(x) + y**2", n=150,
                      file=str(tmp_path / "tri.csv")))
    domain = qmesh.domain.polygon_file.read_domain(tmp_path / "tri.csv")
    m, rep = direct(domain, qmesh.Anisotropy.from_expression("exp(x) + y**2"), 150, 0)
    assert row["error"] is None
    assert (row["n_vertices"], row["kappa2"]) == (m.n_vertices, pytest.approx(rep["kappa2"], rel=1e-9))
    assert str(qmesh.io.read_anisotropy(row["mesh"]).label) == "exp(x) + y**2"


@pytest.mark.parametrize("kind, make, message", [
    ("target below the boundary", dict(n=10), "target_vertices = 10 must exceed the 64 input points"),
    ("polygon file gone", dict(domain="gone.csv", file="/nonexistent/gone.csv"), "cannot read polygon file"),
    ("unwritable mesh file", dict(name="no/such/folder/m.vtu"), "m.vtu"),
])
def test_a_failing_job_is_a_row_with_its_error(tmp_path, kind, make, message):
    j = job(tmp_path, **make)
    row = run_job(j)
    assert message in row["error"]
    assert (row["domain"], row["conductivity"], row["target_vertices"], row["seed"]) == j.key
    assert row["mesh"] is None and set(row) == set(COLUMNS)


def test_an_error_that_is_not_qmeshs_keeps_its_type(tmp_path):
    row = failed_row(job(tmp_path), MemoryError())
    assert row["error"] == "MemoryError" and row["n_vertices"] is None
    assert failed_row(job(tmp_path), OSError("disk full"))["error"] == "OSError: disk full"
