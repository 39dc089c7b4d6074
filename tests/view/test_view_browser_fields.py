"""A conductivity field in the real app: `qmesh-view --server` on 127.0.0.1 in Debian's Chromium.
Pick `rotating` (FVCA5 test 5), Run to the certified mesh, and see the ellipses and the mesh.
The page's screenshot goes to test-artifacts/ (screenshots/field_rotating.png is one kept)."""

import re

import numpy as np
import pytest
import view_browser as b
from headless_browser import drawn
from view_cases import ARTIFACTS

pytestmark = pytest.mark.browser      # shares the worker's Chromium (tests/conftest.py)


def coloured(image: np.ndarray, spread: int = 60) -> float:
    """Share of coloured pixels (not white, grey or black): the ellipses, not the mesh."""
    rgb = np.asarray(image)[..., :3].astype(int)
    return float(np.mean(rgb.max(axis=-1) - rgb.min(axis=-1) > spread))


@pytest.mark.slow(40)
def test_picking_rotating_runs_and_shows_ellipses_and_the_mesh():
    with b.qmesh_view_server() as url, b.chromium_page(url, viewport=(1400, 800)) as page:
        start = b.wait_drawn(page)
        b.wait_idle(page)
        s0 = b.status(page)
        assert coloured(start["lifted"]) < 0.5 and "lifted" in b.page_text(page, "#title-lifted")
        page.locator("#select-domain .v-field").click()
        page.get_by_role("option", name="rotating", exact=True).click()
        s1 = b.settled_status(page, s0)
        assert re.match(r"iteration 0 · triangulate · N = \d+", s1), s1
        assert "E = " not in s1 and "q_ij ≥ 0 with the element means" in s1
        first = {name: b.wait_view_change(page, name, start[name]) for name in b.VIEWS}
        assert b.page_text(page, "#title-lifted").startswith("Q(x) as ellipses over the mesh")
        readout = b.page_text(page, "#media-readout")
        assert "do not apply" in readout and "FVCA5 test 5" in readout
        assert not page.locator("#q-readout").is_visible()          # no Q sliders apply
        assert not page.locator("#slider-z_scale").is_visible()     # no surface to scale
        assert "ellipses" in b.page_text(page, "#legend-lifted")
        # Q's larger eigenvalue is 1 everywhere: one colour said in words, no colour bar
        assert "one colour" in b.page_text(page, "#legend-lifted")
        assert not page.locator("#legend-lifted .legend-colour-bar").count()
        assert page.locator("#field-target input").input_value() == "500"   # its own target

        page.get_by_role("button", name="Run", exact=True).click()
        b.until(lambda: "converged" in b.status(page) or None, 60, "the run to converge")
        b.wait_idle(page)
        # the measures (quality and q_ij in the element means, κ2) follow the mesh: "–" until then
        final = b.until(lambda: (lambda s: s if "element means: –%" not in s else None)(b.status(page)),
                        60, "the certified mesh's measures")
        assert "q_ij ≥ 0 with the element means: 100.0%" in final, final
        shown = {name: b.wait_view_change(page, name, first[name], min_diff=0.3)
                 for name in ("mesh", "quality")}
        lifted = b.view_image(page, "lifted")
        assert drawn(lifted) and all(drawn(img) for img in shown.values())
        assert coloured(lifted) > 0.01                                # the ellipses
        rgb = lifted.astype(int)
        grey = (rgb.max(axis=-1) - rgb.min(axis=-1) < 12) & (rgb.max(axis=-1) < 200)
        assert grey.mean() > 0.005                                     # the mesh under them
        assert "certified" in b.page_text(page, "#legend-quality")
        assert "none: no s" in b.page_text(page, "#chart")              # no energy to chart
        assert b.page_text(page, "#no-energy") == "a field has no s: no energy"
        assert b.page_text(page, "#messages") == ""       # no warning at its default target
        ARTIFACTS.mkdir(exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / "field_rotating.png"))

        # a stage the Run meshed while the views drew another has its element means computed
        # when it is shown: scrubbed to, its quality view, status line and legend follow
        before = b.view_image(page, "quality")
        thumb = page.locator("#slider-history_index .v-slider-thumb")
        thumb.focus()
        page.keyboard.press("ArrowLeft")
        back = b.until(lambda: (lambda s: s if "converged" not in s and "means: –%" not in s
                                else None)(b.status(page)), 60, "the stage before's measures")
        assert re.search(r"q_ij ≥ 0 with the element means: \d+\.\d%", back), back
        assert re.search(r"quality min \d\.\d{3} mean \d\.\d{3}", back), back
        b.wait_view_change(page, "quality", before, min_diff=0.3)
        legend = b.page_text(page, "#legend-quality")
        assert "computed from the field on this stage's mesh" in legend, legend
