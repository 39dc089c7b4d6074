"""The real app in a real browser: `qmesh-view --server` on 127.0.0.1, driven by Debian's Chromium.

One test walks the whole session (starting the server and the browser costs more than the
clicks): the three views get drawn, Step (every view redrawn), Iterate, the history slider,
a Q slider, Run and Stop each change the status line and the views. Others drive the controls
into conflicts (VB past the target, a target the mesher refuses) and check the app recovers.
Screenshots go to test-artifacts/.
"""

import re

import pytest
import view_browser as b
from headless_browser import drawn

pytestmark = pytest.mark.browser      # shares the worker's Chromium (tests/conftest.py)


def _iteration_stage(line):
    m = re.match(r"iteration (\d+) · (\w+) · N = (\d+)", line)
    assert m, f"unexpected status line {line!r}"
    return int(m.group(1)), m.group(2), int(m.group(3))


@pytest.mark.slow
def test_app_session_in_chromium():
    with b.qmesh_view_server("--run-pause", "0.5") as url, b.chromium_page(url) as page:
        start = b.wait_drawn(page)
        b.wait_idle(page)
        b.save(page, "browser-0-start")
        s0 = b.status(page)
        assert _iteration_stage(s0)[:2] == (0, "triangulate")
        for part in ("E = ", "quality min", "q_ij ≥ 0: 100.0%", "κ2 = "):
            assert part in s0
        assert b.page_text(page, "#q-readout") == "Q11 = 0.1 · Q12 = 0 · Q22 = 10"

        # Step: one stage, the adjust of iteration 1, drawn with its displacement arrows; every
        # view shows a new picture after the click (how soon: bench_view.py's figure)
        page.evaluate(b.LATENCY_PROBE)
        latency = b.click_latency(page, page.get_by_role("button", name="Step", exact=True).click,
                                  timeout=30)
        assert all(t is not None and t > 0 for t in latency.values()), latency
        s1 = b.settled_status(page, s0)
        assert _iteration_stage(s1)[:2] == (1, "adjust")
        b.wait_view_change(page, "mesh", start["mesh"])
        b.save(page, "browser-1-step")

        # Iterate: to the end of iteration 1 (points inserted, re-triangulated)
        page.get_by_role("button", name="Iterate", exact=True).click()
        s2 = b.settled_status(page, s1)
        it, stage, n = _iteration_stage(s2)
        assert (it, stage) == (1, "triangulate") and n > _iteration_stage(s0)[2]
        after_iterate = {name: b.wait_view_change(page, name, start[name]) for name in b.VIEWS}
        b.save(page, "browser-2-iterate")

        # the history slider scrubs back to the first triangulation, and forward again
        b.wait_idle(page)
        thumb = page.locator("#slider-history_index .v-slider-thumb")
        thumb.focus()
        page.keyboard.press("Home")
        assert b.settled_status(page, s2) == s0
        page.keyboard.press("End")
        assert b.settled_status(page, s0) == s2

        # a Q slider: k2 10 → 9.95 re-meshes from the start with the new Q and redraws
        b.wait_idle(page)
        page.locator("#slider-k2 .v-slider-thumb").focus()
        page.keyboard.press("ArrowLeft")
        s3 = b.settled_status(page, s2)
        assert _iteration_stage(s3)[:2] == (0, "triangulate") and s3 != s0
        assert b.page_text(page, "#q-readout") == "Q11 = 0.1 · Q12 = 0 · Q22 = 9.95"
        for name in b.VIEWS:
            b.wait_view_change(page, name, after_iterate[name])
        b.save(page, "browser-3-q-changed")

        # view options redraw without re-meshing: q_ij-sign edges, colour by metric area, z-scale
        shown = b.views(page)
        page.locator("#switch-q-sign input").check()
        shown["quality"] = b.wait_view_change(page, "quality", shown["quality"])
        page.locator("#select-colour-by .v-field").click()
        page.get_by_role("option", name="metric area").click()
        b.wait_view_change(page, "quality", shown["quality"])
        page.locator("#slider-z_scale .v-slider-thumb").focus()
        page.keyboard.press("PageUp")
        b.wait_view_change(page, "lifted", shown["lifted"])
        assert b.status(page) == s3                         # same stage, nothing re-meshed
        b.save(page, "browser-4-view-options")

        b.wait_idle(page)
        before = b.views(page)
        # the mesh and quality cameras are linked: zooming the mesh view zooms the quality view
        box = page.locator("#view-mesh").bounding_box()
        page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        for _ in range(4):
            page.mouse.wheel(0, -240)
            page.wait_for_timeout(150)
        b.wait_view_change(page, "mesh", before["mesh"], min_diff=3.0)
        b.wait_view_change(page, "quality", before["quality"], min_diff=3.0)
        assert b.mean_diff(b.view_image(page, "lifted"), before["lifted"]) < 1.0
        b.save(page, "browser-5-zoomed")

        # Run animates stage after stage until Stop (the server holds each stage 0.5 s: a whole
        # run at 20,000 vertices ends in a fraction of a second, before a click could land)
        b.wait_idle(page)
        target = page.locator("#field-target input")
        target.fill("20000")
        target.press("Enter")
        s4 = b.settled_status(page, s3, timeout=120)
        assert _iteration_stage(s4)[0] == 0 and _iteration_stage(s4)[2] > 15_000
        page.get_by_role("button", name="Run", exact=True).click()
        b.until(lambda: _iteration_stage(b.status(page))[0] >= 2, 120,
                "the run to reach iteration 2")
        page.get_by_role("button", name="Stop", exact=True).click()
        page.get_by_role("button", name="Run", exact=True).wait_for(timeout=30_000)
        b.wait_idle(page)
        stopped = b.status(page)
        page.wait_for_timeout(1000)
        assert b.status(page) == stopped                     # nothing runs after Stop
        assert _iteration_stage(stopped)[0] >= 2
        assert all(drawn(img) for img in b.views(page).values())
        b.save(page, "browser-6-run-stopped")


def _slider_value(page, name):
    return b.page_text(page, f"#slider-{name} .slider-value")


def _target(page):
    return page.locator("#field-target input").input_value()


@pytest.mark.slow
def test_vb_past_the_target_and_a_refused_target_never_wedge_the_controls():
    with b.qmesh_view_server() as url, b.chromium_page(url) as page:
        b.wait_drawn(page)
        b.wait_idle(page)
        s0 = b.status(page)
        assert (_slider_value(page, "vb"), _target(page)) == ("64", "212")

        # VB driven to its maximum, far past the target 212: the target follows to VB + 1
        page.locator("#slider-vb .v-slider-thumb").focus()
        page.keyboard.press("End")
        s1 = b.settled_status(page, s0)
        assert (_slider_value(page, "vb"), _target(page)) == ("512", "513")
        assert _iteration_stage(s1)[:2] == (0, "triangulate") and _iteration_stage(s1)[2] >= 512
        assert "target vertices set to 513" in b.page_text(page, "#messages")
        shown = b.views(page)

        # a target the mesher cannot have (VB would go below 3): refused, the field is put back
        field = page.locator("#field-target input")
        field.fill("3")
        field.press("Enter")
        b.until(lambda: "exceed" in b.page_text(page, "#messages") or None, 20, "the refusal")
        b.until(lambda: _target(page) == "513" or None, 20, "the target field to be put back")
        assert _slider_value(page, "vb") == "512" and b.status(page) == s1

        # a later k1 change works: re-meshed with the values in force, the error gone
        page.locator("#slider-k1 .v-slider-thumb").focus()
        page.keyboard.press("End")
        s2 = b.settled_status(page, s1)
        assert _iteration_stage(s2)[:2] == (0, "triangulate") and s2 != s1
        assert b.page_text(page, "#q-readout") == "Q11 = 20 · Q12 = 0 · Q22 = 10"
        assert "exceed" not in b.page_text(page, "#messages")
        assert (_slider_value(page, "vb"), _target(page), _slider_value(page, "k1")) == (
            "512", "513", "20")
        for name in ("lifted", "quality"):                 # s and the metric changed with Q
            b.wait_view_change(page, name, shown[name])

        # Run to the end: the controls still show the parameters of the mesh on screen
        page.get_by_role("button", name="Run", exact=True).click()
        b.until(lambda: "converged" in b.status(page) or None, 120, "the run to converge")
        b.wait_idle(page)
        assert (_slider_value(page, "vb"), _target(page), _slider_value(page, "k1")) == (
            "512", "513", "20")
        b.save(page, "browser-vb-recovered")



@pytest.mark.slow
def test_keys_pressed_fast_on_the_history_slider_are_never_lost():
    """A person steps through a run's stages by pressing arrow keys faster than a stage is drawn
    and measured: the app ends on the stage the slider was last moved to, and shows it."""
    with b.qmesh_view_server() as url, b.chromium_page(url) as page:
        b.wait_drawn(page)
        b.wait_idle(page)
        page.get_by_role("button", name="Run", exact=True).click()
        b.until(lambda: "converged" in b.status(page) or None, 120, "the run to converge")
        b.wait_idle(page)
        last = int(_slider_value(page, "history_index").split(" / ")[1])
        assert last >= 6
        b.until(lambda: page.locator("#slider-history_index .v-input--disabled").count() == 0
                or None, 10, "the stage slider enabled after the Run")
        thumb = page.locator("#slider-history_index .v-slider-thumb")
        thumb.focus()
        page.keyboard.press("Home")
        b.until(lambda: _iteration_stage(b.status(page))[:2] == (0, "triangulate") or None,
                30, "the first stage")
        b.wait_idle(page)
        for _ in range(3):                       # 0 -> 3: iteration 1's adjust, insert, triangulate
            page.keyboard.press("ArrowRight")
            page.wait_for_timeout(60)
        b.until(lambda: _iteration_stage(b.status(page))[:2] == (1, "triangulate") or None,
                30, "the stage the slider was moved to")
        b.wait_idle(page)
        assert _slider_value(page, "history_index") == f"3 / {last}"
        assert _iteration_stage(b.status(page))[:2] == (1, "triangulate")
        page.keyboard.press("End")                # and back down from the end, as fast
        for _ in range(2):
            page.wait_for_timeout(60)
            page.keyboard.press("ArrowLeft")
        b.until(lambda: _slider_value(page, "history_index") == f"{last - 2} / {last}" or None,
                30, "the slider to rest two stages before the end")
        b.wait_idle(page)
        page.wait_for_timeout(500)
        assert _slider_value(page, "history_index") == f"{last - 2} / {last}"
        at_end = b.status(page)
        assert "converged" not in at_end         # not the last stage
        assert all(drawn(img) for img in b.views(page).values())
        b.save(page, "browser-history-keys")

@pytest.mark.slow
def test_choosing_l_shape_and_uploading_a_polygon_file(tmp_path):
    with b.qmesh_view_server() as url, b.chromium_page(url) as page:
        start = b.wait_drawn(page)
        b.wait_idle(page)
        s0 = b.status(page)
        page.locator("#select-domain .v-field").click()
        page.get_by_role("option", name="L-shape", exact=True).click()
        s1 = b.settled_status(page, s0)
        assert _iteration_stage(s1)[:2] == (0, "triangulate")
        assert not page.locator("#slider-vb").is_visible()         # VB is the disk's only
        lshape = {name: b.wait_view_change(page, name, start[name]) for name in b.VIEWS}
        b.save(page, "browser-domain-lshape")

        # maximise the quality view: it takes the row, the others step aside; then restore
        small = page.locator("#view-quality").bounding_box()
        page.locator("#max-quality").click()
        b.until(lambda: page.locator("#view-quality").bounding_box()["width"]
                > 2.5 * small["width"] or None, 20, "the quality view to grow")
        assert not page.locator("#view-mesh").is_visible()
        big = b.wait_view_change(page, "quality", lshape["quality"])   # drawn at its new size
        assert drawn(big) and big.shape[1] > 2.5 * lshape["quality"].shape[1]
        b.save(page, "browser-domain-maximised")
        page.locator("#max-quality").click()
        b.until(lambda: page.locator("#view-mesh").is_visible() or None, 20, "the views back")
        b.wait_idle(page)

        # a CSV file with an outline and a hole, uploaded from the browser
        path = tmp_path / "plate.csv"
        path.write_text("0,0\n2,0\n2,1\n0,1\n\n0.6,0.3\n0.9,0.3\n0.9,0.7\n0.6,0.7\n")
        page.locator("#upload-domain input[type=file]").set_input_files(str(path))
        s2 = b.settled_status(page, s1)
        assert _iteration_stage(s2)[:2] == (0, "triangulate")
        assert "file: plate.csv" in b.page_text(page, "#select-domain")
        for name in b.VIEWS:
            b.wait_view_change(page, name, lshape[name])
        assert b.page_text(page, "#messages") == ""
        assert page.locator("#upload-domain input[type=file]").input_value() == ""   # cleared
        b.save(page, "browser-domain-upload")

        # a bad file: refused on the page, the field cleared, the plate still on screen
        bad = tmp_path / "bad.csv"
        bad.write_text("1,2\n")
        page.locator("#upload-domain input[type=file]").set_input_files(str(bad))
        b.until(lambda: "bad.csv" in b.page_text(page, "#messages") or None, 20, "the refusal")
        assert b.status(page) == s2 and "file: plate.csv" in b.page_text(page, "#select-domain")
        b.until(lambda: page.locator("#upload-domain").inner_text().find("bad.csv") < 0 or None,
                20, "the file field to forget the refused file")


@pytest.mark.slow
def test_s_typed_as_text_remeshes_and_a_hostile_text_shows_an_error():
    with b.qmesh_view_server() as url, b.chromium_page(url) as page:
        start = b.wait_drawn(page)
        b.wait_idle(page)
        s0 = b.status(page)
        page.locator("#q-mode").get_by_role("button", name="s(x, y)").click()
        s1 = b.settled_status(page, s0)                 # the default text, exp(x) + y**2
        assert _iteration_stage(s1)[:2] == (0, "triangulate")
        assert not page.locator("#q-readout").is_visible()
        first = {name: b.wait_view_change(page, name, start[name]) for name in b.VIEWS}

        field = page.locator("#field-s input")
        field.fill("cosh(3*x) + 0.02*y**2")
        field.press("Enter")
        s2 = b.settled_status(page, s1)
        assert _iteration_stage(s2)[:2] == (0, "triangulate")
        assert "for s_h: 100.0%" in s2
        for name in b.VIEWS:
            b.wait_view_change(page, name, first[name])
        b.wait_idle(page)
        page.wait_for_timeout(500)
        shown = b.views(page)
        b.save(page, "browser-s-cosh")

        field.fill("__import__('os')")
        field.press("Enter")
        message = page.locator("#field-s .v-messages")
        b.until(lambda: "__import__" in message.inner_text() or None, 20,
                "the error next to the s(x, y) field")
        assert b.status(page) == s2                               # the last mesh stays
        assert field.input_value() == "__import__('os')"          # the text, to be corrected
        page.wait_for_timeout(500)
        assert all(b.mean_diff(b.view_image(page, n), shown[n]) < 1.0 for n in b.VIEWS)
        b.save(page, "browser-s-hostile")

        # a preset re-meshes and clears the error
        page.locator("#select-s-preset .v-field").click()
        page.get_by_role("option", name="x**4 + y**4 + x**2 + y**2").click()
        s3 = b.settled_status(page, s2)
        assert _iteration_stage(s3)[:2] == (0, "triangulate")
        assert field.input_value() == "x**4 + y**4 + x**2 + y**2"
        b.until(lambda: message.inner_text().strip() == "" or None, 20, "the error to clear")


@pytest.mark.slow
def test_choosing_layered_shows_regions_and_their_q():
    with b.qmesh_view_server() as url, b.chromium_page(url) as page:
        start = b.wait_drawn(page)
        b.wait_idle(page)
        s0 = b.status(page)
        assert not page.locator("#media-readout").is_visible()
        page.locator("#select-domain .v-field").click()
        page.get_by_role("option", name="layered", exact=True).click()
        s1 = b.settled_status(page, s0)
        assert _iteration_stage(s1)[1] == "triangulate"     # (media count from iteration 1)
        for name in b.VIEWS:
            assert drawn(b.wait_view_change(page, name, start[name])), name
        b.until(lambda: page.locator("#media-readout").is_visible() or None, 20,
                "the regions' Q on the page")
        readout = b.page_text(page, "#media-readout")
        assert "do not apply" in readout and "layer 1 (bottom): Q = " in readout
        assert readout.count("Q = ") == 5
        assert not page.locator("#q-readout").is_visible()          # one Q does not apply
        mesh_legend = b.page_text(page, "#legend-mesh")
        assert "layer 5 (top): Q = " in mesh_legend and "interface" in mesh_legend
        b.save(page, "browser-domain-layered")
