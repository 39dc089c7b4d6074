"""The maximum principle in the real app: `qmesh-view --server --domain rotating` in Debian's
Chromium. Run to the certified mesh, show u_h in the quality view: no vertex of qmesh's mesh lies
outside [0, 1], some of the isotropic mesh of the same N do, both counts read from the page.
The page's screenshots go to test-artifacts/."""

import re

import numpy as np
import pytest
import view_browser as b
from headless_browser import drawn

from qmesh_view import draw

pytestmark = pytest.mark.browser      # shares the worker's Chromium (tests/conftest.py)


def counts(text: str) -> dict:
    """The legend's counts in words: {"qmesh": n, "isotropic": n}."""
    found = {key: re.search(rf"{what}, N = (\d+): (\d+) vertices? outside \[0, 1\]", text)
             for key, what in (("qmesh", "qmesh's mesh"), ("isotropic", "isotropic Delaunay mesh"))}
    assert all(found.values()), text
    assert found["qmesh"].group(1) == found["isotropic"].group(1), text     # the same N
    return {key: int(m.group(2)) for key, m in found.items()}


def near(image: np.ndarray, colour: str, tol: int = 25) -> int:
    rgb = image[..., :3].astype(int)
    target = np.array([int(colour[i:i + 2], 16) for i in (1, 3, 5)])
    return int(np.sum(np.abs(rgb - target).max(axis=-1) < tol))


@pytest.mark.slow(60)
def test_the_maximum_principle_on_the_rotating_preset():
    with (b.qmesh_view_server("--domain", "rotating") as url,
          b.chromium_page(url, viewport=(1400, 800)) as page):
        b.wait_drawn(page)
        b.wait_idle(page)
        assert not page.locator("#switch-isotropic").is_visible()
        page.get_by_role("button", name="Run", exact=True).click()
        b.until(lambda: "converged" in b.status(page), 60, "the run to converge")
        b.wait_idle(page)
        b.until(lambda: "element means: –%" not in b.status(page), 60, "the measures")
        quality = b.view_image(page, "quality")

        page.locator("#select-colour-by .v-field").click()
        page.get_by_role("option", name="maximum principle: u_h").click()
        own = b.wait_view_change(page, "quality", quality)
        b.until(lambda: "outside [0, 1]" in b.page_text(page, "#legend-quality"), 30,
                "the maximum principle's legend")
        assert b.page_text(page, "#title-quality").startswith("maximum principle")
        legend = b.page_text(page, "#legend-quality")
        n = counts(legend)
        assert n["qmesh"] == 0 and n["isotropic"] > 0, legend
        assert "x < 0.5" in legend and "beyond 1e-09" in legend
        assert drawn(own) and all(near(own, c) == 0 for c in (*draw.ABOVE, *draw.BELOW))
        b.save(page, "maximum-principle-qmesh")

        page.locator("#switch-isotropic input").check()
        iso = b.wait_view_change(page, "quality", own)
        b.until(lambda: "isotropic mesh" in b.page_text(page, "#title-quality"), 30,
                "the isotropic mesh's title")
        assert counts(b.page_text(page, "#legend-quality")) == n
        # the view may arrive in two renders (the mesh, then its marks): wait for the marks
        b.until(lambda: near(b.view_image(page, "quality"), draw.ABOVE[0])
                + near(b.view_image(page, "quality"), draw.BELOW[0]) > 0, 30, "the isotropic mesh's marks")
        iso = b.view_image(page, "quality")
        assert drawn(iso) and near(iso, draw.ABOVE[0]) + near(iso, draw.BELOW[0]) > 0
        assert "converged" in b.status(page)                # nothing re-meshed
        b.save(page, "maximum-principle-isotropic")
