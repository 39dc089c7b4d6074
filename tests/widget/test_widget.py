"""qmesh_view.widget without a kernel: its controls are bound to the session (the session's own
behaviour is tested in tests/view/test_view_session.py)."""

import asyncio
import datetime
import io
import threading
import time

import ipywidgets
import numpy as np
import pytest
from PIL import Image

import qmesh_view
from lab_browser import drawn
from qmesh.errors import QmeshError
from qmesh_view.controller import q_matrix, status_text
from qmesh_view.widget import MainThread, choose_backend, in_jupyter_server_kernel

SIZE = (200, 180)
NOW = datetime.datetime(2026, 1, 1, tzinfo=datetime.timezone.utc)   # an upload's time stamp


@pytest.fixture
def view():
    w = qmesh_view.widget(backend="static", view_size=SIZE)
    yield w
    w.close()


def pictures(w) -> dict:
    """The PNGs the widget currently shows, decoded: name → RGB array."""
    return {name: np.asarray(Image.open(io.BytesIO(image.value)).convert("RGB"))
            for name, image in w.view_widgets.items()}


def changed(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape != b.shape or np.abs(a.astype(int) - b.astype(int)).mean() > 0.5


def test_builds_a_box_with_controls_and_three_drawn_pictures(view):
    assert isinstance(view, ipywidgets.Box)
    assert view.backend == "static"
    assert set(view.sliders) == {"k1", "k2", "angle", "vb", "target_vertices", "domain",
                                 "q_mode"}
    assert set(view.buttons) == {"step", "iterate", "run", "reset"}
    p = view.controller.params
    assert (view.sliders["k1"].value, view.sliders["k2"].value, view.sliders["vb"].value,
            view.sliders["target_vertices"].value) == (p.k1, p.k2, p.vb, p.target_vertices)
    images = pictures(view)
    assert set(images) == {"lifted", "mesh", "quality"}
    for name, image in images.items():
        assert image.shape == (SIZE[1], SIZE[0], 3), name
        assert drawn(image), name
    assert view.status.value == status_text(view.controller.status())
    assert view.status.value.startswith("iteration 0 · triangulate")
    assert (view.history.min, view.history.max, view.history.value) == (0, 0, 0)


def test_step_and_iterate_buttons_advance_the_run_and_redraw(view):
    c = view.controller
    before = pictures(view)
    n0 = c.current.stats.n_vertices
    view.buttons["step"].click()
    assert (c.index, c.current.stage, c.current.iteration) == (1, "adjust", 1)
    assert (view.history.max, view.history.value) == (1, 1)
    assert "adjust" in view.status.value
    after = pictures(view)
    assert changed(after["mesh"], before["mesh"])          # the vertices moved (and arrows show)
    view.buttons["iterate"].click()
    assert (c.current.stage, c.current.iteration) == ("triangulate", 1)
    n1 = c.current.stats.n_vertices
    assert n1 > n0                                         # the insert stage added points
    assert f"N = {n1}" in view.status.value
    assert view.history.max == view.history.value == c.index == len(c.history) - 1
    assert changed(pictures(view)["quality"], after["quality"])


def test_a_slider_change_remeshes_from_the_start_and_rerenders(view):
    c = view.controller
    view.buttons["step"].click()
    mesh0, before = c.current.mesh, pictures(view)
    view.sliders["angle"].value = 45.0
    assert c.params.angle == 45.0
    assert len(c.history) == 1 and c.index == 0 and view.history.max == 0
    np.testing.assert_allclose(c.q, q_matrix(0.1, 10.0, 45.0))
    assert "Q12 = -4.95" in view.readout.value               # (0.1 − 10)/2 at 45°
    assert c.current.mesh is not mesh0
    assert not np.array_equal(c.current.mesh.points, mesh0.points)
    after = pictures(view)
    assert all(changed(after[name], before[name]) for name in after)
    view.sliders["k1"].value = 1.0
    assert c.params.k1 == 1.0 and c.readout["q11"] == pytest.approx(5.5)
    assert changed(pictures(view)["lifted"], after["lifted"])


def test_run_converges_and_the_history_slider_goes_back(view):
    c = view.controller
    view.sliders["target_vertices"].value = 300
    view.buttons["run"].click()
    assert c.at_end
    assert abs(c.current.stats.n_vertices - 300) <= 30
    assert view.buttons["step"].disabled and view.buttons["iterate"].disabled
    assert view.buttons["run"].disabled
    assert view.history.value == view.history.max == len(c.history) - 1 > 3
    final = pictures(view)
    view.history.value = 1
    assert c.index == 1 and c.current.stage == "adjust"
    assert not view.buttons["step"].disabled
    assert "adjust" in view.status.value
    assert changed(pictures(view)["mesh"], final["mesh"])
    view.buttons["reset"].click()
    assert len(c.history) == 1 and c.index == 0 and view.history.max == 0


def test_vb_above_the_target_raises_the_target(view):
    view.sliders["vb"].value = 250                          # the target was 212
    assert view.controller.params.vb == 250
    assert view.controller.params.target_vertices == 251 == view.sliders["target_vertices"].value
    assert view.controller.current.mesh.fixed.sum() == 250
    assert "target vertices set to 251" in view.error.value      # the adjustment is said
    assert "warning" in view.error.value                          # and the thin mesh


def test_a_bad_value_shows_an_error_and_keeps_the_run(view):
    c = view.controller
    view.buttons["step"].click()
    history = list(c.history)
    view.sliders["target_vertices"].value = 3                # VB would have to go below 3
    assert "target" in view.error.value
    assert c.params.target_vertices == 212 == view.sliders["target_vertices"].value
    assert c.history == history and c.index == 1
    view.buttons["step"].click()                             # still works; the error clears
    assert c.index == 2 and view.error.value == ""


def test_backend_choice():
    with pytest.raises(QmeshError, match="backend"):
        choose_backend("browser")
    with pytest.raises(QmeshError, match="backend"):
        qmesh_view.widget(backend="vtk")
    assert choose_backend("static") == "static" and choose_backend("trame") == "trame"


def test_auto_is_static_without_a_jupyter_server_kernel(monkeypatch):
    monkeypatch.setenv("JPY_SESSION_NAME", "/somewhere/quickstart.ipynb")
    assert not in_jupyter_server_kernel()                  # no IPython kernel in pytest
    assert choose_backend("auto") == "static"


def test_bad_parameters_fail_before_any_widget_is_made():
    with pytest.raises(QmeshError):
        qmesh_view.widget(backend="static", k1=-1.0)


# --------------------------------------------------------------------------- threads

def _run_until(loop, predicate, timeout=20.0):
    async def wait():
        deadline = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() > deadline:
                raise TimeoutError("the main loop never ran the dispatched callback")
            await asyncio.sleep(0.01)
    loop.run_until_complete(wait())


def _from_thread(fn) -> threading.Thread:
    """Call fn() on a second thread, as ipykernel 7 delivers comm messages from a subshell."""
    t = threading.Thread(target=fn, name="fake-subshell")
    t.start()
    t.join(20)
    assert not t.is_alive()
    return t


@pytest.fixture
def loop():
    loop = asyncio.new_event_loop()
    yield loop
    loop.close()


def test_callbacks_from_another_thread_render_on_the_main_thread(loop):
    view = qmesh_view.widget(backend="static", view_size=SIZE, loop=loop)
    try:
        renders = []
        render = view.views.render

        def recording_render():
            renders.append(threading.current_thread())
            render()
        view.views.render = recording_render
        before = pictures(view)

        _from_thread(lambda: setattr(view.sliders["angle"], "value", 30.0))
        assert renders == [] and view.controller.params.angle == 0.0   # nothing ran there
        _run_until(loop, lambda: renders)
        assert renders == [threading.main_thread()]
        assert view.controller.params.angle == 30.0
        assert changed(pictures(view)["mesh"], before["mesh"])

        _from_thread(view.buttons["step"].click)
        assert view.controller.index == 0
        _run_until(loop, lambda: len(renders) == 2)
        assert view.controller.index == 1
        assert all(t is threading.main_thread() for t in renders)
    finally:
        view.close()


def test_main_thread_call_runs_at_once_on_its_own_thread(loop):
    ran = []
    for main in (MainThread(), MainThread(loop)):
        main.call(lambda: ran.append(threading.current_thread()))
    assert ran == [threading.main_thread()] * 2


def test_run_is_animated_on_the_loop_and_stop_halts_it(loop):
    view = qmesh_view.widget(backend="static", view_size=SIZE, loop=loop)
    c = view.controller

    async def scenario():
        view.buttons["run"].click()                       # returns at once: stages come later
        assert view.running and view.buttons["run"].description == "Stop"
        assert view.buttons["step"].disabled and view.history.disabled
        while c.index < 2:
            await asyncio.sleep(0.01)
        view.buttons["run"].click()                       # Stop
        stopped_at = c.index
        await asyncio.sleep(0.3)
        assert c.index == stopped_at and not view.running
        assert view.buttons["run"].description == "Run" and not view.buttons["step"].disabled
        view.buttons["run"].click()
        while view.running:
            await asyncio.sleep(0.02)
        assert c.at_end and view.history.value == len(c.history) - 1
    try:
        loop.run_until_complete(asyncio.wait_for(scenario(), 60))
    finally:
        view.close()


def test_legends_beside_the_views_and_the_edges_toggle(view):
    assert "seed points (fixed)" in view.legends["mesh"].value
    assert "quality: 0" in view.legends["quality"].value
    assert not view.views.plotters["quality"].scalar_bars       # no bar over the mesh
    before = pictures(view)
    view.edges.value = "off"
    actor = view.views.plotters["mesh"].actors["mesh"]
    assert not actor.GetProperty().GetEdgeVisibility()
    assert changed(pictures(view)["mesh"], before["mesh"])
    view.edges.value = "on"
    assert actor.GetProperty().GetEdgeVisibility()


def test_an_uploaded_polygon_file_becomes_the_domain_and_a_bad_one_is_refused(view):
    c = view.controller
    csv = b"0,0\n2,0\n2,1\n0,1\n\n0.6,0.3\n0.9,0.3\n0.9,0.7\n0.6,0.7\n"
    view.upload.value = ({"name": "plate.csv", "type": "text/csv", "size": len(csv),
                          "content": memoryview(csv), "last_modified": NOW},)
    assert c.params.domain == "file: plate.csv" == view.sliders["domain"].value
    assert "file: plate.csv" in view.sliders["domain"].options
    assert len(c.domain.rings) == 2 and c.domain.area == pytest.approx(2.0 - 0.12)
    shown = pictures(view)
    view.upload.value = ({"name": "bad.csv", "type": "text/csv", "size": 4,
                          "content": memoryview(b"1,2\n"), "last_modified": NOW},)
    assert "bad.csv" in view.error.value
    assert c.params.domain == "file: plate.csv" == view.sliders["domain"].value
    assert not changed(pictures(view)["mesh"], shown["mesh"])


def test_s_as_text_remeshes_and_a_hostile_text_shows_its_error_and_keeps_the_mesh(view):
    c = view.controller
    before = pictures(view)
    view.sliders["q_mode"].value = "expression"               # the default text, exp(x) + y**2
    assert c.params.q_mode == "expression" and not c.anisotropy.is_constant
    assert view._constant_box.layout.display == "none" and view._s_box.layout.display is None
    assert all(changed(a, before[n]) for n, a in pictures(view).items())
    view.s_text.value = "cosh(3*x) + 0.02*y**2"
    assert c.anisotropy.expression == "cosh(3*x) + 0.02*y**2" and len(c.history) == 1
    view.buttons["run"].click()
    assert c.at_end and "for s_h: 100.0%" in view.status.value
    shown, history = pictures(view), list(c.history)
    for hostile in ("__import__('os')", "().__class__", "x**2 - y**2"):
        view.s_text.value = hostile
        assert "color:#c62828" in view.s_error.value and len(view.s_error.value) > 40
        assert view.s_text.value == hostile                       # left to be corrected
        assert c.params.s_text == "cosh(3*x) + 0.02*y**2" and c.history == history
        assert not any(changed(a, shown[n]) for n, a in pictures(view).items())
    view.s_text.value = "x**4 + y**4 + x**2 + y**2"
    assert view.s_error.value == "" and c.params.s_text == "x**4 + y**4 + x**2 + y**2"
    view.sliders["q_mode"].value = "constant"
    assert c.anisotropy.is_constant and view._s_box.layout.display == "none"


def test_a_failure_while_drawing_is_shown_not_raised(view, monkeypatch):
    def broken(*args, **kwargs):
        raise RuntimeError("the GL context went away")
    monkeypatch.setattr(view.views, "draw", broken)
    view.buttons["step"].click()                             # no exception reaches ipywidgets
    assert "RuntimeError: the GL context went away" in view.error.value
    monkeypatch.undo()
    view.buttons["step"].click()
    assert view.controller.index == 2 and "RuntimeError" not in view.error.value


def test_a_media_preset_binds_regions_and_hides_the_single_q_controls(view):
    before = pictures(view)
    view.sliders["domain"].value = "layered"
    c = view.controller
    assert c.params.domain == "layered"
    assert c.index == 0 and not c.at_end          # opens on its first face, steppable
    c.controller.finish()
    assert len(np.unique(c.current.mesh.region_tags)) >= 2
    assert view._constant_box.layout.display == "none"
    assert view.sliders["q_mode"].layout.display == "none"
    for r in c.regions:
        assert r["name"] in view.media_readout.value
        assert r["name"] in view.legends["mesh"].value
    after = pictures(view)
    assert all(changed(after[name], before[name]) for name in after)
    view.sliders["domain"].value = "disk"
    assert view._constant_box.layout.display is None and view.media_readout.value == ""
    assert "Q11 = 0.1" in view.readout.value
