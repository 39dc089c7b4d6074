"""The viewer at large N and on media: readable views, every message, refusals that stop nothing.

Off-screen scenes and the session without a browser; the page itself in test_view_browser_large.
"""

import re
import warnings

import numpy as np
from scipy.spatial import cKDTree
import pytest

import qmesh
from qmesh.errors import QmeshWarning
from qmesh_view import draw, legend, scene
from qmesh_view.app import convergence_chart
from qmesh_view.controller import _integer
from qmesh_view.session import Session


@pytest.fixture(scope="module")
def step_1e4():
    return next(qmesh.iterate(qmesh.Disk(64), qmesh.Anisotropy.constant([[0.1, 0], [0, 10]]),
                              target_vertices=10_000, seed=0))


def _dark_share(image):
    h, w = image.shape[:2]
    inner = image[h // 3: 2 * h // 3, w // 3: 2 * w // 3].astype(int)
    return float((inner.max(axis=2) < 60).mean())


def test_q_sign_edges_leave_the_quality_view_readable_at_1e4(step_1e4):
    Q = qmesh.Anisotropy.constant([[0.1, 0], [0, 10]])
    views = draw.ViewSet(scalar_bar=False)
    try:
        views.draw(step_1e4, Q, q_sign_edges=True)
        image = views.images()["quality"]
        info = dict(views.legend)
    finally:
        views.close()
    assert _dark_share(image) < 0.2, _dark_share(image)         # was solid black
    assert info["quality_edges"] != "dark"
    text = legend.html("quality", info)
    assert "q_ij &lt; 0" in text or "q_ij < 0" in text
    assert "not drawn" in text or "light" in text               # says what is drawn


def test_facets_too_small_to_see_give_way_to_s_until_zoomed_in(step_1e4):
    Q = qmesh.Anisotropy.constant([[0.1, 0], [0, 10]])
    views = draw.ViewSet((260, 240), scalar_bar=False)
    try:
        views.draw(step_1e4, Q)
        lifted = views.plotters["lifted"]
        facets, surface = lifted.actors["facets"], lifted.actors["surface"]
        assert views._looks["lifted"] is None                      # edges hidden: too dense
        assert not facets.GetVisibility() and surface.GetProperty().GetOpacity() == 1.0
        assert "too small to tell apart" in legend.html("lifted", views.legend)
        assert views.order(Q) == ("mesh", "quality", "lifted")      # the changing views first
        image = views.images()["lifted"]
        assert (image.min(axis=2) < 240).mean() > 0.2               # the surface is drawn
        lifted.camera.zoom(30)
        assert views.fine_facets
        views.apply_edges(["lifted"])
        assert not views.fine_facets                                # the app re-sends the view
        assert views._looks["lifted"] is not None
        assert facets.GetVisibility() and surface.GetProperty().GetOpacity() == 0.3
        assert "facets of s_h" in legend.html("lifted", views.legend)
        assert views.order(Q) == ("lifted", "mesh", "quality")
    finally:
        views.close()


def test_markers_are_capped_and_shrink():
    idx = np.arange(50_000)
    assert len(scene.markers(idx)) == scene.MAX_MARKERS
    assert draw.marker_size(10, 9) == 9 and draw.marker_size(50_000, 9) == 3.0
    info = {"n_fixed": 64, "n_fixed_shown": 64, "n_vertices": 60_000}
    assert "inserted by the last insert (at most 2000 marked)" in legend.html("mesh", info)
    assert "at most" not in legend.html("mesh", {**info, "n_vertices": 1500})


@pytest.fixture(scope="module")
def stages_1e4():
    """The first triangulate, adjust and insert Steps of a 1e4-vertex run."""
    Q = qmesh.Anisotropy.constant([[0.1, 0], [0, 10]])
    out = {}
    for s in qmesh.iterate(qmesh.Disk(64), Q, target_vertices=10_000, seed=0):
        out.setdefault(s.stage, s)
        if len(out) == 3:
            return out
    raise AssertionError(f"the run had only the stages {sorted(out)}")


def test_the_mesh_legend_reads_the_same_at_every_stage(stages_1e4):
    """Its text sets the height of the legend row, and so of the three pictures: a line more
    at one stage than at the next resized them (and re-rendered them) at every Step."""
    Q = qmesh.Anisotropy.constant([[0.1, 0], [0, 10]])
    views = draw.ViewSet(scalar_bar=False)
    try:
        texts, changes = set(), set()
        for step in stages_1e4.values():
            views.draw(step, Q)
            text = legend.html("mesh", views.legend)
            change = re.search(r"<span class='legend-change'[^>]*>([^<]*)</span>", text)
            changes.add(change.group(1))     # what the stage changed: its own line, one line
            texts.add(text.replace(change.group(0), ""))
    finally:
        views.close()
    assert len(texts) == 1 and len(changes) == len(stages_1e4)
    assert "(at most 2000 drawn: the longest in each cell of a grid)" in texts.pop()


def test_moves_at_1e4_are_drawn_one_per_cell_and_cover_the_domain(stages_1e4):
    adjust = stages_1e4["adjust"]
    P = adjust.mesh.points
    D = np.asarray(adjust.moved)[:len(P)]
    length = np.hypot(D[:, 0], D[:, 1])
    view = scene.projected(adjust)
    shown = view.arrows.n_cells // 3
    assert view.n_moved == np.count_nonzero(length > 0) > 2 * scene.MAX_MARKERS
    assert 0.5 * scene.MAX_MARKERS < shown <= scene.MAX_MARKERS
    tips = view.arrows.points[shown:2 * shown, :2]
    drawn = cKDTree(P).query(tips)[1]
    np.testing.assert_array_equal(P[drawn], tips)                      # each at a vertex,
    np.testing.assert_allclose(view.arrows.points[:shown, :2], P[drawn] - D[drawn])   # its move
    assert np.argmax(length) in drawn                                  # the longest is drawn
    cell = np.ptp(P, axis=0).max() / np.sqrt(scene.MAX_MARKERS)
    assert cKDTree(tips).query(P)[0].max() < 2 * np.sqrt(2) * cell   # none far from one


def test_exponent_integers_are_accepted():
    assert _integer("t", "2e7") == 20_000_000 and _integer("t", "1.5e4") == 15_000
    for bad in ("2.5", "1e-3", "nan", "abc", "1e400"):
        with pytest.raises(qmesh.QmeshError):
            _integer("t", bad)


def test_a_refused_submit_stops_no_run_and_is_not_kept():
    s = Session()
    out = s.submit("target_vertices", "abc")
    assert out is not None and out.kind == "refused" and "integer" in out.message
    assert not s.has_pending() and not s._stop.is_set()
    assert s.messages[0] == out.message
    out = s.submit("target_vertices", 2_000_000_000)            # over the memory budget
    assert out is not None and "GiB" in out.message and not s._stop.is_set()
    assert s.submit("target_vertices", 300) is None and s._stop.is_set()
    assert s.take_pending() == {"target_vertices": 300}


def test_a_medium_warns_on_the_message_row_with_the_legend_names():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        s = Session(domain="layered", target_vertices=300)
    assert not [w for w in caught if issubclass(w.category, QmeshWarning)]
    names = {r["tag"]: r["name"] for r in s.regions}
    assert s.named("warning: region 3: too thin") == f"warning: region 3 ({names[3]}): too thin"
    assert s.named("region 3 (x) stays") == "region 3 (x) stays"


def test_a_medium_lifted_relative_to_each_regions_plane():
    s = Session(domain="layered", target_vertices=300)
    view = scene.lifted(s.current, s.anisotropy)
    z = view.facets.points[:, 2]
    regions = view.facets.cell_data["region"]
    faces = view.facets.faces.reshape(-1, 4)[:, 1:]
    for tag in np.unique(regions):
        zr = z[np.unique(faces[regions == tag])]
        assert zr.min() == pytest.approx(0.0, abs=1e-12) and zr.max() > 0


def test_a_mediums_energy_chart_follows_one_face():
    series = {"iteration": [0, 1, 0, 1, 1], "face": [0, 0, 1, 1, None],
              "energy": [1.0, 0.9, 5.0, 4.0, 4.0], "kappa2": [1, 2, 3, 4, 4],
              "n_vertices": [10, 12, 30, 31, 31]}
    chart = convergence_chart(series)
    assert chart["chart_energy"] == pytest.approx(np.log10([5.0, 4.0]))
    assert chart["chart_labels"]["chart_energy"].startswith("face 2")
    assert chart["chart_n"] == [10, 12, 30, 31, 31]
