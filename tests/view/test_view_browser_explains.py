"""The viewer explains itself in a real browser: no console error on load or after a Run, every
slider found by its label, titles in words with the equation numbers in their tooltips, a legend
line saying what each Step changed, and a medium steppable from its first triangulation at a
target where it meshes without a warning."""

import re

import pytest
import view_browser as b

pytestmark = pytest.mark.browser      # shares the worker's Chromium (tests/conftest.py)

SLIDERS = ("k1, the conductivity along the angle", "k2, the conductivity across it",
           "angle of k1 in degrees", "VB, seed points on the disk",
           "z-scale of the lifted surface", "stage shown, from the history of the run")
FIELDS = ("target vertices", "seed", "domain", "colour by")


def listen(errors: list):
    """A `chromium_page` hook: every console error and uncaught page error into `errors`."""
    def hook(page):
        page.on("console", lambda m: m.type == "error" and errors.append(m.text))
        page.on("pageerror", lambda e: errors.append(f"uncaught: {e}"))
    return hook


def run_to_the_end(page, timeout: float = 120) -> str:
    page.get_by_role("button", name="Run", exact=True).click()
    b.until(lambda: "converged" in b.status(page) or None, timeout, "the run to converge")
    b.wait_idle(page)
    page.wait_for_function("() => !document.querySelector('#btn-run').textContent"
                           ".includes('Stop')")
    return b.status(page)


@pytest.mark.slow
def test_the_default_case_loads_and_runs_without_console_errors_and_says_what_changed():
    errors: list = []
    with b.qmesh_view_server() as url, b.chromium_page(url, before=listen(errors)) as page:
        b.wait_drawn(page)
        b.wait_idle(page)
        page.wait_for_timeout(1000)            # late layout passes and frames
        assert errors == [], errors

        for label in SLIDERS:
            assert page.get_by_role("slider", name=label, exact=True).count() == 1, label
        unnamed = page.evaluate("() => [...document.querySelectorAll('[role=slider]')]"
                                ".filter(e => !e.getAttribute('aria-label')).length")
        assert unnamed == 0
        for label in FIELDS:
            assert page.get_by_label(label, exact=True).count() >= 1, label

        for name in b.VIEWS:
            title = page.locator(f"#title-{name}")
            assert not re.search(r"\(\d\.\d+\)", title.inner_text()), title.inner_text()
            assert title.get_attribute("title")
        assert "(2.94)" in page.locator("#title-quality").get_attribute("title")

        assert "first triangulation: " in b.page_text(page, "#legend-mesh")
        s0 = b.status(page)
        page.get_by_role("button", name="Step", exact=True).click()
        b.settled_status(page, s0)
        b.until(lambda: re.search(r"adjust: \d+ vertices moved, rms [\d.e-]+ of an element",
                                  b.page_text(page, "#legend-mesh")), 20, "the legend's line")
        run_to_the_end(page)
        page.wait_for_timeout(1000)
        assert errors == [], errors


@pytest.mark.slow(40)
def test_layered_opens_steppable_at_its_own_target_and_runs_without_a_warning():
    with b.qmesh_view_server() as url, b.chromium_page(url) as page:
        b.wait_drawn(page)
        b.wait_idle(page)
        s0 = b.status(page)
        page.locator("#select-domain .v-field").click()
        page.get_by_role("option", name="layered", exact=True).click()
        s1 = b.settled_status(page, s0)
        assert re.match(r"iteration 0 · triangulate · ", s1), s1
        assert page.locator("#field-target input").input_value() == "800"
        for button in ("Step", "Iterate", "Run"):
            assert page.get_by_role("button", name=button, exact=True).is_enabled(), button
        assert b.page_text(page, "#messages") == ""
        page.get_by_role("button", name="Step", exact=True).click()
        assert re.match(r"iteration 1 · adjust · ", b.settled_status(page, s1))
        final = run_to_the_end(page)
        assert "converged" in final and b.page_text(page, "#messages") == "", \
            b.page_text(page, "#messages")
        b.save(page, "browser-layered-run")
