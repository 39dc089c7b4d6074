"""The Jupyter widget (static pictures, no kernel) on a conductivity field: the `rotating`
preset shows its label instead of the Q controls, Q(x) as ellipses in the first picture under
its own title, and Run ends at the certified mesh."""

import io

import numpy as np
import pytest
from PIL import Image

import qmesh
import qmesh_view
from lab_browser import drawn
from qmesh_view import legend
from qmesh_view.controller import status_text

SIZE = (240, 220)


@pytest.fixture
def view():
    w = qmesh_view.widget(backend="static", view_size=SIZE)
    yield w
    w.close()


def pictures(w) -> dict:
    return {name: np.asarray(Image.open(io.BytesIO(image.value)).convert("RGB"))
            for name, image in w.view_widgets.items()}


def coloured(image: np.ndarray, spread: int = 60) -> float:
    rgb = image.astype(int)
    return float(np.mean(rgb.max(axis=-1) - rgb.min(axis=-1) > spread))


def test_the_rotating_field_in_the_widget(view):
    assert legend.VIEW_TITLES["lifted"] in view.titles["lifted"].value
    view.sliders["domain"].value = "rotating"
    c = view.controller
    assert c.params.domain == "rotating" and isinstance(c.anisotropy, qmesh.TensorField)
    assert view._constant_box.layout.display == "none" and view._s_box.layout.display == "none"
    assert view.sliders["q_mode"].layout.display == "none"
    assert "FVCA5 test 5" in view.media_readout.value
    assert legend.FIELD_TITLE in view.titles["lifted"].value
    assert "ellipses" in view.legends["lifted"].value
    images = pictures(view)
    assert all(drawn(img) for img in images.values())
    assert coloured(images["lifted"]) > 0.01                  # the ellipses
    view.buttons["run"].click()
    assert c.at_end and c.current.mesh.conductivity is not None
    assert view.status.value == status_text(c.status()) and "converged" in view.status.value
    assert "with the element means: 100.0%" in view.status.value
    assert "certified" in view.legends["quality"].value
    view.sliders["domain"].value = "disk"
    assert legend.VIEW_TITLES["lifted"] in view.titles["lifted"].value
    assert "ellipses" not in view.legends["lifted"].value


def counts(html: str) -> dict:
    """The legend's two counts, read from its words: {"mesh": n, "isotropic": n}."""
    import re
    return {key: int(re.search(rf"class='mp-{key}'><b>[^<]*: (\d+) vertices? outside \[0, 1\]",
                               html).group(1)) for key in ("mesh", "isotropic")}


def test_the_maximum_principle_toggle_in_the_widget(view):
    """On the rotating preset's certified mesh the quality view shows u_h with no vertex outside
    [0, 1]; the isotropic mesh of the same N has some, and the picture changes to show it."""
    view.sliders["domain"].value = "rotating"
    view.buttons["run"].click()
    assert view.isotropic.layout.display == "none"              # hidden with the quality
    quality = pictures(view)["quality"]
    view.quality_view.value = "solution"
    assert view.isotropic.layout.display is None
    assert view.titles["quality"].value == f"<b>{legend.SOLUTION_TITLES['mesh']}</b>"
    own = pictures(view)["quality"]
    assert drawn(own) and np.abs(own.astype(int) - quality.astype(int)).mean() > 0.5
    n = counts(view.legends["quality"].value)
    assert n["mesh"] == 0 and n["isotropic"] > 0
    view.isotropic.value = True
    assert view.titles["quality"].value == f"<b>{legend.SOLUTION_TITLES['isotropic']}</b>"
    iso = pictures(view)["quality"]
    assert drawn(iso) and np.abs(iso.astype(int) - own.astype(int)).mean() > 0.5
    assert counts(view.legends["quality"].value) == n
    view.quality_view.value = "quality"
    assert view.titles["quality"].value == f"<b>{legend.VIEW_TITLES['quality']}</b>"
    assert "outside [0, 1]" not in view.legends["quality"].value
