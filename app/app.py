"""The qmesh-view trame app: three views of Algorithm 2.1 stepping on the chapter's case.

State names are the model's names (`k1`, `k2`, `angle`, `q11`, `q12`, `q22`, `vb`,
`target_vertices`, `alpha`, `seed`, `history_index`, …). Controllers only call
`qmesh_view.controller.Controller` (the run and its history) and `qmesh_view.draw.ViewSet`
(the scene functions on three plotters); the plotters render on the server (remote views).

The mesher and the measurements run in one worker thread so the page never freezes (`busy`
greys the buttons and shows a progress bar); VTK renders only on the event loop's thread.
"""

from __future__ import annotations

import asyncio
import math
from concurrent.futures import ThreadPoolExecutor

from trame.app import TrameApp, asynchronous
from trame.decorators import change
from trame.ui.vuetify3 import SinglePageWithDrawerLayout
from trame.widgets import html
from trame.widgets import vtk as vtk_widgets
from trame.widgets import vuetify3 as v3

from qmesh.errors import QmeshError

from .controller import PARAMS, Controller, status_text
from .draw import VIEWS, ViewSet

TITLE = "qmesh-view — Q-adapted meshes (Algorithm 2.1)"
VIEW_TITLES = {"lifted": "lifted: s(x) and the facets of s_h",
               "mesh": "mesh: seeds, inserted points, moves",
               "quality": "quality"}
CHART_SERIES = (("chart_energy", "energy E per iteration (log scale)", "#1f77b4"),
                ("chart_kappa2", "κ2 per iteration", "#d62728"),
                ("chart_n", "N per iteration", "#2ca02c"))
RUN_PAUSE = 0.05     # seconds between animated stages, so every frame reaches the browser


def convergence_chart(series: dict) -> dict:
    """State for the sparklines: log10 E, κ2, N per iteration, and "first → last" labels."""
    def ends(values, fmt):
        v = [x for x in values if x is not None]
        return f"{v[0]:{fmt}} → {v[-1]:{fmt}}" if v else ""
    energy = [x for x in series["energy"] if x is not None and x > 0]
    kappa2 = [x for x in series["kappa2"] if x is not None]
    return {"chart_energy": [math.log10(x) for x in energy], "chart_kappa2": kappa2,
            "chart_n": list(series["n_vertices"]),
            "chart_labels": {"chart_energy": ends(energy, ".3g"),
                             "chart_kappa2": ends(kappa2, ".3g"),
                             "chart_n": ends(series["n_vertices"], "d")}}


def slider(name: str, label: str, lo, hi, step, **kwargs) -> None:
    """A compact labelled VSlider bound to state `name`, in a <div id="slider-NAME"> for tests."""
    with html.Div(id=f"slider-{name}"):
        v3.VSlider(v_model=(name,), label=label, min=lo, max=hi, step=step, thumb_label=True,
                   hide_details=True, density="compact", **kwargs)


class QmeshView(TrameApp):
    """The web GUI: parameter drawer, Step/Iterate/Run/Reset, history slider, three views."""

    def __init__(self, server=None, **params):
        super().__init__(server, client_type="vue3")
        self.controller = Controller(**params)
        self.views = ViewSet()
        for name in ("mesh", "quality"):
            self.views.plotters[name].enable_2d_style()
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="qmesh-view")
        self._remesh_wanted = False
        self._remesh_task = None
        self._init_state()
        self.views.draw(self.controller.current, self.controller.anisotropy,
                        **self._view_options())
        self._build_ui()
        self._link_cameras()
        self._show()
        with self.state:
            self.state.status_line = status_text(self.controller.status())
            self.state.update(self._chart())

    # ------------------------------------------------------------------ state
    def _init_state(self) -> None:
        p = self.controller.params
        for name in PARAMS:
            self.state[name] = getattr(p, name)
        self.state.update(self.controller.readout)
        self.state.update(dict(history_index=0, history_length=1, busy=False, running=False,
                               z_scale=1.0, colour_by="quality", q_sign_edges=False,
                               status_line="", error="", at_end=False,
                               chart_energy=[], chart_kappa2=[], chart_n=[], chart_labels={}))

    def _view_options(self) -> dict:
        return dict(z_scale=float(self.state.z_scale), colour_by=self.state.colour_by,
                    q_sign_edges=bool(self.state.q_sign_edges), domain=self.controller.domain)

    def _chart(self) -> dict:
        """Worker thread: the convergence series as sparkline data (E on a log10 scale)."""
        return convergence_chart(self.controller.convergence())

    def _show(self) -> int:
        """Event loop: draw the shown stage, push its images, the slider and its quick numbers.

        κ2 and the q_ij signs follow from the worker (`_move`); until then the status line
        shows "–" for them, so a large mesh is on screen before it is measured.
        """
        c = self.controller
        with self.state:
            self.state.history_length = len(c.history)
            self.state.history_index = c.index
            self.state.at_end = c.at_end
            self.state.status_line = status_text(c.status(quick=True))
        self._redraw()
        return c.index

    def _redraw(self) -> None:
        c = self.controller
        self.views.draw(c.current, c.anisotropy, **self._view_options())
        for view in self.html_views.values():
            view.update()

    # ------------------------------------------------------------------ off-loop work
    async def _work(self, fn):
        """Run `fn` in the one worker thread (the mesher and measurements never run on the loop)."""
        return await asyncio.get_running_loop().run_in_executor(self._worker, fn)

    async def _move(self, move) -> None:
        """Busy while: `move` the run (worker) → draw (loop) → measure and chart (worker)."""
        c = self.controller
        with self.state:
            self.state.busy = True
            self.state.error = ""
        try:
            before = len(c.history)
            await self._work(move)
            index = self._show()
            grew = len(c.history) != before
            status, chart = await self._work(
                lambda: (c.status(index), self._chart() if grew else None))
            with self.state:
                if c.index == index:
                    self.state.status_line = status_text(status)
                if chart is not None:
                    self.state.update(chart)
        except QmeshError as e:
            with self.state:
                self.state.error = str(e)
        finally:
            with self.state:
                self.state.busy = False

    def _start(self, move) -> None:
        if self.state.busy or self.state.running:
            return
        asynchronous.create_task(self._move(move))

    async def _when_idle(self) -> None:
        while self.state.busy:                        # let a running stage finish first
            await asyncio.sleep(0.02)

    # ------------------------------------------------------------------ buttons
    def on_step(self) -> None:
        self._start(self.controller.step)

    def on_iterate(self) -> None:
        self._start(self.controller.iterate)

    def on_reset(self) -> None:
        """Back to the first triangulation; a running Run is stopped first."""
        self.state.running = False
        asynchronous.create_task(self._reset())

    async def _reset(self) -> None:
        await self._when_idle()
        await self._move(self.controller.reset)

    def on_run(self) -> None:
        """Run toggles: start the animated run, or ask a running one to stop after this stage."""
        if self.state.running:
            self.state.running = False
            return
        if self.state.busy:
            return
        self.state.running = True
        asynchronous.create_task(self._run())

    async def _run(self) -> None:
        try:
            while self.state.running and not self.controller.at_end:
                await self._move(self.controller.step)
                if self.state.error:
                    break
                await asyncio.sleep(RUN_PAUSE)
        finally:
            with self.state:
                self.state.running = False

    # ------------------------------------------------------------------ reactions
    @change("history_index")
    def on_history_index(self, history_index, **_):
        if self.state.busy or int(history_index) == self.controller.index:
            return
        asynchronous.create_task(self._move(lambda: self.controller.scrub(history_index)))

    @change("z_scale", "colour_by", "q_sign_edges")
    def on_view_option(self, **_):
        if not self.state.busy:
            self._redraw()

    @change(*PARAMS)
    def on_param(self, **_):
        """Any parameter change re-meshes from the start; the latest values win."""
        self._remesh_wanted = True
        if self._remesh_task is None or self._remesh_task.done():
            self._remesh_task = asynchronous.create_task(self._remesh())

    async def _remesh(self) -> None:
        while self._remesh_wanted:
            self._remesh_wanted = False
            self.state.running = False
            await self._when_idle()
            changes = {name: self.state[name] for name in PARAMS}
            await self._move(lambda: self.controller.set_params(**changes))
            with self.state:
                self.state.update(self.controller.readout)

    # ------------------------------------------------------------------ cameras
    def _link_cameras(self) -> None:
        """The mesh and quality views share one camera; after moving one, push the other too."""
        pairs = (("mesh", "quality"), ("quality", "mesh"))
        for source, other in pairs:
            iren = self.views.plotters[source].iren.interactor
            view = self.html_views[other]
            iren.AddObserver("EndInteractionEvent", lambda *_, v=view: v.update())

    # ------------------------------------------------------------------ layout
    def _build_ui(self) -> None:
        with SinglePageWithDrawerLayout(self.server, width=330, full_height=True) as layout:
            layout.title.set_text("qmesh-view")
            self.state.trame__title = TITLE
            self._toolbar(layout.toolbar)
            with layout.drawer:
                self._parameters()
            with layout.content:
                self._main()
        self.ui = layout

    def _toolbar(self, toolbar) -> None:
        with toolbar:
            v3.VSpacer()
            disabled = ("busy || running || at_end",)
            v3.VBtn("Step", click=self.on_step, disabled=disabled, classes="mx-1",
                    variant="tonal", id="btn-step")
            v3.VBtn("Iterate", click=self.on_iterate, disabled=disabled, classes="mx-1",
                    variant="tonal", id="btn-iterate")
            v3.VBtn("{{ running ? 'Stop' : 'Run' }}", click=self.on_run, classes="mx-1",
                    disabled=("!running && (busy || at_end)",), variant="tonal", id="btn-run",
                    color=("running ? 'error' : 'primary'",))
            v3.VBtn("Reset", click=self.on_reset, disabled=("busy && !running",), classes="mx-1",
                    variant="tonal", id="btn-reset")
            v3.VProgressLinear(indeterminate=True, absolute=True, location="bottom",
                               v_show=("busy",), color="primary", id="busy")

    def _parameters(self) -> None:
        with v3.VContainer(classes="pa-3", style="font-size: 0.85rem"):
            html.Div("Conductivity Q (principal values, angle of k1)", classes="text-subtitle-2")
            slider("k1", "k1", 0.05, 20, 0.05)
            slider("k2", "k2", 0.05, 20, 0.05)
            slider("angle", "angle", 0, 180, 5)
            html.Div("Q11 = {{ q11.toPrecision(4) * 1 }} · Q12 = {{ q12.toPrecision(4) * 1 }}"
                     " · Q22 = {{ q22.toPrecision(4) * 1 }}", classes="my-2", id="q-readout")
            v3.VDivider(classes="my-2")
            html.Div("Domain and mesher", classes="text-subtitle-2")
            slider("vb", "VB", 8, 256, 1)
            v3.VTextField(v_model_number=("target_vertices",), label="target vertices",
                          type="number", density="compact", hide_details=True, classes="my-2")
            slider("alpha", "α", 0.05, 1, 0.05)
            v3.VTextField(v_model_number=("seed",), label="seed", type="number",
                          density="compact", hide_details=True, classes="my-2")
            v3.VDivider(classes="my-2")
            html.Div("Views", classes="text-subtitle-2")
            slider("z_scale", "z-scale", 0.1, 3, 0.1)
            with html.Div(id="select-colour-by"):
                v3.VSelect(v_model=("colour_by",), label="colour by", density="compact",
                           items=("[{title: 'metric quality (2.94)', value: 'quality'},"
                                  " {title: 'metric area', value: 'metric_area'}]",),
                           hide_details=True, classes="my-2")
            with html.Div(id="switch-q-sign"):
                v3.VSwitch(v_model=("q_sign_edges",), label="edges by sign of q_ij",
                           density="compact", hide_details=True, color="primary")

    def _main(self) -> None:
        with v3.VContainer(fluid=True, classes="pa-2"):
            html.Div("{{ status_line }}", id="status-line",
                     classes="text-body-2 font-weight-medium px-2")
            html.Div("{{ error }}", v_show=("error",), classes="text-error px-2", id="error")
            slider("history_index", "history", 0, ("history_length - 1",), 1,
                   disabled=("busy || running",), classes="px-2")
            self.html_views = {}
            with v3.VRow(classes="ma-0"):
                for name in VIEWS:
                    with v3.VCol(cols=4, classes="pa-1"):
                        html.Div(VIEW_TITLES[name], classes="text-caption text-center")
                        with html.Div(style="position: relative; width: 100%; aspect-ratio: 1;"
                                            " max-height: calc(100vh - 290px)",
                                      id=f"view-{name}"):
                            self.html_views[name] = vtk_widgets.VtkRemoteView(
                                self.views.plotters[name].render_window,
                                ref=f"view_{name}", interactive_ratio=1, still_quality=95,
                                style="position: absolute; inset: 0")
            self._chart_row()

    def _chart_row(self) -> None:
        """The convergence chart: E (log scale), κ2 and N at the end of every iteration."""
        with v3.VRow(classes="ma-0 mt-2", id="chart"):
            for key, label, colour in CHART_SERIES:
                with v3.VCol(cols=4, classes="pa-1"):
                    with v3.VSheet(border=True, rounded=True, classes="pa-2"):
                        with html.Div(classes="d-flex text-caption"):
                            html.Span(label, classes="font-weight-medium")
                            v3.VSpacer()
                            html.Span(f"{{{{ chart_labels.{key} }}}}")
                        v3.VSparkline(model_value=(key,), color=colour, height=60,
                                      line_width=1.5, padding=6, smooth=False,
                                      auto_line_width=False)

    # ------------------------------------------------------------------ life cycle
    def close(self) -> None:
        """Stop the worker thread and release the plotters."""
        self.state.running = False
        self._worker.shutdown(wait=True, cancel_futures=True)
        self.views.close()
