"""Off-screen renders of the three views match the baselines in screenshots/, and a changed Q does not.

Baselines are written by `python tests/view/make_baselines.py` (look at them after!). The error is
`pyvista.compare_images` (vtkImageDifference); identical renders give 0 on one machine, the
tolerance `MAX_ERROR` absorbs small rasteriser differences between machines. Every render is
also saved under test-artifacts/ to look at when a comparison fails.
"""

import numpy as np
import pytest
import pyvista as pv
from PIL import Image

import view_cases as vc
from headless_browser import drawn

REGENERATE = "regenerate with `python tests/view/make_baselines.py` and look at the images"


def _baseline(name):
    path = vc.BASELINES / f"{name}.png"
    assert path.exists(), f"missing baseline {path}; {REGENERATE}"
    return path


def _save(image, name):
    vc.ARTIFACTS.mkdir(exist_ok=True)
    Image.fromarray(image).save(vc.ARTIFACTS / f"{name}.png")


@pytest.fixture(scope="module")
def changed_q_run():
    """The chapter's case with Q22 = 5 instead of 10: a different anisotropy, a different mesh."""
    return vc.finished_run(k2=5.0)


@pytest.mark.parametrize("name", list(vc.CASES))
def test_render_matches_baseline(chapter_run, name):
    image = vc.render_case(chapter_run, name)
    _save(image, name)
    assert drawn(image), f"{name}: the render is blank"
    baseline = _baseline(name)
    assert drawn(np.asarray(Image.open(baseline).convert("RGB"))), f"{baseline} is blank"
    error = pv.compare_images(image, str(baseline))
    assert error <= vc.MAX_ERROR, (f"{name}: image error {error:.0f} > {vc.MAX_ERROR:.0f} "
                                   f"(render in test-artifacts/{name}.png); if the change is "
                                   f"intended, {REGENERATE}")


@pytest.mark.parametrize("name", ["chapter_final_lifted", "chapter_final_mesh",
                                  "chapter_final_quality"])
def test_changed_q_does_not_match_baseline(changed_q_run, name):
    image = vc.render_case(changed_q_run, name)
    _save(image, f"changed_q_{name}")
    assert drawn(image)
    assert pv.compare_images(image, str(_baseline(name))) > vc.MAX_ERROR


def test_blank_image_does_not_match_baseline():
    baseline = _baseline("chapter_final_mesh")
    blank = np.full_like(np.asarray(Image.open(baseline).convert("RGB")), 255)
    assert not drawn(blank)
    assert pv.compare_images(blank, str(baseline)) > vc.MAX_ERROR
