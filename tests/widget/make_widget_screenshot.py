"""Write screenshots/widget.png: the quickstart notebook's widget in a live JupyterLab.

    python tests/widget/make_widget_screenshot.py [--out screenshots/widget.png]

Runs every cell of examples/quickstart.ipynb in JupyterLab (Debian's Chromium through
Playwright, HEADLESS.md), waits until the widget's three views are drawn, runs the widget to
convergence (its Run button), scrolls its views into sight and saves the window. LOOK at the image written.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
os.environ.setdefault("VTK_WASM_DIR_OVERRIDE", tempfile.mkdtemp(prefix="qmesh-widget-wasm-"))
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))                 # tests/: headless_browser

from lab_browser import drawn, jupyter_lab, lab_page, screenshot, until  # noqa: E402

ROOT = HERE.parents[1]
NOTEBOOK = ROOT / "examples" / "quickstart.ipynb"
HEADLESS_ENV = ("PYVISTA_OFF_SCREEN", "VTK_DEFAULT_OPENGL_WINDOW", "VTK_WASM_DIR_OVERRIDE")


def write(out: Path) -> None:
    folder = Path(tempfile.mkdtemp(prefix="qmesh-widget-shot-"))
    shutil.copy(NOTEBOOK, folder)
    env = {name: os.environ[name] for name in HEADLESS_ENV}
    try:
        with jupyter_lab(folder, env) as (base, token), \
                lab_page(f"{base}/lab/tree/{NOTEBOOK.name}?token={token}", (1280, 900)) as page:
            page.get_by_text("Python 3 (ipykernel) | Idle").wait_for(timeout=60_000)
            page.get_by_role("menuitem", name="Run", exact=True).click()
            page.get_by_role("menuitem", name="Run All Cells", exact=True).click()
            frames = page.locator("iframe.pyvista")
            frames.nth(2).wait_for(timeout=120_000)
            until(lambda: all(drawn(screenshot(frames.nth(i))) for i in range(3)) or None, 90,
                  "the widget's three views to be drawn")
            page.get_by_text("Python 3 (ipykernel) | Idle").wait_for(timeout=120_000)
            page.locator(".jp-SideBar .lm-TabBar-tab.lm-mod-current").first.click()  # fold the files
            status = page.locator(".widget-html", has_text="iteration").first
            page.get_by_role("button", name="Run", exact=True).last.click()     # the widget's Run
            until(lambda: "converged" in status.inner_text() or None, 120, "the run to converge")
            page.wait_for_timeout(1000)
            until(lambda: all(drawn(screenshot(frames.nth(i))) for i in range(3)) or None, 60,
                  "the converged views to be drawn")
            frames.nth(2).evaluate("e => e.scrollIntoView({block: 'end'})")
            page.wait_for_timeout(1500)
            out.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(out))
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    print("wrote", out)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=ROOT / "screenshots" / "widget.png")
    write(p.parse_args().out)


if __name__ == "__main__":
    main()
