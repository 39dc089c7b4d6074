"""Headless set-up for the widget's tests (HEADLESS.md "Environment"), before pyvista loads.

The environment is inherited by the kernels nbclient and JupyterLab start. Nothing here
skips: a missing ipywidgets, nbclient, JupyterLab, Playwright or Chromium makes the tests fail.
"""

import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
if "VTK_WASM_DIR_OVERRIDE" not in os.environ:
    os.environ["VTK_WASM_DIR_OVERRIDE"] = tempfile.mkdtemp(prefix="qmesh-widget-wasm-")
sys.path.insert(0, str(Path(__file__).resolve().parent))    # lab_browser

import pyvista  # noqa: E402,F401  (fail at collection when missing)
