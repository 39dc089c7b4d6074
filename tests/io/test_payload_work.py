"""What the writers' payload computes, and only when a format needs it: the metric quality is
measured for a format that keeps cell data and not for MSH 2.2 (which keeps none), with the
same values either way; the boundary edges come out oriented with Ω on the left, as from every
half-edge of the mesh."""

import meshio
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.io import boundary, payload as payload_module


@pytest.fixture(scope="module")
def small_mesh():
    return qmesh.mesh(qmesh.Disk(16), qmesh.Anisotropy.constant(qmesh.CHAPTER_Q), target_vertices=200, seed=0)


def _counting(monkeypatch):
    calls = []
    real = payload_module.quality

    def counted(mesh, anisotropy=None):
        calls.append(1)
        return real(mesh, anisotropy)
    monkeypatch.setattr(payload_module, "quality", counted)
    return calls


def test_msh_22_does_not_measure_the_quality(tmp_path, small_mesh, monkeypatch):
    calls = _counting(monkeypatch)
    qmesh.io.write(tmp_path / "m.msh", small_mesh, anisotropy=qmesh.Anisotropy.constant(qmesh.CHAPTER_Q))
    assert calls == []


def test_vtu_measures_it_once_and_writes_it(tmp_path, small_mesh, monkeypatch):
    a = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    calls = _counting(monkeypatch)
    qmesh.io.write(tmp_path / "m.vtu", small_mesh, anisotropy=a)
    assert calls == [1]
    written = meshio.read(tmp_path / "m.vtu").cell_data["quality"][0]
    np.testing.assert_array_equal(written, qmesh.measure.quality(small_mesh, a))


def test_missing_region_is_refused_before_any_file(tmp_path, small_mesh):
    regions = qmesh.Mesh(small_mesh.points, small_mesh.triangles, small_mesh.fixed,
                         region_tags=np.arange(small_mesh.n_triangles) % 2)
    with pytest.raises(qmesh.QmeshError, match="region tags \\[1\\]"):
        qmesh.io.write(tmp_path / "m.msh", regions, anisotropy={0: qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)})
    assert list(tmp_path.iterdir()) == []


def _oriented_by_every_half_edge(T, E, n):
    half = set(zip(T.ravel().tolist(), T[:, [1, 2, 0]].ravel().tolist()))
    return np.array([(a, b) if (a, b) in half else (b, a) for a, b in E.tolist()]).reshape(-1, 2)


@given(st.integers(0, 2**31), st.integers(4, 40))
@settings(max_examples=40, deadline=None)
@pytest.mark.filterwarnings("ignore:every one of the N:qmesh.QmeshWarning")   # tiny disks: fine here
def test_boundary_edges_oriented_as_their_triangle(seed, vb):
    m = qmesh.mesh(qmesh.Disk(vb), qmesh.Anisotropy.constant([[1.0, 0.0], [0.0, 1.0]]),
                   target_vertices=3 * vb, seed=seed % 1000)
    rng = np.random.default_rng(seed)
    E = np.asarray(m.boundary_edges)
    E = np.where(rng.random(len(E))[:, None] < 0.5, E, E[:, ::-1])        # half of them turned
    got = boundary._oriented(m.triangles, E, m.n_vertices)
    np.testing.assert_array_equal(got, _oriented_by_every_half_edge(m.triangles, E, m.n_vertices))


def test_mesh_command_loads_only_what_a_msh_needs(tmp_path):
    """`qmesh mesh -o x.msh` for one constant Q, stderr no terminal: neither the fields nor the
    media, the FEM adapters, MODFLOW's writer nor xml's quoting (urllib, http) are imported."""
    import subprocess
    import sys
    code = ("import sys, qmesh.cli; "
            f"code = qmesh.cli.main(['mesh', '--target-vertices', '150', '-o', {str(tmp_path / 'x.msh')!r}]); "
            "print(' '.join(sorted(sys.modules)))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    loaded = set(out.stdout.split())
    assert "qmesh.io.gmsh22" in loaded and "qmesh.mesher.loop" in loaded
    for name in ("qmesh.fields", "qmesh.media", "qmesh.io.adapters", "qmesh.io.modflow6", "xml.sax.saxutils",
                 "urllib.request", "qmesh.io.vtu_raw"):
        assert name not in loaded, name


@given(st.lists(st.integers(-2**40, 2**40), max_size=60) | st.lists(st.integers(0, 9), max_size=200))
@settings(max_examples=200, deadline=None)
def test_distinct_tags_are_numpy_unique(values):
    a = np.array(values, dtype=np.int64)
    got = boundary.distinct(a)
    np.testing.assert_array_equal(got, np.unique(a))
    assert got.dtype == np.unique(a).dtype
