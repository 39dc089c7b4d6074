"""qmesh_view — the PyVista/trame front end of qmesh (issue 4).

`scene` turns a mesher Step into PyVista meshes for the three views, `draw` puts them on
plotters, `controller` steps Algorithm 2.1 and keeps the history, `app` is the trame web GUI
and `cli` its `qmesh-view` command, `widget` the Jupyter widget (ipywidgets). `legend` writes
the views' legends, `delivery` speeds up server-rendered frames, `system` checks the rendering
libraries and picks EGL before VTK loads. Only `app`, `cli` and the widget's live (trame)
backend import trame.
"""

from .system import headless_environment as _headless_environment

_headless_environment()          # before anything imports VTK: EGL, never an X server

__all__ = ["scene", "draw", "controller", "widget", "system"]


def __getattr__(name):
    """`qmesh_view.widget` (the Jupyter widget, a callable module) loads on first use."""
    if name == "widget":
        import importlib
        return importlib.import_module(f"{__name__}.widget")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
