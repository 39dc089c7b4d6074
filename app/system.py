"""The system libraries off-screen rendering needs, checked before VTK is asked to render.

VTK's wheels render off-screen through EGL with Mesa's software rasteriser. Without libEGL or
libGL, VTK crashes the whole process (a segfault, exit 139) the first time it renders; so every
entry point that renders (`qmesh-view`, the widget, the scene and draw functions) calls
`require_rendering()` first and gets one `MissingSystemLibrary` error naming the Debian package
to install instead. `headless_environment()` picks EGL before VTK is imported, so VTK never tries
an X server (the `vtkXOpenGLRenderWindow … bad X server connection` message in notebooks).
"""

from __future__ import annotations

import ctypes.util
import glob
import os
import tempfile

from qmesh.errors import QmeshError
from qmesh.setup import GROUPS

_RENDERING = next(g for g in GROUPS if g.name == "rendering")   # what `qmesh setup` installs
# (library name for ctypes.util.find_library, Debian package that provides it): EGL, GL
LIBRARIES = tuple(zip(_RENDERING.libraries, _RENDERING.packages))
DRI_PACKAGE = _RENDERING.packages[len(_RENDERING.libraries)]     # Mesa's DRI drivers
DRI_GLOBS = ("/usr/lib/*/dri/swrast_dri.so", "/usr/lib/dri/swrast_dri.so",
             "/usr/lib64/dri/swrast_dri.so", "/usr/lib/*/dri/libdril_dri.so")

find_library = ctypes.util.find_library
"""The finder used for LIBRARIES (a module attribute so tests can simulate a missing library)."""


class MissingSystemLibrary(QmeshError):
    """A system library needed for rendering is not installed; the message names its package."""


def headless_environment() -> None:
    """Off-screen EGL rendering, and no attempt to download VTK's WebAssembly build.

    `setdefault`: a user's own choice of window type wins. Must run before VTK is imported.
    """
    os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    if "VTK_WASM_DIR_OVERRIDE" not in os.environ:
        os.environ["VTK_WASM_DIR_OVERRIDE"] = tempfile.mkdtemp(prefix="qmesh-view-wasm-")


def dri_driver_found() -> bool:
    """True when Mesa's software rasteriser (the DRI driver EGL loads) is installed."""
    return any(glob.glob(pattern) for pattern in DRI_GLOBS)


def missing_packages() -> list[str]:
    """Debian packages whose libraries off-screen rendering needs and cannot find, in order."""
    missing = [package for name, package in LIBRARIES if not find_library(name)]
    if not dri_driver_found():
        missing.append(DRI_PACKAGE)
    return missing


_ready = False


def require_rendering() -> None:
    """Raise MissingSystemLibrary (before VTK can crash) when a rendering library is missing."""
    global _ready
    if _ready:
        return
    missing = missing_packages()
    if missing:
        raise MissingSystemLibrary(
            "off-screen rendering needs system libraries that are missing; install them with "
            f"`sudo apt-get install {' '.join(missing)}` (Debian/Ubuntu package names)")
    _ready = True
