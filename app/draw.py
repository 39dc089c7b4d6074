"""Add the `qmesh_view.scene` meshes to PyVista plotters: one look for the app, widget and tests.

`ViewSet` holds the three plotters (lifted; mesh and quality with one shared camera) and redraws
them from a Step; `render_views` draws a Step once off-screen and returns the images.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv

from qmesh.errors import QmeshError

from . import scene, system
from .problem import means_source

BACKGROUND = "white"
MESH_FACE = "#e9edf2"
EDGE = "#2b2b2b"
FIXED = "#d62728"          # seed boundary vertices
ADDED = "#ff7f0e"          # points inserted by the last insert stage
ARROW = "#1f5fbf"          # displacements of the last adjust stage
SURFACE = "#9ecae1"        # the smooth s(x)
ELLIPSE_CMAP = "plasma"    # a field's ellipses by log10 of Q's larger eigenvalue
FIELD_EDGE = ("#8c8c8c", "#c4c4c4")   # the mesh under them, drawn / crowded: lighter than
#                                       elsewhere, so the ellipses stand out
FACET = "#fdae6b"          # the facets of s_h
# edges by the sign of q_ij: (actor name, q_sign value, colour, line width); negatives stand out
# (black and red stay visible on every colour of viridis, green vanished on its greens)
# interface edges of a medium (two triangles, two regions) with q_ij ≥ 0: thick magenta
Q_SIGN_LINES = (("q_boundary", 0, "#7f7f7f", 1), ("q_positive", 1, "#000000", 1),
                ("q_interface", 2, "#e7298a", 3), ("q_negative", -1, "#e31a1c", 4))
INTERFACE = "#e7298a"      # the region boundaries in the mesh view of a medium
SIZE_CMAP = "Blues_r"      # mesh view when edges are too dense: triangles by area (log)
QUALITY_CMAP = "viridis"
SCALAR_TITLES = {"quality": "quality", "metric_area": "metric area", "solution": "u_h"}
SOLUTION = "solution"      # the quality view's `colour_by` that shows the maximum principle
ABOVE = ("#e31a1c", "#fb9a99")   # vertices with u_h > 1, and the faces there: red on the
BELOW = ("#17becf", "#b6e8ee")   # colour map's yellow end; u_h < 0 cyan on its dark purple
VIEWS = ("lifted", "mesh", "quality")
EDGE_MODES = ("auto", "on", "off")
EDGE_FULL_PX = 6.0         # auto: edges drawn dark while a typical edge spans this many pixels,
EDGE_THIN_PX = 3.0         # light down to this many, hidden below (they would only darken faces)
EDGE_LIGHT = "#a0a0a0"
WINDOW_SIZE = (520, 480)
SPHERE_LIMIT = 2000        # above this many lifted vertices, flat points (spheres cost ~40% more)
MEDIUM_VIEW = (0.3, -1.0, 2.5)   # a medium's lifted pieces, seen obliquely from above


def _put(plotter: pv.Plotter, name: str, mesh: pv.PolyData | None, keep: bool = False,
         **kwargs) -> None:
    """Show `mesh` under `name`; drop the actor of that name when mesh is empty (hide it,
    emptied, when `keep`: a stage that shows it again reuses it).

    An actor drawn last time with the same options only gets the new data (its mapper's input):
    `add_mesh` would build a new actor, mapper and lookup table eleven times per frame. A new
    `point_size` is set on the actor's property, not a reason for a new actor.
    """
    looks = plotter.__dict__.setdefault("_qmesh_looks", {})
    actor = plotter.actors.get(name)
    if mesh is None or mesh.n_points == 0:
        if keep and actor is not None and name in looks:
            actor.mapper.SetInputData(pv.PolyData())
            actor.SetVisibility(False)
            return
        plotter.remove_actor(name, render=False)
        looks.pop(name, None)
        return
    size = kwargs.pop("point_size", None)
    look = repr(sorted(kwargs.items()))
    scalars = kwargs.get("scalars")
    if actor is not None and looks.get(name) == look and (
            scalars is None or scalars in mesh.cell_data or scalars in mesh.point_data):
        if scalars is not None:
            mesh.set_active_scalars(scalars, preference=kwargs.get("preference", "cell"))
        actor.mapper.SetInputData(mesh)
    else:
        plotter.add_mesh(mesh, name=name, reset_camera=False, render=False, **kwargs)
        looks[name] = look
        actor = plotter.actors[name]
    if size is not None:
        actor.GetProperty().SetPointSize(size)
    if keep:
        actor.SetVisibility(True)


def draw_lifted(plotter: pv.Plotter, view: scene.LiftedScene) -> None:
    """The translucent s(x), the lifted vertices, the s_h facets with their edges (a medium:
    no surface, each region's piece in its region's colour)."""
    for name in ("ellipses", "ellipse_outlines"):             # a field's, drawn before
        plotter.remove_actor(name, render=False)
        plotter.__dict__.get("_qmesh_looks", {}).pop(name, None)
    _put(plotter, "surface", view.surface, color=SURFACE, opacity=0.3, ambient=0.5,
         smooth_shading=True, show_scalar_bar=False)
    if "region_rgb" in view.facets.cell_data:
        _put(plotter, "facets", view.facets, scalars="region_rgb", rgb=True, preference="cell",
             ambient=0.3, show_edges=True, edge_color=EDGE, line_width=1, show_scalar_bar=False)
    else:
        _put(plotter, "facets", view.facets, color=FACET, ambient=0.3, show_edges=True,
             edge_color=EDGE, line_width=1, show_scalar_bar=False)
    many = view.vertices.n_points > SPHERE_LIMIT
    _put(plotter, "vertices", view.vertices, color=EDGE, point_size=3 if many else 5,
         render_points_as_spheres=not many, show_scalar_bar=False)


def draw_field(plotter: pv.Plotter, view: scene.FieldScene) -> None:
    """A field's first view: the flat mesh (faces light, edges as the other views) and Q(x) as
    ellipses above it, filled by log10 of Q's larger eigenvalue, outlined; no surface, no
    lifted vertices."""
    plotter.remove_actor("surface", render=False)
    plotter.remove_actor("vertices", render=False)
    plotter.__dict__.get("_qmesh_looks", {}).pop("surface", None)
    plotter.__dict__.get("_qmesh_looks", {}).pop("vertices", None)
    _put(plotter, "facets", view.mesh, color="white", show_edges=True,
         edge_color=FIELD_EDGE[0], line_width=1, lighting=False, show_scalar_bar=False)
    _put(plotter, "ellipses", view.ellipses, scalars="log10_k_max", preference="cell",
         cmap=ELLIPSE_CMAP, clim=view.clim, lighting=False, show_scalar_bar=False)
    _put(plotter, "ellipse_outlines", view.outlines, scalars="log10_k_max", preference="cell",
         cmap=ELLIPSE_CMAP, clim=view.clim, line_width=3, lighting=False,
         show_scalar_bar=False)


def draw_projected(plotter: pv.Plotter, view: scene.ProjectedScene) -> None:
    """The plane mesh with edges, seeds, inserted points and displacement arrows; a medium's
    triangles in their region's colour, its interfaces as thick lines."""
    by_region = "region_rgb" in view.mesh.cell_data
    if by_region:
        _put(plotter, "mesh", view.mesh, scalars="region_rgb", rgb=True, preference="cell",
             show_edges=True, edge_color=EDGE, line_width=1, lighting=False,
             show_scalar_bar=False)
    else:
        _put(plotter, "mesh", view.mesh, scalars="log_area", preference="cell", cmap=SIZE_CMAP,
             show_edges=True, edge_color=EDGE, line_width=1, lighting=False,
             show_scalar_bar=False)
    _put(plotter, "interfaces", view.interfaces, color=INTERFACE, line_width=3,
         show_scalar_bar=False)
    actor = plotter.actors.get("mesh")
    if actor is not None and not by_region and "log_area" in view.mesh.cell_data:
        a = view.mesh.cell_data["log_area"]
        lo, hi = float(a.min()), float(a.max())
        actor.mapper.SetScalarRange(lo - 0.25, hi + 0.25 if hi > lo else lo + 1.0)
    _put(plotter, "sample", view.sample, color=EDGE, line_width=1, show_scalar_bar=False)
    _put(plotter, "arrows", view.arrows, keep=True, color=ARROW, line_width=2,
         show_scalar_bar=False)                         # adjust stages only
    _put(plotter, "added", view.added, keep=True, color=ADDED,     # insert stages only
         point_size=marker_size(view.added.n_points, 9), render_points_as_spheres=True,
         show_scalar_bar=False)
    _put(plotter, "fixed", view.fixed, color=FIXED, point_size=marker_size(view.fixed.n_points, 7),
         render_points_as_spheres=True, show_scalar_bar=False)


MARKERS_FULL = 200         # up to this many markers at full size; more shrink as 1/√n to 3 px


def marker_size(n: int, full: float) -> float:
    """Pixel size of `n` point markers: `full` for a few, shrinking as 1/√n (the area they
    cover stays about the same) down to 3 px, so thousands of them leave the mesh visible."""
    return float(np.clip(full * np.sqrt(MARKERS_FULL / max(n, 1)), 3.0, full))


def draw_quality(plotter: pv.Plotter, view: scene.QualityScene,
                 scalar_bar: bool = True) -> None:
    """Triangles coloured by the chosen cell scalar, optional q_ij-sign edges.

    `scalar_bar=False` leaves the legend to the page (the app and the widget draw it beside
    the view, where it never covers the mesh); still images keep VTK's bar at the right edge.
    """
    for name in ("below", "above"):                     # the maximum principle's markers
        _put(plotter, name, None)
    title = SCALAR_TITLES[view.scalars]
    keep = {title} if scalar_bar and plotter.__dict__.get("_qmesh_clim") == view.clim else set()
    for other in set(plotter.scalar_bars.keys()) - keep:     # a bar keeps its first range
        plotter.remove_scalar_bar(other, render=False)
    plotter.__dict__["_qmesh_clim"] = view.clim
    _put(plotter, "triangles", view.triangles, scalars=view.scalars, preference="cell",
         cmap=QUALITY_CMAP, clim=view.clim, show_edges=view.edges is None, edge_color=EDGE,
         lighting=False, show_scalar_bar=scalar_bar,
         scalar_bar_args={"title": title, "vertical": True,
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


def draw_solution(plotter: pv.Plotter, view: scene.SolutionScene,
                  scalar_bar: bool = True) -> None:
    """u_h on the mesh shown (viridis on [0, 1], beyond it a light `ABOVE` or `BELOW`) and the
    vertices outside [0, 1] as dots in their darker colour."""
    title = SCALAR_TITLES[SOLUTION]
    for other in set(plotter.scalar_bars.keys()) - ({title} if scalar_bar else set()):
        plotter.remove_scalar_bar(other, render=False)
    plotter.__dict__["_qmesh_clim"] = (0.0, 1.0)
    for name, *_ in Q_SIGN_LINES:
        _put(plotter, name, None)
    _put(plotter, "triangles", view.triangles, scalars="u_h", preference="point",
         cmap=QUALITY_CMAP, clim=(0.0, 1.0), above_color=ABOVE[1], below_color=BELOW[1],
         show_edges=True, edge_color=EDGE, lighting=False, show_scalar_bar=scalar_bar,
         scalar_bar_args={"title": title, "vertical": True,
                          "position_x": 0.86, "position_y": 0.2,
                          "width": 0.05, "height": 0.6, "color": "black",
                          "n_labels": 3, "fmt": "%.2g",
                          "title_font_size": 12, "label_font_size": 11})
    for name, points, colour in (("below", view.below, BELOW), ("above", view.above, ABOVE)):
        _put(plotter, name, points, color=colour[0], point_size=marker_size(points.n_points, 9),
             render_points_as_spheres=True, show_scalar_bar=False)


Q_SIGN_CROWDED = ("q_positive", "q_boundary")
"""The q_ij-sign lines that follow the edge density (dark, light, hidden); q_ij < 0 and a
medium's interfaces are always drawn, so a crowded mesh still shows where the M-matrix property
fails."""
NEGATIVE_THIN = 2          # q_ij < 0 lines when the other edges are light or hidden


def apply_q_sign_look(plotter: pv.Plotter, look: str | None) -> None:
    """The q_ij-sign lines for edges that look `look` on screen: q_ij ≥ 0 and boundary edges
    dark, light or hidden like every other edge; q_ij < 0 always drawn (thinner when crowded)."""
    widths = {name: width for name, _, _, width in Q_SIGN_LINES}
    for name, _, colour, _ in Q_SIGN_LINES:
        actor = plotter.actors.get(name)
        if actor is None:
            continue
        prop = actor.GetProperty()
        if name in Q_SIGN_CROWDED:
            actor.SetVisibility(look is not None)
            prop.SetColor(pv.Color(colour if look == "dark" else EDGE_LIGHT).float_rgb)
        elif name == "q_negative":
            prop.SetLineWidth(widths[name] if look == "dark" else NEGATIVE_THIN)


TYPICAL_SAMPLE = 20_000     # triangles whose sides give the typical edge (evenly taken)


def typical_edge(step) -> float:
    """A short typical edge length of the mesh (the first quartile of the triangle sides; of
    `TYPICAL_SAMPLE` triangles evenly taken when there are more: it only sets how edges look).

    The quartile, not the mean: with an anisotropic Q the short sides set how crowded edges look.
    """
    P, T = step.mesh.points, step.mesh.triangles
    if len(T) == 0:
        return 0.0
    T = T[::-(-len(T) // TYPICAL_SAMPLE)]
    x, y = P[:, 0], P[:, 1]
    a, b = T.ravel(), np.roll(T, -1, axis=1).ravel()
    dx, dy = x[b] - x[a], y[b] - y[a]
    return float(np.percentile(np.sqrt(dx * dx + dy * dy), 25))


def pixels_per_unit(plotter: pv.Plotter) -> float:
    """Screen pixels per world unit at the focal point of the plotter's camera."""
    cam = plotter.renderer.GetActiveCamera()
    height = plotter.render_window.GetSize()[1] or WINDOW_SIZE[1]
    if cam.GetParallelProjection():
        visible = 2.0 * cam.GetParallelScale()
    else:
        visible = 2.0 * cam.GetDistance() * np.tan(np.deg2rad(cam.GetViewAngle()) / 2)
    return height / visible if visible > 0 else 0.0


def edge_look(mode: str, edge_pixels: float) -> str | None:
    """"dark", "light" or None (hidden) for edges spanning `edge_pixels` on screen in `mode`."""
    if mode not in EDGE_MODES:
        raise QmeshError(f"edges must be one of {EDGE_MODES}, got {mode!r}")
    if mode == "on":
        return "dark"
    if mode == "off":
        return None
    if edge_pixels >= EDGE_FULL_PX:
        return "dark"
    return "light" if edge_pixels >= EDGE_THIN_PX else None


def _narrow(plotter: pv.Plotter) -> float:
    """Width / height when the view is taller than wide, else 1: VTK fits a scene to the
    height, so a narrow view must zoom out by this much to show all of it."""
    w, h = plotter.render_window.GetSize()
    return min(1.0, w / h) if w > 0 and h > 0 else 1.0


def _scene_points(plotter: pv.Plotter, names, most: int = 4000) -> np.ndarray:
    """Up to `most` points (evenly taken) of the named actors' data, (n, 3)."""
    parts = []
    for name in names:
        actor = plotter.actors.get(name)
        data = None if actor is None else actor.mapper.GetInput()
        if data is not None and data.GetNumberOfPoints():
            P = pv.wrap(data).points
            parts.append(P[:: max(1, len(P) // most)])
    return np.concatenate(parts) if parts else np.zeros((0, 3))


def new_plotter(window_size=WINDOW_SIZE) -> pv.Plotter:
    """An off-screen plotter without multisampling (MSAA costs ~4× per frame on llvmpipe) and
    without order-independent translucency: the one translucent layer (the lifted view's s(x))
    looks the same blended plainly, and VTK's weighted-OIT pass (floating-point buffers
    composited over the whole window) doubled the lifted view's frame time on llvmpipe."""
    system.require_rendering()
    plotter = pv.Plotter(off_screen=True, window_size=list(window_size))
    plotter.render_window.SetMultiSamples(0)
    plotter.renderer.SetUseOIT(False)
    plotter.set_background(BACKGROUND)
    return plotter


def view_scene(name: str, step, anisotropy, *, z_scale: float = 1.0,
               colour_by: str = "quality", q_sign_edges: bool = False, domain=None,
               arrow_scale: float = 1.0, isotropic: bool = False):
    """The scene of view `name` ("lifted", "mesh" or "quality") of `step`: arrays and PyVista
    meshes only, no plotter, so it may be built in another thread while a plotter renders.
    The quality view with `colour_by` "solution" shows the maximum principle
    (`scene.solution`; on the isotropic mesh of the same N with `isotropic`): only then is
    anything solved."""
    if name == "lifted":
        if scene.is_field(anisotropy):
            return scene.ellipses(step, anisotropy, domain=domain)
        return scene.lifted(step, anisotropy, z_scale, domain=domain)
    if name == "mesh":
        return scene.projected(step, arrow_scale=arrow_scale)
    if name == "quality" and colour_by == SOLUTION:
        return scene.solution(step, anisotropy, isotropic)
    if name == "quality":
        return scene.quality(step, anisotropy, colour_by, q_sign_edges)
    raise QmeshError(f"no view {name!r}; the views are {VIEWS}")


def draw_order(anisotropy) -> tuple[str, ...]:
    """The order the views are drawn in: the mesh view first for a field (its first view shows
    the projected scene's sampled outlines), else lifted, mesh, quality (the quality view shows
    them too)."""
    return ("mesh", "lifted", "quality") if scene.is_field(anisotropy) else ("lifted", "mesh",
                                                                               "quality")


class ViewSet:
    """The three plotters of the app and widget, redrawn from one Step at a time.

    The mesh and quality views share one vtkCamera, so moving one moves the other.
    Cameras are reset on the first draw and on `reset_cameras()`, not on every step, so a
    user's zoom survives stepping through the algorithm.
    """

    def __init__(self, window_size=WINDOW_SIZE, scalar_bar: bool = True):
        self.plotters = {name: new_plotter(window_size) for name in VIEWS}
        self.plotters["quality"].renderer.camera = self.plotters["mesh"].renderer.camera
        for plotter in self.plotters.values():
            plotter.renderer.camera_set = True    # else pyvista resets it on a first render
        self.scalar_bar = scalar_bar
        self.edges = "auto"
        self.top_views = ("mesh", "quality")   # the shown views the shared camera is fitted to
        self.edge_length = 0.0
        self.legend: dict = {}
        self._drawn = False
        self._z_scale = None
        self._domain_key = None
        self._field = False              # the first view shows a field's ellipses, top-down
        self._medium = False             # ... a medium's pieces, from above
        self._fine = False               # s(x) drawn for facets too small to see (_fine_facets)
        self._q_sign = False             # the quality view's edges are the q_ij-sign lines
        self._looks: dict = {}           # each view's edge look (`apply_edges`)
        for name, plotter in self.plotters.items():
            plotter.render_window.AddObserver("WindowResizeEvent",
                                              lambda *_, n=name: self._resized(n))

    def _resized(self, name: str) -> None:
        """A view changed size (the browser laid it out): fit its picture to the new shape."""
        if not self._drawn:
            return
        if name == "lifted":
            self.fit_lifted()
        else:
            self.fit_top()
        self.apply_edges()

    def draw(self, step, anisotropy, *, z_scale: float = 1.0, colour_by: str = "quality",
             q_sign_edges: bool = False, domain=None, arrow_scale: float = 1.0,
             edges: str = "auto", regions=(), scenes: dict | None = None,
             isotropic: bool = False) -> None:
        """Redraw the three views from `step`; `edges` is "auto" (by density), "on" or "off";
        `regions` a medium's rows (tag, name, q11, q12, q22) for the legend; `scenes` the
        views' scenes already built (`view_scene`), the others are built here; `colour_by`
        "solution" and `isotropic` as `view_scene`."""
        edge_look(edges, 0.0)                           # QmeshError for an unknown mode
        scenes = dict(scenes or {})
        for name in self.order(anisotropy):
            if name not in scenes:
                scenes[name] = view_scene(name, step, anisotropy, z_scale=z_scale,
                                          colour_by=colour_by, q_sign_edges=q_sign_edges,
                                          domain=domain, arrow_scale=arrow_scale,
                                          isotropic=isotropic)
            self.draw_view(name, anisotropy, scenes)
        self.finish(step, anisotropy, scenes, regions)
        key = self._key(anisotropy, domain)
        self._medium = scene.is_medium(anisotropy)
        field = key[1]
        if field != self._field:
            self._field = field
            self._lifted_style(field)
        if not self._drawn or key != self._domain_key:      # first draw, a new domain or kind
            self.reset_cameras()
            self._drawn = True
            self._domain_key = key
        elif z_scale != self._z_scale:
            self.fit_lifted()
        self._z_scale = z_scale
        self.begin(step, edges)
        self.apply_edges()

    @staticmethod
    def _key(anisotropy, domain) -> tuple:
        rings = None if domain is None else tuple(np.asarray(r).tobytes() for r in domain.rings)
        return (rings, scene.is_field(anisotropy), scene.is_medium(anisotropy))

    def order(self, anisotropy) -> tuple[str, ...]:
        """`draw_order`, but the lifted view last while it shows s(x) for facets too small to
        see (`_fine_facets`): its picture hardly changes from one stage to the next, so the
        two views that do are drawn first."""
        order = draw_order(anisotropy)
        if self._fine and order[0] == "lifted" and not scene.is_medium(anisotropy):
            return order[1:] + order[:1]
        return order

    @property
    def fine_facets(self) -> bool:
        """Whether the lifted view shows s(x) for facets too small to see (`_fine_facets`)."""
        return self._fine

    def placed(self, anisotropy, *, domain=None, z_scale: float = 1.0) -> bool:
        """True when a draw of a step of this kind would keep every camera where it is (the
        views were drawn before, with this domain, kind and z-scale): the views may then be
        drawn one at a time (`begin`, `draw_view` and `apply_edges` per view, `finish`)."""
        return (self._drawn and self._key(anisotropy, domain) == self._domain_key
                and z_scale == self._z_scale)

    def begin(self, step, edges: str = "auto") -> None:
        """Before drawing `step`'s views one at a time: the edge mode and its typical edge."""
        edge_look(edges, 0.0)
        self.edges = edges
        self.edge_length = typical_edge(step)

    def draw_view(self, name: str, anisotropy, scenes: dict) -> None:
        """Put view `name`'s scene (`scenes[name]`) on its plotter; a field's first view and the
        quality view also take the projected scene's sampled outlines (`scenes["mesh"]`, drawn
        before them: `draw_order`)."""
        p = self.plotters
        field = scene.is_field(anisotropy)
        if name == "lifted":
            if field:                                   # no s: Q(x) as ellipses, top-down
                draw_field(p["lifted"], scenes["lifted"])
            else:
                draw_lifted(p["lifted"], scenes["lifted"])
            _put(p["lifted"], "sample", scenes["mesh"].sample if field else None, color=EDGE,
                 line_width=1, show_scalar_bar=False)   # a field's mesh when edges crowd
        elif name == "mesh":
            draw_projected(p["mesh"], scenes["mesh"])
        else:
            q = scenes["quality"]
            solved = isinstance(q, scene.SolutionScene)
            if solved:                                  # the maximum principle
                draw_solution(p["quality"], q, scalar_bar=self.scalar_bar)
            else:
                draw_quality(p["quality"], q, scalar_bar=self.scalar_bar)
            _put(p["quality"], "sample", q.sample if solved else scenes["mesh"].sample,
                 color=EDGE, line_width=1, show_scalar_bar=False)   # shown when edges crowd
            self._q_sign = not solved and q.edges is not None

    def finish(self, step, anisotropy, scenes: dict, regions=()) -> None:
        """After the views of `step` are drawn: their legend."""
        q, projected, shown = scenes["quality"], scenes["mesh"], scenes["lifted"]
        field = scene.is_field(anisotropy)
        solved = isinstance(q, scene.SolutionScene)
        self.legend = {"title": SCALAR_TITLES[SOLUTION if solved else q.scalars],
                       "clim": (0.0, 1.0) if solved else tuple(map(float, q.clim)),
                       "q_sign_edges": not solved and q.edges is not None,
                       "n_negative": 0 if solved else q.n_negative,
                       "solution": scene.solution_info(q) if solved else None,
                       "regions": list(regions) if scene.is_medium(anisotropy) else [],
                       "n_interface": 0 if solved else q.n_interface, "field": field,
                       "n_fixed": projected.n_fixed, "n_fixed_shown": projected.fixed.n_points,
                       "n_vertices": step.mesh.n_vertices,
                       "crowded": self._looks.get("mesh") != "dark",
                       "quality_edges": self._looks.get("quality"), "fine_facets": self._fine}
        if field:
            self.legend.update(field_clim=tuple(map(float, shown.clim)),
                               n_ellipses=len(shown.centres), field_label=anisotropy.label,
                               means=means_source(step.mesh))

    def apply_edges(self, names=VIEWS) -> dict:
        """Show, lighten or hide the edges of views `names` (default all) for their current
        zoom; returns the looks of all views.

        Called after every draw and after the user zooms (the app's camera observers).
        """
        targets = {"lifted": ("facets", "vertices", "sample"), "mesh": ("mesh", "sample"),
                   "quality": ("triangles", "sample")}
        for name in names:
            actors = targets[name]
            plotter = self.plotters[name]
            pixels = self.edge_length * pixels_per_unit(plotter)
            look = edge_look(self.edges, pixels)
            self._looks[name] = look
            if name == "lifted":
                self._fine_facets(plotter, not (self._field or self._medium)
                                  and edge_look("auto", pixels) is None)
            for actor_name in actors:
                actor = plotter.actors.get(actor_name)
                if actor is None:
                    continue
                if actor_name == "vertices":
                    actor.SetVisibility(look == "dark")
                    continue
                if actor_name == "sample":        # crowded: a sample of triangles outlined
                    actor.SetVisibility(look != "dark")
                    continue
                if actor_name == "mesh" and "region_rgb" in pv.wrap(actor.mapper.GetInput()
                                                                      ).cell_data:
                    pass                          # a medium: always coloured by region
                elif actor_name == "mesh":        # crowded: the triangles coloured by area
                    actor.mapper.SetScalarVisibility(look != "dark")
                    actor.GetProperty().SetColor(pv.Color(MESH_FACE).float_rgb)
                if actor_name == "triangles" and self._q_sign:
                    continue                             # the q_ij-sign lines are the edges
                prop = actor.GetProperty()
                prop.SetEdgeVisibility(look is not None)
                colours = FIELD_EDGE if name == "lifted" and self._field else (EDGE, EDGE_LIGHT)
                prop.SetEdgeColor(pv.Color(colours[0] if look == "dark" else colours[1]).float_rgb)
            if name == "quality":
                apply_q_sign_look(self.plotters["quality"], look)
        self.legend["crowded"] = self._looks.get("mesh") != "dark"
        self.legend["quality_edges"] = self._looks.get("quality")
        return dict(self._looks)

    def _fine_facets(self, plotter: pv.Plotter, fine: bool) -> None:
        """Facets of s_h too small to tell apart (edges hidden for density, e.g. at 1e5
        vertices on the whole view) are not drawn: s(x) is, opaque and in their colour, the
        same picture without 2e5 triangles a frame; zoomed in, the facets are back over the
        translucent s(x)."""
        facets, surface = plotter.actors.get("facets"), plotter.actors.get("surface")
        fine = fine and facets is not None and surface is not None
        if facets is not None:
            facets.SetVisibility(not fine)
        if surface is not None:
            prop = surface.GetProperty()
            prop.SetOpacity(1.0 if fine else 0.3)
            prop.SetColor(pv.Color(FACET if fine else SURFACE).float_rgb)
            prop.SetAmbient(0.3 if fine else 0.5)
        self._fine = fine
        self.legend["fine_facets"] = fine

    def _lifted_style(self, field: bool) -> None:
        """The first view's interaction: panned and zoomed like the mesh view for a field (a
        plane), rotated for a lifted surface."""
        plotter = self.plotters["lifted"]
        if getattr(plotter, "iren", None) is None:
            return
        if field:
            plotter.enable_2d_style()
        else:
            plotter.enable_trackball_style()

    def reset_cameras(self) -> None:
        """Lifted: seen from below, where the lower hull faces (s_h ≥ s lies behind the
        translucent s); a medium's pieces (no surface to look through) obliquely from above, so
        the regions read side by side as on the mesh view; a field's ellipses, and mesh and
        quality: top-down with a parallel projection."""
        lifted = self.plotters["lifted"]
        if self._field:
            lifted.enable_parallel_projection()
            lifted.view_xy(render=False)
        else:
            lifted.disable_parallel_projection()
            lifted.view_vector(MEDIUM_VIEW if self._medium else (0.9, -1.7, -0.7),
                               viewup=(0, 0, 1))
        self.fit_lifted()
        self.plotters["mesh"].enable_parallel_projection()
        self.plotters["quality"].enable_parallel_projection()
        self.plotters["mesh"].view_xy(render=False)
        self.fit_top()

    def fit_top(self) -> None:
        """Fit the shared top-down camera of the mesh and quality views to the domain."""
        top = self.plotters["mesh"]
        top.reset_camera(render=False)                  # centred on the scene
        x0, x1, y0, y1 = top.bounds[:4]
        sizes = [self.plotters[n].render_window.GetSize() for n in self.top_views]
        aspect = min((w / h if w > 0 and h > 0 else 1.0) for w, h in sizes)   # shared camera
        margin = 1.45 if self.scalar_bar else 1.08       # VTK's bar sits at 0.86–0.91 of the width
        top.camera.parallel_scale = margin * max((y1 - y0) / 2, (x1 - x0) / 2 / aspect)

    def fit_lifted(self) -> None:
        """Fit the lifted view to its scene, keeping its direction: the scene's points, projected
        to the screen, are centred and span 92% of the card's width or height (reset_camera
        alone fits a bounding sphere, which left the surface a third of its card)."""
        lifted = self.plotters["lifted"]
        lifted.reset_camera(render=False)
        w, h = lifted.render_window.GetSize()
        if self._field:                                  # a plane seen from above
            x0, x1, y0, y1 = lifted.bounds[:4]
            aspect = w / h if w > 0 and h > 0 else 1.0
            lifted.camera.parallel_scale = 1.08 * max((y1 - y0) / 2, (x1 - x0) / 2 / aspect)
            lifted.renderer.ResetCameraClippingRange()
            return
        X = _scene_points(lifted, ("surface", "facets"))
        if w <= 0 or h <= 0 or len(X) == 0:
            lifted.camera.zoom(1.05 * _narrow(lifted))
            return
        cam = lifted.camera
        X = np.column_stack([X, np.ones(len(X))])
        for _ in range(4):                           # perspective: converge in a few passes
            M = np.array([[cam.GetCompositeProjectionTransformMatrix(w / h, -1, 1).GetElement(i, j)
                           for j in range(4)] for i in range(4)])
            Y = X @ M.T
            ndc = Y[:, :2] / Y[:, 3:4]
            lo, hi = ndc.min(axis=0), ndc.max(axis=0)
            centre, half = (lo + hi) / 2, (hi - lo) / 2
            # pan: NDC offset → world offset along the camera's right and up at the focal plane
            d = cam.GetDistance()
            up_half = d * np.tan(np.deg2rad(cam.GetViewAngle()) / 2)
            right = np.cross(np.subtract(cam.GetFocalPoint(), cam.GetPosition()), cam.GetViewUp())
            right /= np.linalg.norm(right)
            up = np.asarray(cam.GetViewUp(), float)
            up = up - np.dot(up, right) * right
            up /= np.linalg.norm(up)
            shift = centre[0] * up_half * w / h * right + centre[1] * up_half * up
            cam.SetFocalPoint(*(np.asarray(cam.GetFocalPoint()) + shift))
            cam.SetPosition(*(np.asarray(cam.GetPosition()) + shift))
            factor = 0.92 / max(half.max(), 1e-9)
            cam.Zoom(factor)
            if abs(factor - 1) < 0.01 and np.abs(centre).max() < 0.01:
                break
        lifted.renderer.ResetCameraClippingRange()

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
