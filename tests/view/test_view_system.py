"""A missing system library stops rendering with one message naming the Debian package, and
importing the viewer picks EGL before VTK can try an X server.

Absence is simulated: the library finder is replaced, so the real machine keeps its libraries.
"""

import os
import subprocess
import sys

import pytest

import qmesh_view
from qmesh.errors import QmeshError
from qmesh_view import draw, system


@pytest.fixture
def no_egl(monkeypatch):
    """Pretend libEGL is not installed (the finder answers None for it); forget the last check."""
    real = system.find_library
    monkeypatch.setattr(system, "find_library", lambda name: None if name == "EGL" else real(name))
    monkeypatch.setattr(system, "_ready", False)


def test_missing_egl_names_its_package_before_vtk_renders(no_egl, chapter_run):
    assert system.missing_packages() == ["libegl1"]
    for make in (lambda: draw.ViewSet(), draw.new_plotter,
                 lambda: draw.render_views(chapter_run.current, chapter_run.anisotropy)):
        with pytest.raises(system.MissingSystemLibrary, match=r"apt-get install libegl1`"):
            make()
    assert issubclass(system.MissingSystemLibrary, QmeshError)


def test_missing_mesa_driver_and_gl_are_all_named(monkeypatch):
    monkeypatch.setattr(system, "find_library", lambda name: None)
    monkeypatch.setattr(system, "dri_driver_found", lambda: False)
    monkeypatch.setattr(system, "_ready", False)
    with pytest.raises(system.MissingSystemLibrary) as e:
        system.require_rendering()
    assert "sudo apt-get install libegl1 libgl1 libgl1-mesa-dri" in str(e.value)


def test_the_widget_stops_with_the_message(no_egl):
    with pytest.raises(system.MissingSystemLibrary, match="libegl1"):
        qmesh_view.widget(backend="static")


def test_qmesh_view_prints_one_error_line_and_exits_2():
    """The command in a fresh process whose finder cannot see libEGL: exit 2, no segfault."""
    code = ("import sys, qmesh_view.system as s; s.find_library = lambda name: None; "
            "from qmesh_view.cli import main; sys.exit(main(['--server', '--port', '0']))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("qmesh-view: error: ")
    assert "libegl1" in lines[0] and "libgl1" in lines[0]


def test_importing_the_viewer_chooses_egl_so_vtk_never_asks_for_an_x_server():
    """Without the environment set beforehand (as in a notebook): no X11 attempt, no warning."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("VTK_DEFAULT_OPENGL_WINDOW", "PYVISTA_OFF_SCREEN", "DISPLAY")}
    code = ("import qmesh_view.widget as W; w = W.widget(backend='static', view_size=(80, 80)); "
            "print(type(w.views.plotters['mesh'].render_window).__name__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().endswith("vtkEGLRenderWindow")
    assert "X server" not in out.stdout + out.stderr
    assert "vtkXOpenGLRenderWindow" not in out.stdout + out.stderr
