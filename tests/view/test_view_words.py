"""The viewer explains itself: titles in words with the chapter's equation numbers in their
tooltips, a legend line saying what the last stage changed, and no colour bar where the colour
says nothing (the rotating field's larger eigenvalue is 1 everywhere)."""

import re

import numpy as np
import pytest

from qmesh_view import app, legend, scene
from qmesh_view.problem import raster_field, rotating_field
from qmesh_view.session import Session
from qmesh_view.stage_change import what_changed

EQUATION = re.compile(r"\(\d\.\d+\)|Algorithm \d\.\d")


def test_titles_are_words_and_their_tooltips_carry_the_equation_numbers():
    for info in ({}, {"field": True}):
        shown = legend.state(info)
        for name in ("lifted", "mesh", "quality"):
            assert not EQUATION.search(shown[f"title_{name}"]), shown[f"title_{name}"]
            assert shown[f"tip_{name}"] and shown[f"tip_{name}"] != shown[f"title_{name}"]
    assert "(2.94)" in legend.state({})["tip_quality"]
    assert not EQUATION.search(app.TITLE) and EQUATION.search(app.TITLE_TIP)
    titles = re.findall(r"\btitle: '([^']*)', value", app.COLOUR_BY)
    assert titles == ["metric quality", "metric area", "maximum principle: u_h"]
    assert "(2.94)" in app.COLOUR_BY_TIP                # in the select's tooltip
    assert all(not EQUATION.search(label) for _, label, _ in app.CHART_SERIES)
    assert "(2.80)" in app.CHART_TIPS["chart_energy"]
    assert 'title="' in legend.title_html("quality", {})     # the widget's tooltip too


@pytest.fixture(scope="module")
def chapter():
    s = Session()
    s.controller.finish()
    return s.history


def test_the_legend_says_what_each_stage_changed(chapter):
    kinds = set()
    for before, step in zip(chapter, chapter[1:]):
        line = what_changed(step)
        assert line.startswith(step.stage)
        kinds.add(step.stage)
        if step.stage == "adjust":
            moved = int((np.linalg.norm(step.mesh.points - before.mesh.points, axis=1) > 0).sum())
            assert f"{moved} vertices moved" in line or (moved == 0 and "no vertex" in line)
        if step.stage == "insert":
            added = step.mesh.n_vertices - before.mesh.n_vertices
            assert (f"+{added} points" in line) if added else "none needed" in line
    assert kinds == {"adjust", "insert", "triangulate"}
    assert what_changed(chapter[0]) == f"first triangulation: {chapter[0].mesh.n_vertices} vertices"
    info = {"change": what_changed(chapter[1])}
    assert what_changed(chapter[1]) in legend.html("mesh", info)


@pytest.mark.parametrize("make, uniform", [(rotating_field, True), (raster_field, False)])
def test_a_field_whose_colour_is_one_value_gets_no_colour_bar(make, uniform):
    field = make()
    s = Session(domain="rotating" if uniform else "raster")
    view = scene.ellipses(s.current, field, domain=s.domain)
    values = view.ellipses.cell_data["log10_k_max"]
    assert (np.ptp(values) < 1e-9) == uniform
    shown = legend.html("lifted", {"field": True, "field_clim": view.clim,
                                   "field_uniform": view.uniform})
    assert ("legend-colour-bar" in shown) != uniform
    if uniform:
        assert "one colour" in shown and "is 1 everywhere" in shown


def test_the_launcher_answer_names_the_websocket_beside_the_page():
    from qmesh_view.connect import session_url
    assert session_url("/paraview/") == "ws://USE_HOST/ws"
    assert session_url("/paraview/", "/viewer/") == "ws://USE_HOST/viewer/ws"
    assert session_url("/app/paraview/") == "ws://USE_HOST/app/ws"
