"""The legends of the three views as small HTML strings, drawn beside the views, never over them.

One source for the trame app (bound with `v-html`) and the Jupyter widget (`ipywidgets.HTML`):
the colours are `qmesh_view.draw`'s, the quality colour bar is matplotlib's viridis as a CSS
gradient, with the limits the view was coloured with.
"""

from __future__ import annotations

from html import escape

from . import draw, scene
from .problem import q_text

VIRIDIS = ("#440154", "#482878", "#3e4989", "#31688e", "#26828e", "#1f9e89", "#35b779",
           "#6ece58", "#b5de2b", "#fde725")
"""matplotlib's viridis at ten even stops (draw.QUALITY_CMAP), for the CSS colour bar."""

VIEW_TITLES = {"lifted": "lifted: s(x) and the facets of s_h",
               "mesh": "mesh: seeds, inserted points, moves",
               "quality": "quality (2.94)"}
"""The views' titles, one wording for the trame app and the widget."""
SOLUTION_TITLES = {"mesh": "maximum principle: u_h of −div(Q∇u) = 0 on this mesh",
                   "isotropic": "maximum principle: u_h on an isotropic mesh of the same N"}
"""The quality view's title while it shows the maximum principle, by the mesh shown."""
FIELD_TITLE = "Q(x) as ellipses over the mesh (no s to lift)"
"""The first view's title for a conductivity field (`title`)."""
PLASMA = ("#0d0887", "#5302a3", "#8b0aa5", "#b83289", "#db5c68", "#f48849", "#febd2a",
          "#f0f921")
"""matplotlib's plasma at eight even stops (draw.ELLIPSE_CMAP), for the ellipses' colour bar."""


def title(name: str, info: dict) -> str:
    """View `name`'s title for what it shows (`info` is `ViewSet.legend`): the first view of a
    field shows ellipses, not a lifted surface."""
    if name == "lifted" and info.get("field"):
        return FIELD_TITLE
    if name == "quality" and info.get("solution"):
        return SOLUTION_TITLES[info["solution"]["shown"]]
    return VIEW_TITLES[name]

_ROW = "display:flex;flex-wrap:wrap;align-items:center;gap:4px 12px;font-size:12px;padding:2px 6px"


def _dot(colour: str) -> str:
    return (f"<span style='display:inline-block;width:9px;height:9px;border-radius:50%;"
            f"background:{colour};margin-right:4px'></span>")


def _swatch(colour: str, opacity: float = 1.0) -> str:
    return (f"<span style='display:inline-block;width:14px;height:10px;background:{colour};"
            f"opacity:{opacity};border:1px solid #888;margin-right:4px'></span>")


def _line(colour: str, width: int = 2) -> str:
    return (f"<span style='display:inline-block;width:16px;height:0;border-top:{width}px solid "
            f"{colour};margin-right:4px;vertical-align:middle'></span>")


def _item(mark: str, text: str) -> str:
    return f"<span>{mark}{escape(text)}</span>"


def _number(x: float) -> str:
    return format(x, ".3g")


def html(name: str, info: dict) -> str:
    """The legend of view `name` ("lifted", "mesh", "quality"); `info` is `ViewSet.legend`."""
    if name == "lifted" and info.get("field"):
        lo, hi = info.get("field_clim", (0.0, 1.0))
        bar = ("<span style='display:inline-block;width:90px;height:10px;border:1px solid #888;"
               f"background:linear-gradient(to right,{','.join(PLASMA)})'></span>")
        items = [_item("", "ellipses: axes along Q's eigenvectors, ∝ √eigenvalues (each to "
                           "its own scale), over the mesh"),
                 f"<span class='legend-colour-bar'>colour: log10 of Q's larger eigenvalue "
                 f"{_number(lo)} {bar} {_number(hi)}</span>"]
    elif name == "lifted" and info.get("regions"):
        items = [_item(_swatch(draw.FACET), "a medium has one s per region, not one surface: "
                       "each region in its colour, its triangles lifted onto its own s_r less "
                       "its own plane, at most half the region's width high, seen from above"),
                 _item(_dot(draw.EDGE), "vertices (x, s_r(x))")]
    elif name == "lifted" and info.get("fine_facets"):
        items = [_item(_swatch(draw.FACET), "s(x): the facets of s_h are too small to tell "
                       "apart from it here (zoom in to see them)")]
    elif name == "lifted":
        items = [_item(_swatch(draw.SURFACE, 0.5), "s(x), translucent"),
                 _item(_swatch(draw.FACET), "facets of s_h"),
                 _item(_dot(draw.EDGE), "vertices (x, s(x))")]
    elif name == "mesh":
        def few(n, shown):
            return f" ({shown} of {n} marked)" if shown < n else ""

        # the cap said whenever the mesh is larger than it, not only at the stages it bites:
        # the same text at every stage keeps the legend row, and so the pictures, one height
        capped = info.get("n_vertices", 0) > scene.MAX_MARKERS

        def most(how):
            return f" (at most {scene.MAX_MARKERS} {how})" if capped else ""
        items = [_item(_dot(draw.FIXED), "seed points (fixed)"
                       + few(info.get("n_fixed", 0), info.get("n_fixed_shown", 0))),
                 _item(_dot(draw.ADDED), "inserted by the last insert" + most("marked")),
                 _item(_line(draw.ARROW), "moves of the last adjust"
                       + most("drawn: the longest in each cell of a grid"))]
        regions = info.get("regions") or []
        if regions:
            items.append(_item(_line(draw.INTERFACE, 3), "interface"))
            items += [f"<span class='legend-region'>{_swatch(scene.region_colour(r['tag']))}"
                      f"{escape(r['name'])}: {escape(q_text(r))}</span>" for r in regions]
        if info.get("crowded") and not regions:
            bar = ("<span style='display:inline-block;width:70px;height:10px;border:1px solid "
                   "#888;background:linear-gradient(to right,#08306b,#4292c6,#deebf7)'></span>")
            items.append(f"<span class='legend-size'>edges too dense: a sample of "
                         f"triangles outlined; area small {bar} large</span>")
    elif name == "quality" and info.get("solution"):
        items = solution_items(info["solution"], info.get("field"), bool(info.get("regions")))
    elif name == "quality":
        lo, hi = info.get("clim", (0.0, 1.0))
        bar = ("<span style='display:inline-block;width:140px;height:10px;border:1px solid #888;"
               f"background:linear-gradient(to right,{','.join(VIRIDIS)})'></span>")
        items = [f"<span class='legend-colour-bar'>{escape(info.get('title', 'quality'))}: "
                 f"{_number(lo)} {bar} {_number(hi)}</span>"]
        if info.get("field"):
            source = ("the certified means the mesh carries" if info.get("means") == "certified"
                      else "computed from the field on this stage's mesh")
            items.append(_item("", f"each triangle in its own element mean Q̄_T ({source})"))
        if info.get("q_sign_edges"):
            look = {value: (colour, width) for _, value, colour, width in draw.Q_SIGN_LINES}
            crowd = info.get("quality_edges", "dark")
            light = (draw.EDGE_LIGHT, 1)
            n_neg = info.get("n_negative", 0)
            items.append(_item("", "edges by sign of q_ij (switch on):"))
            items.append(_item(_line(draw.Q_SIGN_LINES[-1][2],
                                     look[-1][1] if crowd == "dark" else draw.NEGATIVE_THIN),
                               f"q_ij < 0: {n_neg} edge{'s' if n_neg != 1 else ''}"
                               + (", always drawn" if crowd != "dark" else "")))
            if info.get("regions"):
                items.append(_item(_line(*look[2]), f"interface, q_ij ≥ 0 "
                                                    f"({info.get('n_interface', 0)})"))
            if crowd == "dark":
                items += [_item(_line(*look[1]), "q_ij ≥ 0"),
                          _item(_line(*look[0]), "boundary edge")]
            elif crowd == "light":
                items.append(_item(_line(*light), "q_ij ≥ 0 and boundary (light: crowded)"))
            else:
                items.append(_item("", "q_ij ≥ 0 not drawn: too dense (zoom in)"))
    else:
        raise ValueError(f"no legend for view {name!r}")
    return f"<div class='legend' style='{_ROW}'>{''.join(items)}</div>"


def _outside(n: int) -> str:
    return f"{n} vert{'ex' if n == 1 else 'ices'} outside [0, 1]"


def solution_items(mp: dict, field: bool = False, medium: bool = False) -> list[str]:
    """The maximum-principle legend (`scene.solution_info`): the colours, the data, and the
    two counts in words, the mesh on screen first."""
    bar = ("<span style='display:inline-block;width:110px;height:10px;border:1px solid #888;"
           f"background:linear-gradient(to right,{','.join(VIRIDIS)})'></span>")
    q = ("each triangle's element mean" if field else "each region's Q" if medium else "Q")
    items = [f"<span class='legend-colour-bar'>u_h: 0 {bar} 1</span>",
             _item("", f"−div(Q∇u) = 0 with {q}; u = 1 on the boundary vertices with "
                       f"x < {_number(mp['centre'])}, 0 on the others (a jump)"),
             _item(_dot(draw.ABOVE[0]) + _swatch(draw.ABOVE[1]), "u_h > 1"),
             _item(_dot(draw.BELOW[0]) + _swatch(draw.BELOW[1]), "u_h < 0"),
             _item("", f"(beyond {mp['tolerance']:.0e})")]
    for key, what in (("mesh", "qmesh's mesh"), ("isotropic", "isotropic Delaunay mesh")):
        c = mp[key]
        split = (f" ({c['n_below']} below 0, {c['n_above']} above 1; u_h from "
                 f"{_number(c['u_min'])} to {_number(c['u_max'])})" if c["n_outside"] else "")
        shown = " — shown" if mp["shown"] == key else ""
        items.append(f"<span class='mp-{key}'><b>{escape(what)}, N = {c['n_vertices']}: "
                     f"{_outside(c['n_outside'])}</b>{escape(split + shown)}</span>")
    return items


def state(info: dict) -> dict:
    """{"legend_lifted": …, "legend_mesh": …, "legend_quality": …} and the views' titles
    {"title_lifted": …, …}, `field_view` (the first view shows a field's ellipses), and
    `legend_height` (px, one for all three, so the views keep one height and one scale): two
    lines, three for a field, or room for a medium's region list."""
    out = {f"legend_{name}": html(name, info) for name in draw.VIEWS}
    out.update({f"title_{name}": title(name, info) for name in draw.VIEWS})
    out["field_view"] = bool(info.get("field"))
    out["legend_height"] = (50 + 20 * len(info["regions"]) if info.get("regions")
                            else 62 if info.get("field") else 44)
    return out


def html_legend(name: str) -> None:
    """The trame element showing view `name`'s legend from the state (id legend-NAME)."""
    from trame.widgets import html as h
    h.Div(v_html=(f"legend_{name}",), id=f"legend-{name}",     # the card's second grid row
          style="max-height: 40vh; overflow-y: auto; min-height: 0")
