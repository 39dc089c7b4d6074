"""The viewer as a Jupyter widget: `qmesh_view.widget(**params)` returns an ipywidgets box.

`qmesh_view.widget` is this module, made callable (it calls `widget`), so the call works
whichever way the module was imported; the package loads it on first use (ipywidgets is slow
to import and the other front ends do not need it).

The model and the pictures are the app's: `session.Session` holds the parameters in force, the
run and its history and answers every change; `draw.ViewSet` draws the three views (lifted,
mesh, quality) from `scene`. This module only binds controls to the session and decides where
the pictures go (controls are written only with the values in force, their observers muted, so
a change never echoes back):

- `backend="trame"`: PyVista's trame Jupyter backend, one server-rendered view per plotter
  (an iframe served by a trame server inside the kernel); needs a browser that reaches it.
- `backend="static"`: PNG images of off-screen renders in `ipywidgets.Image`, for frontends
  that cannot show a live view (nbclient, nbconvert, tests).
- `backend="auto"`: trame inside a kernel started by a Jupyter server (JupyterLab, Notebook),
  static anywhere else.

Threads: JupyterLab 4.6 with ipykernel 7 delivers widget messages on a second kernel thread
(comms over subshells); a VTK render from there breaks the GL context (HEADLESS.md), and the
trame views stop following the sliders from the second move on (tests/widget). Every
handler goes through `MainThread.call`, which runs it at once on the thread that built the
widget (the kernel's main thread) and otherwise hands it to that thread's asyncio loop with
`call_soon_threadsafe`; so every draw and render happens on the main thread.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import io
import os
import sys
import threading
import types
from html import escape as html_escape

import ipywidgets as w
import numpy as np

from qmesh.errors import QmeshError

from . import delivery, legend
from .legend import VIEW_TITLES
from .controller import status_text
from .draw import SOLUTION, VIEWS, ViewSet
from .problem import DISK, S_PRESETS, domain_names
from .session import RUN_PAUSE, Session, describe

BACKENDS = ("auto", "trame", "static")
VIEW_SIZE = (340, 320)
SLIDER_STYLE = {"description_width": "8.5em"}


class MainThread:
    """Runs callables on the thread that built it, through its asyncio loop when called elsewhere.

    `loop` defaults to the loop running on the calling thread (in a kernel: the kernel's main
    loop). With no loop there is nowhere to hand a call to, and it runs where it is called.
    """

    def __init__(self, loop: asyncio.AbstractEventLoop | None = None):
        self.ident = threading.get_ident()
        if loop is None:
            try:
                loop = asyncio.get_running_loop()
            except RuntimeError:
                loop = None
        self.loop = loop

    def here(self) -> bool:
        return threading.get_ident() == self.ident

    def call(self, fn, *args) -> None:
        """fn(*args) now on the main thread; from any other thread, soon on the main loop."""
        if self.here() or self.loop is None or self.loop.is_closed():
            fn(*args)
        else:
            self.loop.call_soon_threadsafe(fn, *args)

    def wrap(self, fn):
        """`fn` as a callback that always runs on the main thread (see `call`)."""
        @functools.wraps(fn)
        def dispatched(*args):
            self.call(fn, *args)
        return dispatched


def in_jupyter_server_kernel() -> bool:
    """True in an IPython kernel started by a Jupyter server: a browser frontend can show iframes.

    jupyter_server gives the kernels of its sessions JPY_SESSION_NAME; nbclient does not.
    """
    try:
        from IPython import get_ipython
    except ImportError:
        return False
    shell = get_ipython()
    return (shell is not None and getattr(shell, "kernel", None) is not None
            and "JPY_SESSION_NAME" in os.environ)


def choose_backend(backend: str) -> str:
    """"trame" or "static" for `backend` ("auto" looks at where it runs)."""
    if backend not in BACKENDS:
        raise QmeshError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if backend != "auto":
        return backend
    return "trame" if in_jupyter_server_kernel() else "static"


def png(image: np.ndarray) -> bytes:
    """An RGB array (h, w, 3) as PNG bytes."""
    from PIL import Image
    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(image)).save(buf, format="png")
    return buf.getvalue()


def _slider(kind, description: str, value, **kwargs):
    return kind(value=value, description=description, continuous_update=False,
                style=SLIDER_STYLE, **kwargs)


class QmeshWidget(w.VBox):
    """Controls, status line and the three views of one `Controller` run.

    `sliders` ("k1", "k2", "angle", "vb", "target_vertices"), `buttons` ("step", "iterate",
    "run", "reset"), `history` (the stage slider), `status`, `error`, `quality_view` (the
    quality or the maximum principle), `isotropic` (the latter on an isotropic mesh of the same
    N) and `view_widgets` (name → Image or trame iframe) are the parts; `session` and `views`
    the model and plotters.
    """

    def __init__(self, *, backend: str = "auto", view_size=VIEW_SIZE,
                 loop: asyncio.AbstractEventLoop | None = None, **params):
        super().__init__()
        self.session = Session(**params)             # QmeshError on bad parameters, before any UI
        self.backend = choose_backend(backend)
        self.main = MainThread(loop)
        self.view_size = tuple(int(v) for v in view_size)
        self.views = ViewSet(self.view_size, scalar_bar=False)   # legends are HTML, beside
        self._run_task = None
        self._syncing = False
        self._build_controls()
        self.views.draw(self.session.current, self.session.anisotropy, **self._view_options())
        self.view_widgets = (self._trame_views() if self.backend == "trame"
                             else self._static_views())
        self.children = self._layout()
        self._connect()
        self._show()

    # ------------------------------------------------------------------ parts
    @property
    def controller(self) -> Session:
        """The session (kept under its old name: params, history, index, current …)."""
        return self.session

    @property
    def running(self) -> bool:
        return self.session.running

    def _build_controls(self) -> None:
        p = self.session.params
        log = dict(base=10, min=-2, max=2, step=0.05, readout_format=".3g")
        self.sliders = {
            "k1": _slider(w.FloatLogSlider, "k1", p.k1, **log),
            "k2": _slider(w.FloatLogSlider, "k2", p.k2, **log),
            "angle": _slider(w.FloatSlider, "angle of k1 (°)", p.angle, min=0, max=180, step=5),
            "vb": _slider(w.IntSlider, "VB", p.vb, min=3, max=256),
            "target_vertices": _slider(w.IntSlider, "target vertices", p.target_vertices,
                                       min=3, max=5000),
            "domain": w.Dropdown(options=domain_names(), value=p.domain, description="domain",
                                 style=SLIDER_STYLE),
            "q_mode": w.ToggleButtons(options=[("constant Q", "constant"),
                                               ("s(x, y)", "expression")],
                                      value=p.q_mode, description="conductivity",
                                      style={"button_width": "7em", **SLIDER_STYLE}),
        }
        self.s_text = w.Combobox(value=p.s_text, options=list(S_PRESETS), description="s(x, y)",
                                 ensure_option=False, continuous_update=False,
                                 style=SLIDER_STYLE, layout=w.Layout(width="26em"))
        self.s_error = w.HTML()
        self.upload = w.FileUpload(accept=".csv,.txt,.geojson,.json", multiple=False,
                                   description="polygon file")
        self.buttons = {name: w.Button(description=name.capitalize(),
                                       layout=w.Layout(width="6.5em"))
                        for name in ("step", "iterate", "run", "reset")}
        self.history = _slider(w.IntSlider, "history", 0, min=0, max=0,
                               layout=w.Layout(width="60%"))
        self.readout = w.HTML()
        self.media_readout = w.HTML()     # a medium: every region's Q (one Q does not apply)
        self.status = w.HTML()
        self.error = w.HTML()
        self.edges = w.ToggleButtons(options=["auto", "on", "off"], value="auto",
                                     description="edges", style={"button_width": "4em"},
                                     tooltips=["drawn while they can be told apart",
                                               "always drawn", "never drawn"])
        self.quality_view = w.ToggleButtons(
            options=[("quality", "quality"), ("maximum principle", SOLUTION)], value="quality",
            description="quality view", style={"button_width": "9em", **SLIDER_STYLE},
            tooltips=["the metric quality (2.94)",
                      "u_h of −div(Q∇u) = 0, u = 1 on the left of the boundary, 0 on the rest"])
        self.isotropic = w.Checkbox(value=False, description="compare: isotropic mesh of the "
                                    "same N", indent=False)
        self.legends = {name: w.HTML() for name in VIEWS}

    def _static_views(self) -> dict:
        return {name: w.Image(format="png", layout=w.Layout(width="100%", height="auto",
                                                             max_width=f"{self.view_size[0]}px",
                                                             object_fit="contain"))
                for name in VIEWS}

    def _trame_views(self) -> dict:
        """PyVista's trame Jupyter backend: a server-rendered view (iframe) per plotter."""
        from trame_pyvista.jupyter import show_trame
        width, height = self.view_size
        out = {}
        for name, plotter in self.views.plotters.items():
            if name != "lifted":
                plotter.enable_2d_style()
            with contextlib.redirect_stdout(io.StringIO()):    # trame-vtklocal's "Using wasm_dir"
                out[name] = show_trame(plotter, mode="server", add_menu=False,
                                       width="100%", height=f"{height}px")
        # the mesh and quality views share a camera: after moving one, push the other too
        for source, other in (("mesh", "quality"), ("quality", "mesh")):
            iren = self.views.plotters[source].iren.interactor
            iren.AddObserver("EndInteractionEvent",
                             lambda *_, v=out[other].viewer: self.main.call(v.update))
        return out

    def _layout(self) -> list:
        s, b = self.sliders, self.buttons
        self.titles = {name: w.HTML(f"<b>{html_escape(VIEW_TITLES[name])}</b>") for name in VIEWS}
        # the three views share the output area's width (each at most its rendered size),
        # so the widget fits beside JupyterLab's side panels instead of being cut off
        views = w.HBox([w.VBox([self.titles[name], self.view_widgets[name],
                                self.legends[name]],
                               layout=w.Layout(flex="1 1 0", min_width="0"))
                        for name in VIEWS], layout=w.Layout(width="100%"))
        self._constant_box = w.VBox([s["k1"], s["k2"], s["angle"], self.readout])
        self._s_box = w.VBox([self.s_text, self.s_error])
        return [w.HBox([w.VBox([s["q_mode"], self._constant_box, self._s_box,
                                self.media_readout]),
                        w.VBox([s["domain"], self.upload, s["vb"], s["target_vertices"],
                                self.edges, self.quality_view, self.isotropic])],
                       layout=w.Layout(flex_flow="row wrap")),
                w.HBox([*b.values(), self.history], layout=w.Layout(flex_flow="row wrap")),
                self.status, self.error, views]

    def _connect(self) -> None:
        on = self.main.wrap
        for name, slider in self.sliders.items():
            slider.observe(on(functools.partial(self._on_param, name)), names="value")
        self.history.observe(on(self._on_history), names="value")
        for option in (self.edges, self.quality_view, self.isotropic):
            option.observe(on(lambda _change: self._show()), names="value")
        self.upload.observe(on(self._on_upload), names="value")
        self.s_text.observe(on(self._on_s_text), names="value")
        self.buttons["step"].on_click(on(lambda _: self._move(self.session.step)))
        self.buttons["iterate"].on_click(on(lambda _: self._move(self.session.iterate)))
        self.buttons["run"].on_click(on(self._on_run))
        self.buttons["reset"].on_click(on(self._on_reset))

    # ------------------------------------------------------------------ handlers (main thread)
    def _answer(self, outcome, show_text_error: bool = False) -> None:
        """After an action: the new stage on screen when something changed, else the controls
        put back; the outcome's message and the warnings on the message line."""
        if outcome.ok and outcome.kind != "unchanged":
            try:
                self._show()
            except Exception as e:                      # noqa: BLE001  drawing or measuring
                self.session.action_messages = [describe(e)]
                self._report()
        else:
            self._sync()
            self._report()

    def _report(self, notes=()) -> None:
        lines = list(dict.fromkeys([*self.session.action_messages, *notes]))
        self.error.value = "".join(f"<div style='color:#c62828'>{html_escape(m)}</div>"
                                   for m in lines)

    def _on_param(self, name: str, change) -> None:
        """Any parameter change restarts the run; VB and the target move together; a refused
        value is put back on its control."""
        if self._syncing:
            return
        refused = self.session.refusal(name, change["new"])
        if refused is not None:              # told without meshing: a running Run goes on
            self.session.action_messages = [refused.message]
            self._answer(refused)
            return
        self.session.stop()
        self._answer(self.session.change(name, change["new"]))

    def _on_s_text(self, change) -> None:
        """s(x, y) entered (Enter or a preset): mesh it from the start. A refused text keeps
        the last mesh and stays in the field, its error in red beside it."""
        if self._syncing:
            return
        self.session.stop()
        outcome = self.session.apply_s(change["new"])
        self.s_error.value = ("" if outcome.ok else
                              f"<span style='color:#c62828'>{html_escape(outcome.message)}</span>")
        if outcome.ok:
            self._show()

    def _on_upload(self, change) -> None:
        """A polygon file (CSV or GeoJSON) was uploaded: offer it as a domain and mesh it."""
        files = change["new"]
        if self._syncing or not files:
            return
        upload = files[0]
        self.session.stop()
        try:
            content = bytes(upload["content"])
        except Exception as e:                          # noqa: BLE001  (a forged value)
            content = e
        name = upload.get("name") if hasattr(upload, "get") else None
        self._answer(self.session.upload(name, content))

    def _on_history(self, change) -> None:
        if self._syncing or self.running or int(change["new"]) == self.session.index:
            return
        self._answer(self.session.scrub(change["new"]))

    def _move(self, action) -> None:
        if not self.running:
            self._answer(action())

    def _on_reset(self, _button=None) -> None:
        self.session.stop()
        self._answer(self.session.reset())

    def _on_run(self, _button=None) -> None:
        """Run toggles. In a kernel the session's run loop is a task on its loop, so Stop and
        the sliders are heard between stages; without a running loop Run blocks."""
        if self.running:
            self.session.stop()
            return
        if self.session.at_end:
            return
        loop = self.main.loop
        if loop is not None and loop.is_running() and self.main.here():
            self._run_task = loop.create_task(self._animate())
            self.session.running = True               # at once: the buttons show Stop
            self._sync(quick=True)
        else:
            self._answer(asyncio.run(self.session.run(pause=0)))

    async def _animate(self) -> None:
        outcome = await self.session.run(lambda _: self._show(quick=True), pause=RUN_PAUSE)
        if outcome.ok:
            self._show()
        else:
            self._answer(outcome)

    def _stop(self) -> None:
        self.session.stop()

    # ------------------------------------------------------------------ showing a stage
    def _show(self, quick: bool = False) -> None:
        """Draw the shown stage and send the pictures, then measure it for the status line."""
        c = self.session
        self.views.draw(c.current, c.anisotropy, **self._view_options())
        for name, html in self.legends.items():
            html.value = legend.html(name, self.views.legend)
            self.titles[name].value = f"<b>{html_escape(legend.title(name, self.views.legend))}</b>"
        self._sync(quick=True)
        self._push()
        if not quick:
            self._sync(quick=False)

    def _view_options(self) -> dict:
        return dict(domain=self.session.domain, edges=self.edges.value,
                    regions=self.session.regions, colour_by=self.quality_view.value,
                    isotropic=bool(self.isotropic.value))

    def _sync(self, quick: bool = True) -> None:
        """Controls ← model, without their observers reacting."""
        c = self.session
        self._syncing = True
        try:
            self.sliders["domain"].options = domain_names(c.uploads)
            for name, slider in self.sliders.items():
                slider.value = getattr(c.params, name)
            self.sliders["vb"].disabled = c.params.domain != DISK
            constant = c.params.q_mode == "constant"
            medium = bool(c.readout["regions_text"])       # one Q per region: no Q controls
            self._constant_box.layout.display = None if constant and not medium else "none"
            self._s_box.layout.display = "none" if constant or medium else None
            self.sliders["q_mode"].layout.display = "none" if medium else None
            self.media_readout.value = html_escape(c.readout["regions_text"])
            if not self.s_error.value:
                self.s_text.value = c.params.s_text
            last = len(c.history) - 1
            if last >= self.history.max:
                self.history.max = last
                self.history.value = c.index
            else:
                self.history.value = c.index
                self.history.max = last
            self.history.disabled = self.running
            r = c.readout
            self.readout.value = (f"Q11 = {r['q11']:.4g} · Q12 = {r['q12']:.4g} · "
                                  f"Q22 = {r['q22']:.4g}")
            status = c.status(quick=quick)
            self.status.value = status_text(status)
            self._report(status["notes"])
            for name in ("step", "iterate"):
                self.buttons[name].disabled = self.running or c.at_end
            self.buttons["run"].description = "Stop" if self.running else "Run"
            self.buttons["run"].disabled = c.at_end and not self.running
            self.isotropic.layout.display = None if self.quality_view.value == SOLUTION else "none"
        finally:
            self._syncing = False

    def _push(self) -> None:
        """Send the pictures: re-render the PNGs, or ask the trame views to fetch new frames."""
        if self.backend == "static":
            for name, image in self.views.images().items():
                self.view_widgets[name].value = png(image)
        else:
            for view in self.view_widgets.values():
                delivery.fast_image_delivery(view.viewer.server)   # once its server runs
                view.viewer.update()

    # ------------------------------------------------------------------ life cycle
    def images(self) -> dict:
        """The three views as rendered now: name → RGB (h, w, 3), whatever the backend."""
        return self.views.images()

    def close(self) -> None:
        """Stop a run, release the plotters and close the widget and its children."""
        self._stop()
        self.views.close()
        for child in (*self.sliders.values(), *self.buttons.values(), self.history, self.upload,
                      self.s_text, self.s_error, self._constant_box, self._s_box,
                      self.readout, self.status, self.error, self.edges, self.quality_view,
                      self.isotropic,
                      *self.legends.values(), *self.view_widgets.values()):
            child.close()
        super().close()


def widget(*, backend: str = "auto", view_size=VIEW_SIZE,
           loop: asyncio.AbstractEventLoop | None = None, **params) -> QmeshWidget:
    """The qmesh viewer as an ipywidgets box (display it as a notebook cell's last value).

    `params` are the session's (k1, k2, angle, vb, target_vertices, alpha, seed; default
    the chapter's case Q = diag(0.1, 10), VB = 64, N ≈ 212). `backend` is "auto", "trame" or
    "static" (module docstring). `loop` is the loop of the thread that renders; by default the
    one running where this is called (the kernel's main loop).
    """
    return QmeshWidget(backend=backend, view_size=view_size, loop=loop, **params)


class _CallableModule(types.ModuleType):
    """This module's type: calling the module calls `widget`."""

    def __call__(self, *args, **kwargs) -> QmeshWidget:
        return widget(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
