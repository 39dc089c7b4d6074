"""The widget in a live JupyterLab: Playwright drives Debian's Chromium (HEADLESS.md).

JupyterLab 4.6 with ipykernel 7 delivers widget messages on a kernel subshell thread. Before
the widget re-dispatched its handlers to the kernel's main thread, the views stopped following
the sliders from the second move on. So: run the quickstart notebook, drag the angle slider
twice, and after each move require every view to be drawn (enough colours, enough non-white
pixels, not black) and the mesh view to have changed. Screenshots go to test-artifacts/.
"""

import os
import shutil
from pathlib import Path

import pytest
from lab_browser import (ARTIFACTS, drawn, jupyter_lab, lab_page, mean_diff, screenshot,
                         until)

pytestmark = pytest.mark.browser      # shares the worker's Chromium (tests/conftest.py)

NOTEBOOK = Path(__file__).resolve().parents[2] / "examples" / "quickstart.ipynb"
HEADLESS_ENV = ("PYVISTA_OFF_SCREEN", "VTK_DEFAULT_OPENGL_WINDOW", "VTK_WASM_DIR_OVERRIDE")
VIEWS = ("lifted", "mesh", "quality")


def views(frames) -> dict:
    return {name: screenshot(frames.nth(i)) for i, name in enumerate(VIEWS)}


def drag(page, slider, fraction: float) -> None:
    """Drag `slider`'s handle to `fraction` of its track, as a user does with the mouse."""
    slider.scroll_into_view_if_needed()      # the widget fits a narrow output area: taller
    handle = slider.locator(".noUi-handle").bounding_box()
    track = slider.locator(".noUi-target").bounding_box()
    y = handle["y"] + handle["height"] / 2
    page.mouse.move(handle["x"] + handle["width"] / 2, y)
    page.mouse.down()
    page.mouse.move(track["x"] + fraction * track["width"], y, steps=8)
    page.mouse.up()


@pytest.mark.slow
def test_widget_views_stay_drawn_after_two_slider_moves_in_jupyterlab(tmp_path):
    shutil.copy(NOTEBOOK, tmp_path)
    env = {name: os.environ[name] for name in HEADLESS_ENV}
    ARTIFACTS.mkdir(exist_ok=True)
    with jupyter_lab(tmp_path, env) as (base, token), \
            lab_page(f"{base}/lab/tree/{NOTEBOOK.name}?token={token}") as page:
        page.get_by_text("Python 3 (ipykernel) | Idle").wait_for(timeout=60_000)
        page.get_by_role("menuitem", name="Run", exact=True).click()
        page.get_by_role("menuitem", name="Run All Cells", exact=True).click()

        frames = page.locator("iframe.pyvista")        # PyVista's trame views: "auto" chose trame
        frames.nth(2).wait_for(timeout=90_000)
        assert frames.count() == 3
        shown = until(lambda: (lambda v: v if all(map(drawn, v.values())) else None)(views(frames)),
                      60, "the three views to be drawn")
        box = page.locator(".jp-OutputArea-output", has=frames.first)
        box.screenshot(path=str(ARTIFACTS / "widget-lab-0.png"))
        # a person drags once the notebook has finished running (the kernel idle again): a drag
        # while the last cell still runs waits behind it, which a loaded machine can stretch
        page.get_by_text("Python 3 (ipykernel) | Idle").wait_for(timeout=60_000)

        slider = page.locator(".widget-slider", has_text="angle")
        readout = page.locator(".widget-html", has_text="Q11")
        status = page.locator(".widget-html", has_text="iteration").first
        for move, fraction in enumerate((0.25, 0.5), start=1):
            old_status, old_readout = status.inner_text(), readout.inner_text()
            drag(page, slider, fraction)
            until(lambda: status.inner_text() != old_status, 30, f"move {move}: a new status line")
            assert readout.inner_text() != old_readout          # Q follows the angle

            def redrawn(old=shown):
                new = views(frames)
                return new if (all(map(drawn, new.values()))
                               and mean_diff(new["mesh"], old["mesh"]) > 1.0) else None
            try:
                shown = until(redrawn, 30, f"move {move}: all views drawn, the mesh view changed")
            finally:
                box.screenshot(path=str(ARTIFACTS / f"widget-lab-{move}.png"))
