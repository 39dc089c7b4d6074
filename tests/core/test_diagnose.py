"""qmesh.diagnose: a domain thinner than two elements in the metric is reported, with the N that fixes it."""

import json
import re
import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.spatial import Delaunay

import qmesh
from qmesh.mesher import diagnose
from qmesh.cli import main

CHAPTER = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
NEEDLE = qmesh.Anisotropy.principal(1, 10000, 20)          # the issue's `--principal 1 10000 20`
STRIP = qmesh.Polygon(np.array([[0, 0], [10, 0], [10, 0.1], [0, 0.1]]))   # 10 × 0.1


def suggested_n(message: str) -> int:
    return int(re.search(r"about (\d+) vertices", message).group(1))


def test_needle_domain_warns_and_the_suggested_n_works():
    with pytest.warns(qmesh.QmeshWarning, match="no interior vertex") as record:
        m = qmesh.mesh(qmesh.Disk(64), NEEDLE)
    assert (~m.boundary).sum() == 0
    n = suggested_n(str(record[0].message))
    assert 200 < n < 2000
    with warnings.catch_warnings():
        warnings.simplefilter("error", qmesh.QmeshWarning)
        better = qmesh.mesh(qmesh.Disk(64), NEEDLE, target_vertices=n)
    assert (~better.boundary).sum() > 0
    assert qmesh.measure.quality(better, NEEDLE).min() > 0.3


def never_silent(domain, anisotropy, **options) -> str:
    """The mesher may refuse a too-thin domain (QmeshError) or mesh it and warn; the message."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            qmesh.mesh(domain, anisotropy, **options)
        except qmesh.QmeshError as e:
            assert "thinner" in str(e)
            return str(e)
    said = [str(w.message) for w in caught if issubclass(w.category, qmesh.QmeshWarning)]
    assert said, "a too-thin domain meshed without a word"
    return said[0]


def test_thin_strip_with_the_defaults_is_never_silent():
    message = never_silent(STRIP, CHAPTER)
    assert "thinner" in message or suggested_n(message) > 1000


def test_two_triangles_on_the_strip_give_a_large_n():
    """The strip as two triangles (no mesher): 0.05 elements wide; thousands of vertices needed."""
    m = qmesh.Mesh(STRIP.seeds, np.array([[0, 1, 2], [0, 2, 3]]))
    message = diagnose.thin_domain(m, CHAPTER)
    assert "no interior vertex" in message
    assert 1000 < suggested_n(message) < 20000


def test_a_wide_domain_with_only_boundary_vertices_names_the_target():
    """Disk(64) triangulated from its seeds alone (Q = I): about 7 elements wide, so the advice
    is the N whose interior matches the boundary's spacing (≈ 410), not a thinner-domain one."""
    identity = qmesh.Anisotropy.constant(np.eye(2))
    seeds = qmesh.Disk(64).seeds
    m = qmesh.Mesh(seeds, Delaunay(seeds).simplices)
    message = diagnose.thin_domain(m, identity)
    assert "lies on the boundary" in message and "take the whole target" in message
    n = suggested_n(message)
    assert 300 < n < 550
    better = qmesh.mesh(qmesh.Disk(64), identity, target_vertices=n)
    assert diagnose.thin_domain(better, identity) is None
    assert qmesh.measure.quality(better, identity).min() > 0.5


def test_the_chapters_case_does_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error", qmesh.QmeshWarning)
        m = qmesh.mesh(qmesh.Disk(64), CHAPTER, target_vertices=212)
    assert diagnose.thin_domain(m, CHAPTER) is None


def test_varying_s_is_diagnosed_too():
    """A 3 × 0.02 strip for s = exp(x) + y²: refused, or slivers across the middle, or no
    interior vertex, but never silent."""
    from cases import exp_plus_y2
    A = exp_plus_y2()
    strip = qmesh.Polygon(np.array([[0, 0], [3, 0], [3, 0.02], [0, 0.02]]))
    for options in ({}, {"size": 5.0}):
        message = never_silent(strip, A, **options)
        assert re.search("thinner|no interior vertex|minimum metric quality 0.0", message)
    with warnings.catch_warnings():
        warnings.simplefilter("error", qmesh.QmeshWarning)
        qmesh.mesh(qmesh.Polygon(np.array([[0, 0], [1, 0], [1, 1], [0, 1]])), A, target_vertices=60)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(a=st.floats(0.05, 20), b=st.floats(0.05, 20), k1=st.floats(0.01, 100), k2=st.floats(0.01, 100))
def test_metric_width_of_an_axis_aligned_rectangle(a, b, k1, k2):
    """Width of the a × b rectangle in the metric diag(k1, k2): min(a√k1, b√k2)."""
    P = np.array([[0, 0], [a, 0], [a, b], [0, b]], float)
    H = np.diag([k1, k2])
    sa, sb = a * np.sqrt(k1), b * np.sqrt(k2)
    w = diagnose.metric_width(P, H, sa * sb, 2 * (sa + sb))
    assert w == pytest.approx(min(sa, sb), rel=1e-9)


def test_cli_prints_one_warning_line_and_na(tmp_path, capsys):
    code = main(["mesh", "--principal", "1", "10000", "20", "-o", str(tmp_path / "x.vtu")])
    out, err = capsys.readouterr()
    assert code == 0
    assert "q_ij>=0: interior n/a" in out
    line, = err.splitlines()
    assert line.startswith("qmesh: warning: the domain is") and "vertices" in line
    code = main(["mesh", "--principal", "1", "10000", "20", "--json", "-o", str(tmp_path / "x.vtu")])
    out, _ = capsys.readouterr()
    assert json.loads(out)["q_nonnegative_fraction"] is None


def test_report_says_n_a_without_an_interior_vertex(tmp_path, capsys):
    main(["mesh", "--principal", "1", "10000", "20", "--quiet", "-o", str(tmp_path / "x.vtu")])
    capsys.readouterr()
    assert main(["report", str(tmp_path / "x.vtu"), "--principal", "1", "10000", "20"]) == 0
    rows = dict(line.split() for line in capsys.readouterr().out.splitlines()[1:])
    assert rows["n_interior"] == "0"
    assert rows["q_nonnegative_fraction"] == "n/a" and rows["kappa2"] == "n/a"


def test_thin_ring_warns_and_the_suggested_n_works():
    """A ring 0.05 wide (Q = I): the hull sees a disk, the area/perimeter width the ring."""
    identity = qmesh.Anisotropy.constant(np.eye(2))
    ring = qmesh.Domain(qmesh.Disk(64), holes=[qmesh.Disk(64, radius=0.95)])
    with pytest.warns(qmesh.QmeshWarning, match="no interior vertex") as record:
        qmesh.mesh(ring, identity)
    n = suggested_n(str(record[0].message))
    with warnings.catch_warnings():
        warnings.simplefilter("error", qmesh.QmeshWarning)
        better = qmesh.mesh(ring, identity, target_vertices=n)
    assert (~better.boundary).sum() > 0
    assert qmesh.measure.quality(better, identity).min() > 0.3


@settings(max_examples=30, deadline=None, derandomize=True)
@given(n=st.integers(3, 200), k1=st.floats(-2, 2), ratio=st.floats(0, 3), angle=st.floats(0, 180))
def test_a_mesh_without_interior_vertex_is_always_reported_with_a_larger_n(n, k1, ratio, angle):
    """Any seeds-only mesh of a regular polygon, any SPD Q: the message never stays silent and
    always asks for more vertices than the mesh has (thin or wide in the metric)."""
    A = qmesh.Anisotropy.principal(10 ** k1, 10 ** (k1 + ratio), angle)
    seeds = qmesh.Disk(n).seeds
    m = qmesh.Mesh(seeds, Delaunay(seeds).simplices)
    message = diagnose.thin_domain(m, A)
    assert message is not None and "no interior vertex" in message
    assert suggested_n(message) > n
