"""Headless set-up for the viewer's tests (HEADLESS.md "Environment"), before pyvista loads.

Nothing here skips: a missing pyvista, trame, Playwright or Chromium makes the tests fail.
"""

import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
if "VTK_WASM_DIR_OVERRIDE" not in os.environ:
    os.environ["VTK_WASM_DIR_OVERRIDE"] = tempfile.mkdtemp(prefix="qmesh-view-wasm-")
sys.path.insert(0, str(Path(__file__).resolve().parent))    # view_cases, view_browser

import pytest  # noqa: E402
import pyvista  # noqa: E402,F401  (fail at collection when missing)

import view_cases  # noqa: E402


@pytest.fixture(scope="session")
def chapter_run():
    """The chapter's case run to its end once: Q = diag(0.1, 10), VB = 64, target 212, seed 0."""
    return view_cases.finished_run()


@pytest.fixture(scope="session")
def steps(chapter_run):
    """Named Steps of the chapter's run: first triangulation, first adjust/insert, final."""
    return {"triangulate0": chapter_run.history[0],
            "adjust1": view_cases.pick(chapter_run, "adjust1"),
            "insert1": view_cases.pick(chapter_run, "insert1"),
            "final": view_cases.pick(chapter_run, "final")}
