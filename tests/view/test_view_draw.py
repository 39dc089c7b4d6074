"""qmesh_view.draw and legend: redrawing reuses actors without changing a pixel, edges follow
their on-screen density, every colouring has a legend."""

import numpy as np
import pytest

import pyvista as pv
from headless_browser import drawn

from qmesh.errors import QmeshError
from qmesh_view import draw, legend

SIZE = (240, 240)


def test_a_reused_viewset_draws_exactly_what_a_fresh_one_draws(chapter_run):
    c = chapter_run
    views = draw.ViewSet(SIZE)
    try:
        for options in ({}, {"colour_by": "metric_area", "q_sign_edges": True}, {"edges": "off"}):
            for i in (0, 5, len(c.history) - 1):
                views.draw(c.history[i], c.anisotropy, domain=c.domain, **options)
                reused = views.images()
                fresh = draw.render_views(c.history[i], c.anisotropy, window_size=SIZE,
                                          domain=c.domain, **options)
                for name in draw.VIEWS:
                    assert np.array_equal(reused[name], fresh[name]), (i, options, name)
    finally:
        views.close()


def test_edge_look_by_pixels_and_mode():
    assert draw.edge_look("auto", 10.0) == "dark"
    assert draw.edge_look("auto", 4.0) == "light"
    assert draw.edge_look("auto", 1.0) is None
    assert draw.edge_look("on", 0.1) == "dark" and draw.edge_look("off", 100.0) is None
    with pytest.raises(QmeshError, match="edges"):
        draw.edge_look("some", 1.0)


def test_auto_edges_hide_when_crowded_and_come_back_when_zoomed(chapter_run):
    c = chapter_run
    step = c.history[-1]
    views = draw.ViewSet((60, 60))                 # a tiny window: every edge is a pixel or less
    try:
        views.draw(step, c.anisotropy, domain=c.domain)
        looks = views.apply_edges()
        assert looks["mesh"] is None and looks["quality"] is None
        assert not views.plotters["mesh"].actors["mesh"].GetProperty().GetEdgeVisibility()
        views.plotters["mesh"].camera.zoom(12.0)    # shared by the mesh and quality views
        looks = views.apply_edges()
        assert looks["mesh"] == looks["quality"] == "dark"
        assert views.plotters["mesh"].actors["mesh"].GetProperty().GetEdgeVisibility()
        views.draw(step, c.anisotropy, domain=c.domain, edges="off")
        assert not views.plotters["mesh"].actors["mesh"].GetProperty().GetEdgeVisibility()
    finally:
        views.close()


def test_typical_edge_is_a_short_side(chapter_run):
    step = chapter_run.history[-1]
    P, T = step.mesh.points, step.mesh.triangles
    sides = np.concatenate([np.linalg.norm(P[T[:, k]] - P[T[:, (k + 1) % 3]], axis=1)
                            for k in range(3)])
    h = draw.typical_edge(step)
    assert sides.min() <= h <= np.median(sides)
    assert np.mean(sides <= h) == pytest.approx(0.25, abs=0.01)


def test_every_colouring_has_a_legend():
    q = legend.html("quality", {"title": "quality", "clim": (0.0, 1.0)})
    assert "quality: 0" in q and "linear-gradient" in q and " 1</span>" in q
    assert all(c in q for c in legend.VIRIDIS)
    area = legend.html("quality", {"title": "metric area", "clim": (0.00047, 0.025),
                                   "q_sign_edges": True, "n_negative": 3})
    assert "metric area: 0.00047" in area and "0.025" in area
    assert "q_ij ≥ 0" in area and "q_ij &lt; 0: 3 edges" in area and "boundary edge" in area
    for _, value, colour, _ in draw.Q_SIGN_LINES:
        assert (colour in area) == (value != 2)     # interface edges: media only (test_view_media)
    assert "q_ij" not in q
    assert draw.FIXED in legend.html("mesh", {}) and draw.ADDED in legend.html("mesh", {})
    assert draw.FACET in legend.html("lifted", {})
    with pytest.raises(ValueError):
        legend.html("other", {})


def test_q_sign_colours_stand_out_on_every_quality_colour():
    """Green q_ij ≥ 0 lines vanished on viridis: every interior sign colour keeps an
    RGB distance of at least 90 from every colour of the quality map."""
    def rgb(h):
        return np.array([int(h[i:i + 2], 16) for i in (1, 3, 5)])
    for _, value, colour, _ in draw.Q_SIGN_LINES:
        if value != 0:
            assert min(np.linalg.norm(rgb(colour) - rgb(c)) for c in legend.VIRIDIS) > 90, colour


def test_a_crowded_mesh_is_coloured_by_area_with_a_sample_of_outlines():
    from qmesh_view.session import Session
    s = Session(vb=512, target_vertices=10_000)
    views = draw.ViewSet((300, 280), scalar_bar=False)
    try:
        views.draw(s.current, s.anisotropy, domain=s.domain)
        assert views.legend["crowded"] and "sample of" in legend.html("mesh", views.legend)
        for name in ("mesh", "quality"):
            assert views.plotters[name].actors["sample"].GetVisibility()
        assert views.plotters["mesh"].actors["mesh"].mapper.GetScalarVisibility()
        mesh = views.images()["mesh"].astype(float)
        inner = mesh[70:210, 75:225]
        assert inner.std(axis=(0, 1)).max() > 8.0         # not an even grey disk
        views.edges = "on"
        views.apply_edges()
        assert not views.plotters["mesh"].actors["sample"].GetVisibility()
        assert not views.plotters["mesh"].actors["mesh"].mapper.GetScalarVisibility()
    finally:
        views.close()


def _near(image, colour, tol=25):
    """Pixels of `image` near `colour`, left of VTK's scalar bar (which shows them all)."""
    rgb = np.asarray(image)[:, : int(0.8 * image.shape[1]), :3].astype(int)
    return int(np.sum(np.abs(rgb - np.array(pv.Color(colour).int_rgb)).max(axis=-1) < tol))


def test_the_maximum_principle_view_draws_the_markers_and_goes_back(steps, chapter_run):
    """On the chapter's case qmesh's mesh shows no vertex outside [0, 1], the isotropic mesh of
    the same N shows its markers; back to the quality, the markers are gone."""
    step, A = steps["final"], chapter_run.anisotropy
    views = draw.ViewSet(SIZE)
    try:
        views.draw(step, A, colour_by="solution", domain=chapter_run.domain)
        own = views.images()["quality"]
        assert drawn(own)
        assert all(_near(own, c) == 0 for c in (*draw.ABOVE, *draw.BELOW))
        assert views.legend["solution"]["mesh"]["n_outside"] == 0
        assert "0 vertices outside [0, 1]" in legend.html("quality", views.legend)
        views.draw(step, A, colour_by="solution", isotropic=True, domain=chapter_run.domain)
        iso = views.images()["quality"]
        n = views.legend["solution"]["isotropic"]["n_outside"]
        assert n > 0 and f"{n} vertices outside [0, 1]" in legend.html("quality", views.legend)
        assert _near(iso, draw.ABOVE[0]) + _near(iso, draw.BELOW[0]) > 0
        assert legend.title("quality", views.legend).endswith("isotropic mesh of the same N")
        views.draw(step, A, colour_by="quality", domain=chapter_run.domain)
        assert "below" not in views.plotters["quality"].actors
        assert "above" not in views.plotters["quality"].actors
        assert legend.title("quality", views.legend) == legend.VIEW_TITLES["quality"]
    finally:
        views.close()
