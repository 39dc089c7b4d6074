"""Malformed and hostile files (truncated, deeply nested, huge numbers, huge digit strings, NaN,
wrong cells) give a valid result or one QmeshError: nothing else, for the polygon and mesh readers."""

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import qmesh
from qmesh import io
from qmesh.domain.polygon_file import domain_from_text
from qmesh.errors import QmeshError, QmeshWarning

TOKENS = ["[" * 3000, "{" * 3000, "9" * 5000, "9" * 400, "1e309", "-1e400", "NaN", "Infinity", "nan", ",", "\n",
          '"', "]", "}", "\x00", "1O", "é", "-", "0", " ", "$EndNodes\n", "<", ">", "</Piece>", "triangle", "line",
          "Triangles\n", "2 2 0 1 1 2 3\n", "$Elements\n", "99999999999"]

CSV = "x,y\n0,0\n1,0\n1,1\n0,1\n\n0.2,0.2\n0.4,0.2\n0.3,0.4\n"
GEOJSON = ('{"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": '
           '[[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]], [[0.2, 0.2], [0.4, 0.2], [0.3, 0.4], [0.2, 0.2]]]}}')


@st.composite
def mutated(draw, text):
    """`text` truncated, or with hostile tokens inserted or written over a span, a few times."""
    for _ in range(draw(st.integers(1, 3))):
        i = draw(st.integers(0, len(text)))
        op = draw(st.sampled_from(["truncate", "insert", "replace"]))
        if op == "truncate":
            text = text[:i]
        else:
            token = draw(st.sampled_from(TOKENS))
            j = i + draw(st.integers(0, 8)) if op == "replace" else i
            text = text[:i] + token + text[j:]
    return text


@settings(max_examples=150, deadline=None, derandomize=True)
@given(data=st.data())
def test_polygon_reader_gives_a_domain_or_one_clean_error(data):
    name, base = data.draw(st.sampled_from([("p.csv", CSV), ("p.geojson", GEOJSON)]))
    text = data.draw(mutated(base))
    try:
        domain = domain_from_text(text, name)
    except QmeshError as e:
        assert str(e) and "\n" not in str(e)[:500]
        return
    assert isinstance(domain, qmesh.Domain) and np.all(np.isfinite(domain.seeds))


FORMATS = [".msh", ".vtu", ".vtk", ".mesh", ".obj", ".xdmf", "_facets.xdmf"]   # the last: .xdmf's facet tags


@pytest.fixture(scope="module")
def originals(tmp_path_factory):
    """Each format's bytes for a small tagged mesh with a stored conductivity."""
    folder = tmp_path_factory.mktemp("originals")
    P = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]])
    Q = np.array([[[2.0, 0.5], [0.5, 1.0]]] * 4)   # element means: Q11 Q12 Q22 in every format that keeps them
    mesh = qmesh.Mesh(P, [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]], tag_names={1: "wall"}, conductivity=Q)
    out = {}
    for ext in FORMATS[:-1]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", QmeshWarning)   # .mesh and .obj drop the means
            io.write(folder / f"m{ext}", mesh, anisotropy=qmesh.Anisotropy.principal(1, 5, 10))
        out[ext] = (folder / f"m{ext}").read_bytes()
    out["_facets.xdmf"] = (folder / "m_facets.xdmf").read_bytes()
    out["h5"], out["facets_h5"] = (folder / "m.h5").read_bytes(), (folder / "m_facets.h5").read_bytes()
    return out


@settings(max_examples=150, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_mesh_reader_gives_a_mesh_or_one_clean_error(tmp_path_factory, originals, data):
    ext = data.draw(st.sampled_from(FORMATS))
    base = originals[ext].decode("latin-1")
    folder = tmp_path_factory.mktemp("mutated")
    path = folder / f"m{ext}"
    path.write_bytes(data.draw(mutated(base)).encode("latin-1", "replace"))
    (folder / "m.h5").write_bytes(originals["h5"])
    (folder / "m_facets.h5").write_bytes(originals["facets_h5"])
    if ext.endswith(".xdmf"):   # the mesh with its facet tags, one of the two mutated
        for name in (".xdmf", "_facets.xdmf"):
            if name != ext:
                (folder / f"m{name}").write_bytes(originals[name])
        path = folder / "m.xdmf"
    for call in (io.read, io.read_anisotropy):
        try:
            result = call(path)
        except QmeshError as e:
            assert str(e)
            continue
        if call is io.read:
            assert isinstance(result, qmesh.Mesh) and np.all(np.isfinite(result.points))


def test_deeply_nested_metadata_is_one_error(tmp_path, originals):
    path = tmp_path / "m.vtu"
    path.write_bytes(originals[".vtu"].replace(b"qmesh='{", b"qmesh='" + b"[" * 100000 + b"{", 1))
    assert path.read_bytes() != originals[".vtu"]
    with pytest.raises(QmeshError, match="unreadable qmesh metadata"):
        io.read(path)


def test_an_hdf5_dataset_larger_than_its_file_is_refused_unread(tmp_path, originals):
    """A chunked dataset that declares 3e9 values in a file of a few kB: refused from its shape."""
    h5py = pytest.importorskip("h5py")
    for name in (".xdmf", "_facets.xdmf"):
        (tmp_path / f"m{name}").write_bytes(originals[name])
    (tmp_path / "m_facets.h5").write_bytes(originals["facets_h5"])
    (tmp_path / "m.h5").write_bytes(originals["h5"])
    with h5py.File(tmp_path / "m.h5", "a") as f:
        del f["/Mesh/mesh/topology"]
        f.create_dataset("/Mesh/mesh/topology", shape=(10**9, 3), dtype="int64", chunks=(1024, 3))
    with pytest.raises(QmeshError, match="declares 3000000000 values"):
        io.read(tmp_path / "m.xdmf")
