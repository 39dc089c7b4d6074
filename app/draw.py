"""Add the `qmesh_view.scene` meshes to PyVista plotters: one look for the app, widget and tests.

`ViewSet` holds the three plotters (lifted; mesh and quality with one shared camera) and redraws
them from a Step; `render_views` draws a Step once off-screen and returns the images.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv

from . import scene

BACKGROUND = "white"
MESH_FACE = "#e9edf2"
EDGE = "#2b2b2b"
FIXED = "#d62728"          # seed boundary vertices
ADDED = "#ff7f0e"          # points inserted by the last insert stage
ARROW = "#1f5fbf"          # displacements of the last adjust stage
SURFACE = "#9ecae1"        # the smooth s(x)
FACET = "#fdae6b"          # the facets of s_h
# edges by the sign of q_ij: (actor name, q_sign value, colour, line width); negatives stand out
Q_SIGN_LINES = (("q_boundary", 0, "#7f7f7f", 1), ("q_positive", 1, "#1a7f37", 1),
                ("q_negative", -1, "#e31a1c", 4))
QUALITY_CMAP = "viridis"
SCALAR_TITLES = {"quality": "quality", "metric_area": "metric area"}
VIEWS = ("lifted", "mesh", "quality")
WINDOW_SIZE = (520, 480)
SPHERE_LIMIT = 2000        # above this many lifted vertices, flat points (spheres cost ~40% more)


def _put(plotter: pv.Plotter, name: str, mesh: pv.PolyData | None, **kwargs) -> None:
    """Add `mesh` under `name`, replacing the actor of that name; drop it when mesh is empty."""
    if mesh is None or mesh.n_points == 0:
        plotter.remove_actor(name, render=False)
        return
    plotter.add_mesh(mesh, name=name, reset_camera=False, render=False, **kwargs)


def draw_lifted(plotter: pv.Plotter, view: scene.LiftedScene) -> None:
    """The translucent s(x), the lifted vertices, the s_h facets with their edges."""
    _put(plotter, "surface", view.surface, color=SURFACE, opacity=0.3, ambient=0.5,
         show_scalar_bar=False)
    _put(plotter, "facets", view.facets, color=FACET, ambient=0.3, show_edges=True, edge_color=EDGE,
         line_width=1, show_scalar_bar=False)
    many = view.vertices.n_points > SPHERE_LIMIT
    _put(plotter, "vertices", view.vertices, color=EDGE, point_size=3 if many else 5,
         render_points_as_spheres=not many, show_scalar_bar=False)


def draw_projected(plotter: pv.Plotter, view: scene.ProjectedScene) -> None:
    """The plane mesh with edges, seeds, inserted points and displacement arrows."""
    _put(plotter, "mesh", view.mesh, color=MESH_FACE, show_edges=True, edge_color=EDGE,
         line_width=1, lighting=False, show_scalar_bar=False)
    _put(plotter, "arrows", view.arrows, color=ARROW, line_width=2, show_scalar_bar=False)
    _put(plotter, "added", view.added, color=ADDED, point_size=9,
         render_points_as_spheres=True, show_scalar_bar=False)
    _put(plotter, "fixed", view.fixed, color=FIXED, point_size=7,
         render_points_as_spheres=True, show_scalar_bar=False)


def draw_quality(plotter: pv.Plotter, view: scene.QualityScene) -> None:
    """Triangles coloured by the chosen cell scalar with a scalar bar, optional q_ij-sign edges."""
    title = SCALAR_TITLES[view.scalars]
    for other in set(plotter.scalar_bars.keys()) - {title}:
        plotter.remove_scalar_bar(other, render=False)
    _put(plotter, "triangles", view.triangles, scalars=view.scalars, preference="cell",
         cmap=QUALITY_CMAP, clim=view.clim, show_edges=view.edges is None, edge_color=EDGE,
         lighting=False, scalar_bar_args={"title": title, "vertical": True,
                                          "position_x": 0.86, "position_y": 0.2,
                                          "width": 0.05, "height": 0.6, "color": "black",
                                          "n_labels": 3, "fmt": "%.2g",
                                          "title_font_size": 12, "label_font_size": 11})
    edges = None
    if view.edges is not None:
        edges = view.edges.copy()
        edges.points[:, 2] = 1e-3 * max(edges.length, 1.0)   # just above the triangles
    sign = None if edges is None else edges.cell_data["q_sign"]
    for name, value, colour, width in Q_SIGN_LINES:
        part = None if edges is None else edges.extract_cells(np.flatnonzero(sign == value))
        _put(plotter, name, part, color=colour, line_width=width, show_scalar_bar=False)


def new_plotter(window_size=WINDOW_SIZE) -> pv.Plotter:
    """An off-screen plotter without multisampling: MSAA costs ~4× per frame on llvmpipe."""
    plotter = pv.Plotter(off_screen=True, window_size=list(window_size))
    plotter.render_window.SetMultiSamples(0)
    plotter.set_background(BACKGROUND)
    return plotter


class ViewSet:
    """The three plotters of the app and widget, redrawn from one Step at a time.

    The mesh and quality views share one vtkCamera, so moving one moves the other.
    Cameras are reset on the first draw and on `reset_cameras()`, not on every step, so a
    user's zoom survives stepping through the algorithm.
    """

    def __init__(self, window_size=WINDOW_SIZE):
        self.plotters = {name: new_plotter(window_size) for name in VIEWS}
        self.plotters["quality"].renderer.camera = self.plotters["mesh"].renderer.camera
        self._drawn = False
        self._z_scale = None

    def draw(self, step, anisotropy, *, z_scale: float = 1.0, colour_by: str = "quality",
             q_sign_edges: bool = False, domain=None, arrow_scale: float = 1.0) -> None:
        p = self.plotters
        draw_lifted(p["lifted"], scene.lifted(step, anisotropy, z_scale, domain=domain))
        draw_projected(p["mesh"], scene.projected(step, arrow_scale=arrow_scale))
        draw_quality(p["quality"], scene.quality(step, anisotropy, colour_by, q_sign_edges))
        if not self._drawn:
            self.reset_cameras()
            self._drawn = True
        elif z_scale != self._z_scale:
            self.fit_lifted()
        self._z_scale = z_scale

    def reset_cameras(self) -> None:
        """Lifted: seen from below, where the lower hull faces (s_h ≥ s lies behind the
        translucent s); mesh and quality: top-down with a parallel projection."""
        self.plotters["lifted"].view_vector((0.9, -1.7, -0.7), viewup=(0, 0, 1))
        self.fit_lifted()
        top = self.plotters["mesh"]
        top.enable_parallel_projection()
        self.plotters["quality"].enable_parallel_projection()
        top.view_xy(render=False)
        top.reset_camera(render=False)
        top.camera.zoom(0.9)

    def fit_lifted(self) -> None:
        """Fit the lifted view to its scene, keeping its direction (after a z-scale change)."""
        lifted = self.plotters["lifted"]
        lifted.reset_camera(render=False)
        lifted.camera.zoom(1.2)

    def render(self) -> None:
        """Render all three windows now.

        The VTK call itself: pyvista's `render()` does nothing on a plotter never shown.
        """
        for p in self.plotters.values():
            p.render_window.Render()

    def images(self) -> dict:
        """RGB screenshots {"lifted", "mesh", "quality"} → (h, w, 3) uint8 of the current scene."""
        self.render()
        return {name: np.asarray(p.screenshot(return_img=True))
                for name, p in self.plotters.items()}

    def close(self) -> None:
        for p in self.plotters.values():
            p.close()


def render_views(step, anisotropy, *, window_size=WINDOW_SIZE, **options) -> dict:
    """Draw `step` off-screen once: {"lifted", "mesh", "quality"} → RGB arrays (h, w, 3).

    `options` are those of `ViewSet.draw`: z_scale, colour_by, q_sign_edges, domain, arrow_scale.
    """
    views = ViewSet(window_size)
    try:
        views.draw(step, anisotropy, **options)
        return views.images()
    finally:
        views.close()
