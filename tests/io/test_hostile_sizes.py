"""Small files that declare far more than their bytes (a node numbered 1e9, a zlib stream that
inflates a hundredfold past its file, an HDF5 dataset of 1e8 × 3 values in a few kB) are refused
before the reader allocates what they declare: one QmeshError naming the file and what it
declares, with the reading's peak traced memory (NumPy's arrays, zlib's output) bounded."""

import base64
import tracemalloc
import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh import io
from qmesh.io import sizes

PEAK = 48 * 2**20        # what refusing any of these files may allocate (the allowance's floor is 64 MiB)


def refused(path, *words):
    """io.read(path) raises QmeshError naming the file and `words`; the peak traced memory of
    the attempt stays below PEAK."""
    tracemalloc.start()
    try:
        with pytest.raises(qmesh.QmeshError) as e:
            io.read(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    text = str(e.value)
    assert str(path) in text and "declares" in text, text
    for w in words:
        assert w in text, text
    assert peak < PEAK, f"{peak / 2**20:.0f} MiB traced while refusing {path}"
    return text


# --------------------------------------------------------------------------- gmsh

def gmsh22(node: int, count: int | None = None) -> str:
    nodes = [(1, 0, 0), (2, 1, 0), (node, 0, 1)]
    return ("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n"
            f"{len(nodes) if count is None else count}\n"
            + "".join(f"{i} {x} {y} 0\n" for i, x, y in nodes)
            + f"$EndNodes\n$Elements\n1\n1 2 2 0 0 1 2 {node}\n$EndElements\n")


@settings(max_examples=12, deadline=None, derandomize=True)
@given(node=st.integers(10**8, 2**31 - 2))
def test_a_gmsh_node_numbered_past_the_allowance_is_refused_unallocated(tmp_path_factory, node):
    path = tmp_path_factory.mktemp("gmsh") / "m.msh"
    path.write_text(gmsh22(node))
    refused(path, f"a node numbered {node}")


def test_the_issues_gmsh_file_of_one_node_numbered_1e9(tmp_path):
    path = tmp_path / "m.msh"
    path.write_text(gmsh22(10**9) + "$Comments\n" + "x" * 1200 + "\n$EndComments\n")   # 1.5 kB
    assert path.stat().st_size < 1600
    refused(path, "a node numbered 1000000000")


@pytest.mark.parametrize("count", [10**6, 10**9, 10**15])
def test_a_gmsh_node_count_beyond_the_file_is_refused(tmp_path, count):
    path = tmp_path / "m.msh"
    path.write_text(gmsh22(3, count))
    refused(path, f"{count} nodes")


def test_a_gmsh_41_largest_node_tag_is_refused(tmp_path):
    path = tmp_path / "m.msh"
    path.write_text("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 3 1 1000000000\n2 1 0 3\n1\n2\n1000000000\n"
                    "0 0 0\n1 0 0\n0 1 0\n$EndNodes\n")
    refused(path, "a node numbered 1000000000")


def test_sparse_but_modest_node_numbers_still_read(tmp_path):
    path = tmp_path / "m.msh"
    path.write_text(gmsh22(10**6))                     # a 4-8 MB index: within the allowance
    mesh = io.read(path)
    assert mesh.n_vertices == 3 and mesh.n_triangles == 1


# --------------------------------------------------------------------------- .vtu

def _b64(a: bytes) -> str:
    return base64.b64encode(a).decode()


def compressed(raw_size: int, declared: int | None = None, chunk: bytes = b"\0" * 2**20) -> str:
    """One zlib block of `raw_size` zero bytes, with a UInt64 header saying `declared` bytes."""
    c = zlib.compressobj(9)
    out = []
    for start in range(0, raw_size, len(chunk)):
        out.append(c.compress(chunk[:min(len(chunk), raw_size - start)]))
    out.append(c.flush())
    body = b"".join(out)
    n = raw_size if declared is None else declared
    return _b64(np.array([1, n, n, len(body)], "<u8").tobytes()) + _b64(body)


def small(a: np.ndarray) -> str:
    body = zlib.compress(a.tobytes())
    return _b64(np.array([1, a.nbytes, a.nbytes, len(body)], "<u8").tobytes()) + _b64(body)


def vtu(points: str) -> str:
    return f"""<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64" compressor="vtkZLibDataCompressor">
<UnstructuredGrid><Piece NumberOfPoints="3" NumberOfCells="1">
<Points><DataArray type="Float64" Name="Points" NumberOfComponents="3" format="binary">{points}</DataArray></Points>
<Cells>
<DataArray type="Int64" Name="connectivity" format="binary">{small(np.array([0, 1, 2], "<i8"))}</DataArray>
<DataArray type="Int64" Name="offsets" format="binary">{small(np.array([3], "<i8"))}</DataArray>
<DataArray type="UInt8" Name="types" format="binary">{small(np.array([5], "u1"))}</DataArray>
</Cells></Piece></UnstructuredGrid></VTKFile>
"""




@pytest.fixture(scope="module")
def bomb():
    """160 MiB of zeros in one zlib block: about 215 kB of text."""
    return 160 * 2**20


def test_a_vtu_whose_zlib_stream_inflates_far_past_its_file_is_refused(tmp_path, bomb):
    path = tmp_path / "m.vtu"
    path.write_text(vtu(compressed(bomb)))
    assert path.stat().st_size < 400_000
    refused(path, "'Points'", f"{bomb} bytes")


def test_a_vtu_whose_header_hides_what_its_stream_inflates_to_is_refused_while_inflating(tmp_path, bomb):
    path = tmp_path / "m.vtu"
    path.write_text(vtu(compressed(bomb, declared=72)))     # the header says 3 points
    refused(path, "'Points'", "inflates past", "header says 72 bytes")


def test_a_vtu_declaring_more_blocks_than_its_text_is_refused(tmp_path):
    path = tmp_path / "m.vtu"
    path.write_text(vtu(_b64(np.array([10**12, 8, 8], "<u8").tobytes())))
    refused(path, "1000000000000 compressed blocks")


def test_an_honest_compressed_vtu_reads(tmp_path):
    path = tmp_path / "m.vtu"
    path.write_text(vtu(small(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f8"))))
    mesh = io.read(path)
    assert mesh.n_vertices == 3 and mesh.n_triangles == 1


def test_qmeshs_own_files_read_back_within_the_allowance(tmp_path):
    mesh = qmesh.mesh(qmesh.Disk(32), qmesh.Anisotropy.principal(1, 20, 30), target_vertices=2000)
    for ext in (".vtu", ".msh", ".xdmf"):
        io.write(tmp_path / f"m{ext}", mesh)
        back = io.read(tmp_path / f"m{ext}")
        assert np.array_equal(back.points, mesh.points)


# --------------------------------------------------------------------------- .xdmf

def xdmf_file(tmp_path, shape, *, chunks=True, data_format="HDF", name="m.h5"):
    """An XDMF file of meshio's layout whose topology is an HDF5 dataset of `shape`, never written."""
    h5py = pytest.importorskip("h5py")
    with h5py.File(tmp_path / "m.h5", "w") as f:
        if chunks:                                     # declared, never written
            f.create_dataset("topology", shape=shape, dtype="int64", chunks=(1024, 3))
        else:
            f.create_dataset("topology", data=np.zeros(shape, "int64"))
        f.create_dataset("geometry", data=np.array([[0.0, 0], [1, 0], [0, 1]]))
    text = f"{name}:/topology" if data_format == "HDF" else name
    (tmp_path / "m.xdmf").write_text(f"""<?xml version="1.0"?>
<Xdmf Version="3.0"><Domain><Grid Name="Grid">
<Topology TopologyType="Triangle" NumberOfElements="{shape[0]}">
<DataItem DataType="Int" Dimensions="{shape[0]} 3" Format="{data_format}" Precision="8">{text}</DataItem></Topology>
<Geometry GeometryType="XY"><DataItem DataType="Float" Dimensions="3 2" Format="HDF" Precision="8">m.h5:/geometry</DataItem></Geometry>
</Grid></Domain></Xdmf>
""")
    return tmp_path / "m.xdmf"


def test_the_issues_xdmf_of_a_1e8_by_3_topology_is_refused_unread(tmp_path):
    path = xdmf_file(tmp_path, (10**8, 3))
    assert path.stat().st_size + (tmp_path / "m.h5").stat().st_size < 32_000
    refused(path, "'/topology'", "300000000 values")


def test_an_xdmf_dataset_over_the_budget_is_refused_naming_the_budget(tmp_path, monkeypatch):
    path = xdmf_file(tmp_path, (200_000, 3), chunks=False)     # 4.8 MB, really there
    from qmesh.mesher import budget
    monkeypatch.setattr(budget, "default_budget", lambda: 2**20)
    refused(path, "'/topology'", "(1 MiB)")


@pytest.mark.parametrize("name", ["/dev/zero", "../m.h5", "missing.bin"])
def test_an_xdmf_binary_item_must_be_a_file_beside_it(tmp_path, name):
    path = xdmf_file(tmp_path, (1, 3), chunks=False, data_format="Binary", name=name)
    with pytest.raises(qmesh.QmeshError, match="beside the .xdmf|does not exist"):
        io.read(path)


def test_the_allowance_is_the_files_bytes_times_ratio_within_the_budget(tmp_path, monkeypatch):
    path = tmp_path / "f"
    path.write_bytes(b"x" * 2**20)
    assert sizes.allowance(path) == min(sizes.RATIO * 2**20, qmesh.mesher.budget.default_budget())
    path.write_bytes(b"x")
    assert sizes.allowance(path) == sizes.FLOOR
    from qmesh.mesher import budget
    monkeypatch.setattr(budget, "default_budget", lambda: 1000)
    assert sizes.allowance(path) == 1000
