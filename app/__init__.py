"""qmesh_view — the PyVista/trame front end of qmesh.

`session` is the one UI-neutral source of truth (parameters in force, the run, the outcome of
every change, the memory budget, the messages) that `app` (the trame web GUI, `cli` its
`qmesh-view` command) and `widget` (the Jupyter widget, ipywidgets) bind their controls to;
`controller` is one run of Algorithm 2.1 and its history, `problem` the domain and conductivity
of a parameter set. `scene` turns a mesher Step into PyVista meshes for the three views, `draw`
puts them on plotters. `legend` writes
the views' legends, `delivery` speeds up server-rendered frames, `system` checks the rendering
libraries and picks EGL before VTK loads. Only `app`, `cli` and the widget's live (trame)
backend import trame.
"""

from .system import headless_environment as _headless_environment

_headless_environment()          # before anything imports VTK: EGL, never an X server

__all__ = ["session", "problem", "scene", "draw", "controller", "widget", "system"]


def __getattr__(name):
    """`qmesh_view.widget` (the Jupyter widget, a callable module) loads on first use."""
    if name == "widget":
        import importlib
        return importlib.import_module(f"{__name__}.widget")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
