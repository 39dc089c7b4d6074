"""The screenshot cases: which Step of the chapter's run is drawn how, and where its baseline lives.

Shared by `test_view_screenshots.py` (compare) and `make_baselines.py` (write), so both draw exactly
the same thing. The chapter's case (2.95): Q = diag(0.1, 10), the 64-gon, target 212, seed 0.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from qmesh_view.controller import Controller
from qmesh_view.draw import render_views

ROOT = Path(__file__).resolve().parents[2]
BASELINES = ROOT / "screenshots"
ARTIFACTS = ROOT / "test-artifacts"
WINDOW = (400, 400)

# name → (which step of the run, which view, draw options)
CASES = {
    "chapter_final_lifted": ("final", "lifted", {}),
    "chapter_final_mesh": ("final", "mesh", {}),
    "chapter_final_quality": ("final", "quality", {}),
    "chapter_adjust1_mesh": ("adjust1", "mesh", {}),
    "chapter_insert1_mesh": ("insert1", "mesh", {}),
    "chapter_adjust1_area_qsign": ("adjust1", "quality",
                                   {"colour_by": "metric_area", "q_sign_edges": True}),
    "chapter_final_solution": ("final", "quality", {"colour_by": "solution"}),
    "chapter_final_solution_isotropic": ("final", "quality",
                                         {"colour_by": "solution", "isotropic": True}),
}

MAX_ERROR = 500.0
"""Largest `pyvista.compare_images` error accepted against a baseline (see test_view_screenshots)."""


def finished_run(**params) -> Controller:
    """A controller that has run the chapter's case (or `params` changed) to its end."""
    c = Controller(**params)
    c.finish()
    return c


def pick(controller: Controller, which: str):
    """The Step named by a case: the final one, or the first adjust/insert stage of iteration 1."""
    if which == "final":
        return controller.history[-1]
    stage, iteration = which[:-1], int(which[-1])
    return next(s for s in controller.history if s.stage == stage and s.iteration == iteration)


_rendered: dict = {}


def render_case(controller: Controller, name: str) -> np.ndarray:
    """The case's view of its Step; the three views of one Step and options are drawn once."""
    which, view, options = CASES[name]
    key = (id(controller), which, tuple(sorted(options.items())))
    if key not in _rendered:
        _rendered[key] = (controller, render_views(
            pick(controller, which), controller.anisotropy, window_size=WINDOW,
            domain=controller.domain, **options))
    return _rendered[key][1][view]


