"""In Chromium: typed and fast inputs land, a huge target is refused without wedging
the app, warnings reach the page, and the mesh view shows the mesh at N = 10,000."""

import os
import re

import numpy as np
import pytest

import view_browser as b

pytestmark = pytest.mark.browser      # shares the worker's Chromium (tests/conftest.py)

SETTLE = 600      # ms without a change that counts as settled


def _n(line):
    m = re.search(r"N = (\d+)", line)
    assert m, line
    return int(m.group(1))


def _slider_value(page, name):
    return b.page_text(page, f"#slider-{name} .slider-value")


def _target(page):
    return page.locator("#field-target input").input_value()


def _rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS:")) / 1024


def _wait_settled(page, timeout=60.0):
    """Idle, with nothing more arriving: the status line and the Q readout read when the busy
    bar hides and again SETTLE ms later, the same."""
    def read():
        b.wait_idle(page, timeout)
        return b.status(page), b.page_text(page, "#q-readout")
    last = [read()]

    def same():
        page.wait_for_timeout(SETTLE)
        now = read()
        ok = now == last[0]
        last[0] = now
        return now if ok else None
    return b.until(same, timeout, "the page to settle", interval=0)


@pytest.mark.slow
def test_typed_target_fast_slider_keys_and_a_refused_huge_target():
    with b.qmesh_view_server() as url, b.chromium_page(url) as page:
        b.wait_drawn(page)
        b.wait_idle(page)
        s0 = b.status(page)

        # typing 1000 over 212 at a human pace: nothing applies until Enter; then N ≈ 1000
        field = page.locator("#field-target input")
        field.click()
        field.press("Control+a")
        field.press_sequentially("1000", delay=150)
        page.wait_for_timeout(800)
        assert b.status(page) == s0 and _target(page) == "1000"   # not applied, not rewritten
        field.press("Enter")
        line, _ = _wait_settled(page)
        assert abs(_n(line) - 1000) <= 100 and _target(page) == "1000"
        assert _slider_value(page, "vb") == "64"

        # 5000 typed over 1000: VB unchanged (64 < 5000), applied on leaving the field (blur)
        field.click()
        field.press("Control+a")
        field.press_sequentially("5000", delay=150)
        page.locator("#q-readout").click()
        line, _ = _wait_settled(page)
        assert abs(_n(line) - 5000) <= 500 and _target(page) == "5000"
        assert _slider_value(page, "vb") == "64"
        field.click()
        field.press("Control+a")
        field.press_sequentially("212", delay=100)
        field.press("Enter")
        _wait_settled(page)

        # Home then ArrowRight ×9 quickly on the angle slider (5° steps): 45°, three times;
        # the slider, the Q readout and the mesh agree at the end
        thumb = page.locator("#slider-angle .v-slider-thumb")
        for attempt in range(3):
            thumb.focus()
            page.keyboard.press("Home")
            for _ in range(9):
                page.keyboard.press("ArrowRight", delay=20)
            line, readout = _wait_settled(page)
            assert _slider_value(page, "angle") == "45°", attempt
            assert readout == "Q11 = 5.05 · Q12 = -4.95 · Q22 = 5.05", attempt
            assert line.startswith("iteration 0 · triangulate")
        b.save(page, "browser-inputs-angle-45")

        # dragging the angle with the mouse to the middle of its track: wherever it stops, the
        # slider, the readout and the mesh's Q agree once the page settles
        track = page.locator("#slider-angle .v-slider-track").bounding_box()
        thumb_box = thumb.bounding_box()
        y = thumb_box["y"] + thumb_box["height"] / 2
        page.mouse.move(thumb_box["x"] + thumb_box["width"] / 2, y)
        page.mouse.down()
        page.mouse.move(track["x"] + 0.5 * track["width"], y, steps=12)
        page.mouse.up()
        line, readout = _wait_settled(page)
        angle = float(_slider_value(page, "angle").rstrip("°"))
        assert 60 <= angle <= 120, angle
        t = np.deg2rad(angle)
        q12 = float(readout.split("Q12 = ")[1].split(" ")[0])
        assert q12 == pytest.approx((0.1 - 10.0) * np.sin(t) * np.cos(t), abs=0.01), (angle, q12)

        # a forged state value (not a number) is refused on the page and the slider put back
        before = b.status(page)
        page.evaluate("() => window.trame.state.set('k1', 'abc')")
        b.until(lambda: "k1 must be a number" in b.page_text(page, "#messages") or None, 20,
                "the refusal of a forged value")
        b.until(lambda: _slider_value(page, "k1") == "0.1" or None, 20, "k1 put back")
        assert b.status(page) == before

        # a 2e9 target, typed with an exponent: refused by the memory budget with the estimate on
        # the page (not as "not an integer"); the server stays small; Step works
        before = b.status(page)
        field.click()
        field.press("Control+a")
        field.press_sequentially("2e9", delay=30)
        field.press("Enter")
        b.until(lambda: "GiB" in b.page_text(page, "#messages") or None, 30, "the refusal")
        message = b.page_text(page, "#messages")
        assert "2e+09 vertices" in message and "memory" in message, message
        b.until(lambda: _target(page) == "212" or None, 20, "the target field to be put back")
        assert b.status(page) == before
        server = b.last_server_pid()
        assert _rss_mb(server) < 1500, _rss_mb(server)
        views_before = b.views(page)
        page.get_by_role("button", name="Step", exact=True).click()
        s1 = b.settled_status(page, before)
        assert s1.startswith("iteration 1 · adjust")
        b.wait_view_change(page, "mesh", views_before["mesh"])
        b.save(page, "browser-inputs-refused-2e9")


@pytest.mark.slow
def test_a_warning_is_shown_and_the_mesh_view_is_readable_at_10000():
    with b.qmesh_view_server("--vb", "512", "--target-vertices", "513") as url, \
            b.chromium_page(url) as page:
        b.wait_drawn(page)
        b.wait_idle(page)
        messages = page.locator("#messages")
        b.until(lambda: "warning" in messages.inner_text() or None, 30, "a warning")
        assert "interior vertex" in messages.inner_text()
        views_top = page.locator("#views").bounding_box()["y"]

        field = page.locator("#field-target input")
        field.click()
        field.press("Control+a")
        field.press_sequentially("10000", delay=50)
        field.press("Enter")
        line, _ = _wait_settled(page, 120)
        assert abs(_n(line) - 10000) <= 1000
        assert page.locator("#views").bounding_box()["y"] == views_top   # the views never moved
        page.wait_for_timeout(1000)
        mesh = b.view_image(page, "mesh").astype(float)
        b.save(page, "browser-inputs-10000")
        # not a uniform disk: the inside of the view varies (colour by element size)
        h, w = mesh.shape[:2]
        inner = mesh[h // 4: 3 * h // 4, w // 4: 3 * w // 4]
        assert b.colour_count(inner) > 50
        assert inner.std(axis=(0, 1)).max() > 8.0, inner.std(axis=(0, 1))
        assert os.path.exists(b.ARTIFACTS / "browser-inputs-10000.png")
