"""Write the screenshot baselines into screenshots/ (and, with --app, the README's app.png).

    python tests/view/make_baselines.py          # the off-screen view baselines
    python tests/view/make_baselines.py --app    # also browser screenshots of the whole app:
                                                 # app.png (the chapter's case) and
                                                 # app_holes.png (a plate with three holes),
                                                 # app_layered.png (the layered medium),
                                                 # app_inclusion.png (the inclusion medium),
                                                 # app_maximum_principle.png (the rotating
                                                 # field's u_h on an isotropic mesh)

Run it only when the drawing or the mesher changed on purpose, then LOOK at every image written.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))    # tests/: headless_browser

from PIL import Image  # noqa: E402

import view_cases as cases  # noqa: E402


def write_views() -> None:
    run = cases.finished_run()
    cases.BASELINES.mkdir(exist_ok=True)
    for name in cases.CASES:
        path = cases.BASELINES / f"{name}.png"
        Image.fromarray(cases.render_case(run, name)).save(path)
        print("wrote", path)


def write_app(path: Path, domain: str | None = None, then=None) -> None:
    """The whole app in Chromium after Run has taken the chapter's case (or the chapter's Q on
    the named `domain`) to convergence; `then(page)` clicks on before the screenshot."""
    import view_browser as browser
    with browser.qmesh_view_server() as url, browser.chromium_page(url, (1600, 900)) as page:
        browser.wait_drawn(page)
        browser.wait_idle(page)
        if domain is not None:
            old = browser.status(page)
            page.locator("#select-domain .v-field").click()
            page.get_by_role("option", name=domain, exact=True).click()
            browser.settled_status(page, old)
        run = page.get_by_role("button", name="Run", exact=True)
        if run.is_enabled():                          # a medium is shown whole at once
            run.click()
        browser.until(lambda: "converged" in browser.status(page) or None, 180,
                      "the run to converge")
        browser.wait_idle(page)
        if then is not None:
            then(page)
        page.wait_for_timeout(1500)                   # the last images reach the browser
        page.screenshot(path=str(path))
    print("wrote", path)


def maximum_principle(page) -> None:
    """The quality view shows u_h on the isotropic mesh of the same N (both counts below it)."""
    import view_browser as browser
    page.locator("#select-colour-by .v-field").click()
    page.get_by_role("option", name="maximum principle: u_h").click()
    browser.until(lambda: "outside [0, 1]" in browser.page_text(page, "#legend-quality"), 30,
                  "the maximum principle's legend")
    page.locator("#switch-isotropic input").check()
    browser.until(lambda: "isotropic mesh" in browser.page_text(page, "#title-quality"), 30,
                  "the isotropic mesh's title")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--app", action="store_true", help="also write screenshots/app.png")
    args = p.parse_args()
    write_views()
    if args.app:
        write_app(cases.BASELINES / "app.png")
        write_app(cases.BASELINES / "app_holes.png", "plate with holes")
        write_app(cases.BASELINES / "app_layered.png", "layered")
        write_app(cases.BASELINES / "app_inclusion.png", "inclusion")
        write_app(cases.BASELINES / "app_maximum_principle.png", "rotating", maximum_principle)


if __name__ == "__main__":
    main()
