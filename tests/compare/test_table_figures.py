"""run_table end to end on small VB, the adapted rows, the figures and the optional peers."""

from __future__ import annotations

import csv

import numpy as np
import pytest

import qmesh
from qmesh.compare import chapter, figures, peers, table

VB_SMALL = [32, 45, 64]


@pytest.fixture(scope="module")
def small_table(tmp_path_factory):
    out = tmp_path_factory.mktemp("table")
    text = table.run_table(vb=VB_SMALL, out=str(out))
    return out, text


def test_adapted_rows_are_q_delaunay_and_on_target(small_table):
    out, _ = small_table
    with open(out / "table.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["mesher"] == "qmesh"]
    assert sorted(int(r["vb"]) for r in rows) == VB_SMALL
    for r in rows:
        assert float(r["q_nonnegative_fraction"]) == 1.0          # every interior q_ij ≥ 0
        target = chapter.adapted_target(int(r["vb"]))
        assert int(r["target"]) == target
        assert abs(int(r["n_vertices"]) / target - 1) <= 0.10


def test_csv_parses_and_holds_every_vb_with_ratios(small_table):
    out, _ = small_table
    with open(out / "table.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert {(int(r["vb"]), r["mesher"]) for r in rows} == {
        (v, m) for v in VB_SMALL for m in ("isotropic", "qmesh")}
    for r in rows:
        for q in chapter.QUANTITIES:
            assert float(r[f"ratio_{q}"]) == pytest.approx(float(r[q]) / float(r[f"chapter_{q}"]))
        kind = "isotropic" if r["mesher"] == "isotropic" else "adapted"
        assert float(r["chapter_kappa2"]) == chapter.row(int(r["vb"]), kind)["kappa2"]


def test_markdown_is_written_and_returned(small_table):
    out, text = small_table
    assert (out / "table.md").read_text() == text
    assert "√2" in text and "Table 2.2" in text and "Table 2.3" in text
    for v in VB_SMALL:
        assert f"| {v} | qmesh |" in text and f"| {v} | isotropic |" in text


def test_every_figure_is_a_nonempty_png(small_table):
    out, _ = small_table
    for name in figures.FIGURES:
        data = (out / name).read_bytes()
        assert len(data) > 5000 and data[:8] == b"\x89PNG\r\n\x1a\n"


def test_figures_redraw_from_the_csv(small_table, tmp_path):
    out, _ = small_table
    figures.main([str(out / "table.csv"), str(tmp_path)])
    assert all((tmp_path / name).stat().st_size > 5000 for name in figures.FIGURES)


def test_slope_recovers_a_power_law():
    x = np.array([10.0, 20.0, 80.0])
    assert figures.slope(x, 3 * x ** -1.5) == pytest.approx(-1.5)
    assert figures.slope([5.0, 5.0], [1.0, 2.0]) is None


def test_bad_vb_is_refused(tmp_path):
    for bad in ([], [2], ["x"]):
        with pytest.raises(qmesh.QmeshError):
            table.run_table(vb=bad, out=str(tmp_path))


@pytest.mark.parametrize("peer", peers.PEERS)
def test_peer_reaches_the_target_and_keeps_the_vb_gon(peer, chapter_anisotropy):
    reason = peers.available()[peer]
    if reason:
        pytest.skip(f"optional peer not installed: {reason}")
    pm = peers.peer_mesh(peer, qmesh.Disk(32), chapter_anisotropy, 101)
    m = pm.mesh
    assert abs(m.n_vertices / 101 - 1) <= 0.10
    assert m.boundary.sum() == 32 and m.fixed.sum() == 32
    np.testing.assert_allclose(np.sort(m.points[m.fixed], axis=0),
                               np.sort(qmesh.Disk(32).seeds, axis=0), atol=1e-9)
    rep = qmesh.measure.report(m, chapter_anisotropy)
    assert rep["inverted_triangles"] == 0
    assert rep["mean_quality"] > 0.5        # anisotropic in the metric's sense, not isotropic
