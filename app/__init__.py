"""qmesh_view — the PyVista/trame front end of qmesh (issue 4).

`scene` turns a mesher Step into PyVista meshes for the three views, `draw` puts them on
plotters, `controller` steps Algorithm 2.1 and keeps the history, `app` is the trame web GUI
and `cli` its `qmesh-view` command. Only `app` and `cli` import trame.
"""

__all__ = ["scene", "draw", "controller"]
