"""The qmesh-view trame app: three views of Algorithm 2.1 stepping on the chapter's case.

State names are the model's names (`k1`, `k2`, `angle`, `q11`, `q12`, `q22`, `vb`,
`target_vertices`, `alpha`, `seed`, `history_index`, …). Controllers only call
`qmesh_view.controller.Controller` (the run and its history) and `qmesh_view.draw.ViewSet`
(the scene functions on three plotters).

Views render on the server (`remote`, the default) or in the browser (`local`, vtk.js).
Remote is the default because it reaches the screen sooner, the more so the larger the mesh
(`benchmarks/bench_view.py --browser` measures both, from the input to the changed picture in
Chromium), and because vtk.js draws the translucent s(x) over the facets of s_h wrongly. Remote
frames are re-pushed every 10 ms while still being encoded, not after trame-vtk's 0.5 s wait, each
view's as soon as it is encoded, and the page's websocket hands them over as ArrayBuffers
(`qmesh_view.delivery`).

Every control is bound to one `qmesh_view.session.Session` (the parameters in force, the run,
the outcome of every change); this module only binds controls and draws. Slider moves are
submitted to the session and applied by one drain task, so a burst while a re-mesh runs
collapses into its last value; text fields send their value on Enter or blur only. The server
writes a control only when the value in force differs from what that control sent (adjusted or
refused), never echoing a change back. Refusals and warnings go to `messages`, a fixed-height
line beside the status line, so the views never move.

The mesher and the measurements run in one worker thread so the page never freezes (`busy`
greys the buttons and shows a still bar under them: nothing on the page animates, since every
animation has the browser redraw the page for as long as it runs, `delivery.QUIET_PAGE`); VTK
renders only on the event loop's thread. The pictures of a stage go out first, its measurements
(κ2, q_ij signs, chart) follow; a Run measures only the stage it stops at, and it meshes on
while the views draw, showing the newest stage each time they are free (drawing a stage takes
longer than meshing the next below about 20,000 vertices: a Run that waited for every picture
spent most of its time drawing stages replaced a moment later).
"""

from __future__ import annotations

import asyncio
import functools
import math
import threading
import time
from concurrent.futures import ThreadPoolExecutor

from trame.app import TrameApp, asynchronous
from trame.decorators import change
from trame.ui.vuetify3 import SinglePageWithDrawerLayout
from trame.widgets import client, html
from trame.widgets import vtk as vtk_widgets
from trame.widgets import vuetify3 as v3

from qmesh.errors import QmeshError

from . import connect, delivery, legend
from .controller import PARAMS, status_text
from .draw import VIEWS, ViewSet, view_scene
from .problem import DISK, S_PRESETS
from .session import Outcome, Session, check_run_pause, describe

TITLE = "qmesh-view — triangle meshes shaped by a conductivity Q"
TITLE_TIP = ("Q-adapted meshes: Algorithm 2.1 of the chapter, a mesh whose every stiffness "
             "coefficient q_ij ≥ 0")
VIEW_MODES = ("remote", "local")
CHART_SERIES = (("chart_energy", "energy E (log scale)", "#1f77b4"),
                ("chart_kappa2", "κ2 per iteration", "#d62728"),
                ("chart_n", "N per iteration", "#2ca02c"))
CHART_TIPS = {"chart_energy": "E = ‖s_h − s‖_L1 (2.80) at the end of each iteration: the volume "
                              "between the lifted mesh and s(x), which each adjust stage lowers",
              "chart_kappa2": "the condition number of the stiffness matrix with Dirichlet "
                              "boundary values",
              "chart_n": "the vertex count at the end of each iteration"}
NO_ENERGY = "a field has no s: no energy"
"""The energy panel's body for a conductivity field, in place of an empty chart."""
COLOUR_BY = ("[{title: 'metric quality', value: 'quality'},"
             " {title: 'metric area', value: 'metric_area'},"
             " {title: 'maximum principle: u_h', value: 'solution'}]")
COLOUR_BY_TIP = ("metric quality (2.94): 1 for a triangle equilateral in the metric of Q · "
                 "metric area: each triangle's area in that metric · maximum principle: u_h of "
                 "−div(Q∇u) = 0, which stays between its boundary values when every q_ij ≥ 0")
"""The colour-by items in words; the equation numbers are in the select's tooltip."""
VIEW_HEIGHT = "calc(100vh - 347px)"   # the views fill the page below the status lines
TEXT_PARAMS = ("target_vertices", "seed")   # typed: applied on Enter or blur, never per key
SLIDER_PARAMS = tuple(n for n in PARAMS if n not in TEXT_PARAMS + ("s_text",))
QUICK_FIRST = 20_000       # vertices up to which Step computes a stage's quick numbers before its
#                            pictures (a pass over the triangles; above, the pictures go first)
MEASURE_AFTER = 0.1        # seconds from the pictures sent to the measurements started: the
#                            browser shows them first (the status and chart updates that follow
#                            the measurements made it decode the last picture later)
AHEAD_UP_TO = 5_000        # target vertices up to which the worker meshes a run's next stages
#                            while the page is idle (Step and Run then show them at once; each
#                            stage is a few milliseconds there, so a click waits for at most one)
FIRST_PICTURE = 0.25       # seconds: a Run (without a pause) draws nothing on its way before
#                            this; one that ends sooner shows its last stage only (a picture on
#                            the way would hold the last one back until it was drawn)


def convergence_chart(series: dict, field: bool = False) -> dict:
    """State for the sparklines: log10 E, κ2, N per iteration, and "first → last" labels (E's
    says "none: no s" for a `field`, whose metric has no energy).

    A medium's Steps are the stages of each face's run in turn: E is a face's own energy, so
    its chart follows the last face run ("face k: …"), while κ2 and N (of the faces
    stitched so far) run over every face's iterations in order."""
    def ends(values, fmt):
        v = [x for x in values if x is not None]
        return f"{v[0]:{fmt}} → {v[-1]:{fmt}}" if v else ""
    faces = series.get("face") or [0] * len(series["energy"])
    known = [f for f in faces if f is not None]
    last = max(known) if known else 0
    energy = [x for x, f in zip(series["energy"], faces)
              if x is not None and x > 0 and (last == 0 or f == last)]
    kappa2 = [x for x in series["kappa2"] if x is not None]
    e_label = "none: no s" if field else ends(energy, ".3g")
    if last > 0 and not field:
        e_label = f"face {last + 1}: {e_label}"
    return {"chart_energy": [math.log10(x) for x in energy], "chart_kappa2": kappa2,
            "chart_n": list(series["n_vertices"]),
            "chart_labels": {"chart_energy": e_label,
                             "chart_kappa2": ends(kappa2, ".3g"),
                             "chart_n": ends(series["n_vertices"], "d")}}


def slider(name: str, label: str | None, lo, hi, step, shown: str | None = None,
           aria: str | None = None, **kwargs) -> None:
    """A compact labelled VSlider bound to state `name`, its value always shown at the right,
    in a <div id="slider-NAME"> (the value in <span class="slider-value">) for tests; its
    thumb (role "slider") named `aria` (default `label`: Vuetify gives it the slider's `name`
    as aria-label) for screen readers and `get_by_role`."""
    with html.Div(id=f"slider-{name}"):
        with v3.VSlider(v_model=(name,), label=label, min=lo, max=hi, step=step,
                        hide_details=True, density="compact", name=aria or label,
                        **kwargs):
            with v3.Template(v_slot_append=True):
                html.Span(f"{{{{ {shown or f'+Number({name}).toPrecision(4)'} }}}}", classes="slider-value text-body-2",
                          style="min-width: 3.2em; text-align: right; display: inline-block")


class QmeshView(TrameApp):
    """The web GUI: parameter drawer, Step/Iterate/Run/Reset, history slider, three views."""

    def __init__(self, server=None, view_mode: str = "remote", memory_budget: int | None = None,
                 session: Session | None = None, run_pause: float = 0.0, **params):
        """Either the parameters of a new Session (`memory_budget`, `**params`) or a `session`
        made beforehand (the command line checks its arguments that way, before VTK loads).
        `run_pause`: seconds Run holds each stage before asking for the next (0: as fast as the
        mesher goes), to watch the algorithm step by step."""
        if session is not None and (params or memory_budget is not None):
            raise QmeshError("give either a session or the parameters of a new one, not both")
        if view_mode not in VIEW_MODES:
            raise QmeshError(f"view_mode must be one of {VIEW_MODES}, got {view_mode!r}")
        self.run_pause = check_run_pause(run_pause)
        super().__init__(server, client_type="vue3")
        self.view_mode = view_mode
        self.session = session if session is not None else Session(memory_budget=memory_budget,
                                                                    **params)
        self.views = ViewSet(scalar_bar=False)
        for name in ("mesh", "quality"):
            self.views.plotters[name].enable_2d_style()
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="qmesh-view")
        self._scene_worker = ThreadPoolExecutor(max_workers=1,   # the views' scenes, built
                                                thread_name_prefix="qmesh-view-scene")
        self._drain_task = None
        self._resume = False             # a Run stopped by a change that may yet be refused
        self._options_changed = False
        self._drawn = None                # (run, stage index) the views show
        self._drawer, self._wanted = None, None   # a run's drawing task and its newest stage
        self._drawing = threading.Event()  # set while that task draws (the worker meshes on)
        self._run_started = 0.0           # time.monotonic() at the start of the last Run
        self._ahead_task = None           # meshing the run's next stages while idle
        self._wanted_stage = None         # the history slider moved while busy: show it next
        self._echo = False                # writing the slider's value (`_show`)
        self._init_state()
        self.views.draw(self.session.current, self.session.anisotropy, **self._view_options())
        self._build_ui()
        self.server.controller.on_server_ready.add(self._fast_image_delivery)
        self.server.controller.on_server_ready.add(lambda **_: self._mesh_ahead_soon())
        connect.answer_launcher(self.server)        # no 405 in the page's console
        self._link_cameras()
        for name in SLIDER_PARAMS:
            self.state.change(name)(functools.partial(self.on_control, name))
        self._show()
        status = self.session.status()
        with self.state:
            self.state.status_line = status_text(status)
            self.state.update(self._chart())
        self._messages(status["notes"])

    @property
    def controller(self):
        """The run on screen (its history); `session` holds it."""
        return self.session.controller

    # ------------------------------------------------------------------ state
    def _init_state(self) -> None:
        self.state.update({f"rev_{name}": 0 for name in TEXT_PARAMS})
        self._write_params(PARAMS)
        self.state.update(dict(history_index=0, history_length=1, busy=False, running=False,
                               z_scale=1.0, colour_by="quality", q_sign_edges=False,
                               isotropic=False,
                               edges="auto", maximised="",
                               status_line="", messages="", at_end=False, regions_text="",
                               chart_energy=[], chart_kappa2=[], chart_n=[], chart_labels={}))
        self.state.update(legend.state(self.views.legend))
        self.state.domain_items = self.session.domain_names()
        self.state.domain_file = None
        self.state.update(dict(s_input=self.session.params.s_text, s_error="",
                               s_presets=list(S_PRESETS), s_preset=None))

    def _write_params(self, names) -> None:
        """Controls `names` ← the parameters in force (pushed even when the state holds that
        value: the browser may show another), and the Q readout."""
        p = self.session.params
        for name in names:
            self.state[name] = getattr(p, name)
            self.state.dirty(name)
            if name in TEXT_PARAMS:         # a new key redraws the field over what was typed
                self.state[f"rev_{name}"] = (self.state[f"rev_{name}"] or 0) + 1
        self.state.update(self.session.readout)
        self.state.s_shown = p.s_text if p.q_mode == "expression" else ""

    def _settle_controls(self, sent: dict) -> None:
        """After a change: write back only the controls whose value in force differs from what
        they hold and that have nothing newer pending (adjusted or refused): never an echo."""
        p = self.session.params
        stale = [n for n in PARAMS if not self.session.has_pending(n)
                 and (self.state[n] != getattr(p, n) or (n in sent and sent[n] != getattr(p, n)))]
        with self.state:
            self._write_params(stale)
            if "s_text" in stale or "q_mode" in stale:
                self.state.s_input = p.s_text

    def _messages(self, notes=()) -> None:
        """The line beside the status: refusals of the last action, warnings about the stage."""
        with self.state:
            self.state.messages = "\n".join(dict.fromkeys([*self.session.action_messages,
                                                           *notes]))

    def _view_options(self) -> dict:
        return dict(z_scale=float(self.state.z_scale), colour_by=self.state.colour_by,
                    q_sign_edges=bool(self.state.q_sign_edges), domain=self.session.domain,
                    edges=self.state.edges, regions=self.session.regions,
                    isotropic=bool(self.state.isotropic))

    def _chart(self) -> dict:
        """Worker thread: the convergence series as sparkline data (E on a log10 scale)."""
        return convergence_chart(self.session.convergence(), field=self.session.controller.is_field)

    def _show(self, push: bool = True, index: int | None = None, draw: bool = True) -> int:
        """Event loop: draw the shown stage (or stage `index`, which a run has already left),
        push its images (unless not `push`: the caller awaits `_push_each`), the slider and
        its quick numbers (only those when not `draw`: the caller draws, `_draw_each`).

        κ2 and the q_ij signs follow from the worker (`_act`); until then the status line
        shows "–" for them, so a large mesh is on screen before it is measured.
        """
        c = self.session
        i = c.index if index is None else index
        self._echo = True                     # the slider's own change: not the user's
        try:
            with self.state:
                self.state.history_length = len(c.history)
                if self._wanted_stage is None:    # else the slider stays where the user put it
                    self.state.history_index = i
                self.state.at_end = c.at_end and i == c.index
                self.state.status_line = status_text(c.status(i, quick=True, bare=True))
        finally:
            self._echo = False
        if draw:
            self._redraw(push, i)
            self._drawn = (c.controller, i)
        return i

    def _redraw(self, push: bool = True, index: int | None = None) -> None:
        c = self.session
        step = c.current if index is None else c.history[index]
        self.views.draw(step, c.anisotropy, **self._view_options())
        with self.state:
            self.state.update(legend.state(self.views.legend))
        if push:
            self._push()

    def _push(self) -> None:
        for view in self.html_views.values():
            view.update()

    async def _push_each(self) -> None:
        """Push the views one after the other, giving the loop a moment after each (its due
        re-pushes and sends run before the next render): a frame encoded while the next view
        renders is sent then, so the browser decodes it meanwhile instead of receiving all
        three pictures after the last render."""
        for view in self.html_views.values():
            view.update()
            await asyncio.sleep(delivery.STALE_RETRY / 5)

    def _fast_image_delivery(self, **_) -> None:
        """Remote views: frames re-pushed every 10 ms while being encoded (`delivery`)."""
        self._image_link = delivery.fast_image_delivery(self.server)

    async def _frames_sent(self, timeout: float = 1.0) -> None:
        """Wait (≤ timeout) until the remote views' new frames are encoded and sent.

        The measurements that follow (κ2, charts) hold the GIL for tens of milliseconds at
        N = 1,000 and more; started at once they delayed the frames the user waits for.
        """
        link = getattr(self, "_image_link", None)
        deadline = asyncio.get_running_loop().time() + timeout
        while delivery.frames_pending(link) and asyncio.get_running_loop().time() < deadline:
            await asyncio.sleep(delivery.STALE_RETRY / 2)

    # ------------------------------------------------------------------ off-loop work
    async def _work(self, fn):
        """Run `fn` in the one worker thread (the mesher and measurements never run on the loop)."""
        return await asyncio.get_running_loop().run_in_executor(self._worker, fn)

    async def _stage_work(self, action, figures: bool = True):
        """`_work(action)`, and then, still in the worker, the shown stage's own numbers (a
        Step computes its energy and quality statistics when first asked, a pass over the
        triangles the event loop would otherwise make before drawing) and a field's element
        means (`Controller.warm`). Without `figures`, above `QUICK_FIRST` vertices, the numbers
        are left for after the pictures (`_measure`).

        In a run the worker goes on to the next stage while the views are still drawing an
        earlier one (`_drawing`), so the mesher never waits for the pictures; the run then
        gets the newest stage."""
        c = self.session

        def act():
            outcome = action()
            while (outcome.kind == "applied" and self._drawing.is_set() and c.running
                   and not c.stopping and not c.at_end):
                outcome = action()
            if outcome.ok and (not c.running or c.at_end or not self._in_first_picture()):
                c.controller.warm()        # a field's means of the stage drawn next, here
                if figures or c.current.mesh.n_vertices <= QUICK_FIRST:
                    c.status(quick=True)
            return outcome
        return await self._work(act)

    async def _act(self, action, then=None):
        """Busy while: the session's `action` (worker) → draw (loop) → measure (worker), then
        `then()` (controls that follow the action), so that idle means the page is complete.

        Returns the Outcome; a refusal keeps the picture and shows its message.
        """
        with self.state:
            self.state.busy = True
        try:
            before = (len(self.session.history), self.session.controller)
            outcome = await self._stage_work(action, figures=False)
            if outcome.ok:
                await self._after_stage(outcome, before)
            else:
                self._messages()
            return outcome
        except Exception as e:                        # noqa: BLE001  drawing or measuring
            outcome = Outcome("refused", describe(e))
            self.session.action_messages = [outcome.message]
            self._messages()
            return outcome
        finally:
            if then is not None:
                then()
            self._end_busy()

    def _end_busy(self) -> None:
        """The work in hand is done: idle (the run's next stages meshed ahead meanwhile), or on
        into the stage the history slider was moved to while busy, never idle in between."""
        wanted = self._stage_wanted()
        with self.state:
            self.state.busy = wanted is not None
        self._redraw_changed_options()
        if wanted is None:
            self._mesh_ahead_soon()
        else:
            asynchronous.create_task(self._act(lambda: self.session.scrub(wanted)))

    def _stage_wanted(self) -> int | None:
        """The stage the history slider was moved to while busy, if not the one shown (its
        last position: keys pressed fast on the slider are never lost), to show next."""
        wanted, self._wanted_stage = self._wanted_stage, None
        if wanted is None or self.state.running or wanted == self.session.index:
            return None
        return wanted

    def _mesh_ahead_soon(self) -> None:
        """Once idle: mesh the shown run's next stages in the worker (`Controller.ahead`)."""
        if self._ahead_task is None or self._ahead_task.done():
            self._ahead_task = asynchronous.create_task(self._mesh_ahead())

    async def _mesh_ahead(self) -> None:
        """A small run's stages meshed one by one while nothing else is asked of the worker:
        each stage is a separate task, so an action waits for at most one; any work in hand
        ends it, and the next idle moment starts it again (for the run then on screen)."""
        while not self.state.busy and not self.state.running:
            run = self.session.controller            # the one on screen now
            if run.params.target_vertices > AHEAD_UP_TO or run.all_meshed:
                return
            await self._work(run.ahead)

    def _redraw_changed_options(self) -> None:
        """Once the work in hand is done: redraw for a view option changed meanwhile."""
        if self._options_changed:
            self._options_changed = False
            self._redraw()

    async def _after_stage(self, outcome, before=None) -> None:
        """Show the stage on screen, then measure it (κ2, q_ij signs, warnings) and chart."""
        await self._show_stage()
        await asyncio.sleep(MEASURE_AFTER)
        await self._measure(before)

    async def _show_stage(self, outcome=None, index: int | None = None) -> None:
        """Draw the shown stage (or `index`) and push its pictures (its quick numbers on the
        status line)."""
        c = self.session
        options = self._view_options()
        each = (self.view_mode == "remote" and not self.state.running
                and self.views.placed(c.anisotropy, domain=options["domain"],
                                      z_scale=options["z_scale"]))
        i = self._show(push=False, index=index, draw=not each)
        self._messages()
        if each:
            await self._draw_each(i, options)
        else:
            await self._push_each()
        await self._frames_sent()

    async def _draw_each(self, index: int, options: dict) -> None:
        """Draw stage `index` one view at a time, each pushed as soon as it is drawn: the
        scenes are built in the scene thread in drawing order (`draw.view_scene`), the next
        while this loop has the one before rendered and encoded (VTK renders without the GIL),
        and the legend follows the pictures. Only while every camera stays where it is
        (`ViewSet.placed`) and no Run is meshing on meanwhile (a third busy thread beside the
        mesher and the renders slowed the run more than it sped the pictures); else `_redraw`
        draws all three at once."""
        c = self.session
        step, anisotropy = c.history[index], c.anisotropy
        loop = asyncio.get_running_loop()
        order = self.views.order(anisotropy)
        built = {name: loop.run_in_executor(self._scene_worker, functools.partial(
            view_scene, name, step, anisotropy, z_scale=options["z_scale"],
            colour_by=options["colour_by"], q_sign_edges=options["q_sign_edges"],
            domain=options["domain"], isotropic=options["isotropic"])) for name in order}
        self.views.begin(step, options["edges"])
        scenes: dict = {}
        for name in order:
            scenes[name] = await built[name]
            self.views.draw_view(name, anisotropy, scenes)
            self.views.apply_edges((name,))
            self.html_views[name].update()
            await asyncio.sleep(delivery.STALE_RETRY / 5)
        self.views.finish(step, anisotropy, scenes, options["regions"])
        self._drawn = (c.controller, index)
        with self.state:
            self.state.update(legend.state(self.views.legend))

    async def _run_stage(self, outcome) -> None:
        """After each stage of a run: draw it while the mesher goes on (in the worker), and
        when the views are free again draw the newest stage, leaving out those meshed meanwhile
        (they stay in the history); none in a Run's first FIRST_PICTURE seconds unless it pauses.
        The run asks for the next stage as soon as this returns, before the drawing starts."""
        c = self.session
        self._wanted = c.index
        if self._in_first_picture():
            return
        if self._drawer is None or self._drawer.done():
            self._drawing.set()
            self._drawer = asynchronous.create_task(self._draw_wanted())

    def _in_first_picture(self) -> bool:
        """True in a Run's first FIRST_PICTURE seconds (without a pause): no stage drawn yet."""
        return not self.run_pause and time.monotonic() - self._run_started < FIRST_PICTURE

    async def _draw_wanted(self) -> None:
        """Draw the newest stage a run asked for until the views show it (`_drawing` set
        meanwhile: the worker meshes on)."""
        try:
            while self._wanted is not None and self._drawn != (self.session.controller,
                                                               self._wanted):
                await self._show_stage(index=self._wanted)
        finally:
            self._drawing.clear()

    async def _measure(self, before=None) -> None:
        """Worker: the shown stage's κ2, q_ij signs and warnings, then the chart when the
        history grew (since `before`: κ2 of every iteration not measured yet, one factorisation
        each); each shown as soon as it is known, if that stage is still the one on screen."""
        c = self.session
        index = c.index
        grew = before is None or (len(c.history), c.controller) != before
        run = c.controller
        shown = c.status(index, quick=True, bare=True)
        if shown["min_quality"] is None and not shown["field"]:   # the figures first
            quick = await self._work(lambda: c.status(index, quick=True))
            if c.controller is run and c.index == index:
                with self.state:
                    self.state.status_line = status_text(quick)
        status = await self._work(lambda: c.status(index))
        if c.controller is run and c.index == index:
            with self.state:
                self.state.status_line = status_text(status)
            self._messages(status["notes"])
        if grew:
            chart = await self._work(self._chart)
            if c.controller is run and c.index == index:
                with self.state:
                    self.state.update(chart)

    def _start(self, action) -> None:
        if self.state.busy or self.state.running:
            return
        asynchronous.create_task(self._act(action))

    async def _when_idle(self) -> None:
        while self.state.busy:                        # let a running stage finish first
            await asyncio.sleep(0.02)

    # ------------------------------------------------------------------ buttons
    def on_step(self) -> None:
        self._start(self.session.step)

    def on_iterate(self) -> None:
        self._start(self.session.iterate)

    def on_reset(self) -> None:
        """Back to the first triangulation; a running Run is stopped first."""
        self.session.stop()
        asynchronous.create_task(self._reset())

    async def _reset(self) -> None:
        await self._when_idle()
        await self._act(self.session.reset)

    def on_run(self) -> None:
        """Run toggles: start the animated run, or ask a running one to stop after this stage."""
        if self.state.running:
            self.session.stop()
            return
        if self.state.busy:
            return
        asynchronous.create_task(self._run())

    async def _run(self) -> None:
        """The animated run: every stage drawn with its quick numbers as soon as it is meshed;
        the stage it stops at is measured (κ2, q_ij signs, chart) once it has stopped, busy
        meanwhile (not when a change is waiting: it re-meshes). Measuring every stage on the
        way (κ2 costs the most of all at a large N) would hold the mesher back for numbers
        that are replaced a moment later."""
        with self.state:
            self.state.running = True
        measure = False
        self._drawer, self._wanted, self._wanted_stage = None, None, None
        self._run_started = time.monotonic()
        try:
            outcome = await self.session.run(self._run_stage, work=self._stage_work,
                                             pause=self.run_pause)
            if self._drawer is not None:
                await self._drawer
            if self._drawn != (self.session.controller, self.session.index):   # where it stopped
                await self._show_stage()
            if not outcome.ok:
                self._messages()
        except Exception as e:                        # noqa: BLE001  drawing or measuring
            self.session.action_messages = [describe(e)]
            self._messages()
        finally:
            measure = not self.state.busy and not self.session.has_pending()
            with self.state:                          # one flush: never idle in between
                self.state.running = False
                self.state.at_end = self.session.at_end
                self.state.busy = self.state.busy or measure
        if measure:
            try:
                await asyncio.sleep(MEASURE_AFTER)
                await self._measure()
            except Exception as e:                    # noqa: BLE001  measuring
                self.session.action_messages = [describe(e)]
                self._messages()
            finally:
                self._end_busy()

    # ------------------------------------------------------------------ reactions
    @change("history_index")
    def on_history_index(self, history_index, **_):
        """Show the stage the slider points at; while busy, remember it for when idle."""
        if self.state.running or self._echo:
            return
        if self.state.busy:
            self._wanted_stage = int(history_index)
            return
        self._wanted_stage = None                 # this move is the latest
        if int(history_index) == self.session.index:
            return
        with self.state:
            self.state.busy = True                # the next key press waits its turn
        asynchronous.create_task(self._act(lambda: self.session.scrub(history_index)))

    @change("z_scale", "colour_by", "q_sign_edges", "edges", "isotropic")
    def on_view_option(self, **_):
        """Redraw the stage shown with the new option, now or when the work in hand is done."""
        if self.state.busy:
            self._options_changed = True
        else:
            self._redraw()

    @change("maximised")
    def on_maximised(self, maximised, **_):
        """A view grew or shrank: let the remote views fetch frames at their new size, and fit
        the shared top-down camera to the top views on show."""
        top = tuple(n for n in ("mesh", "quality") if not maximised or n == maximised)
        self.views.top_views = top or ("mesh", "quality")
        for view in self.html_views.values():
            view.resize()
        asynchronous.create_task(self._after_resize())

    async def _after_resize(self) -> None:
        await asyncio.sleep(0.3)                     # the browser has laid the page out again
        self.views.fit_top()
        self.views.fit_lifted()
        self.views.apply_edges()
        self._push()

    def on_s_enter(self, text=None) -> None:
        """Enter in the s(x, y) field: mesh that s from the start (also when unchanged)."""
        asynchronous.create_task(self._apply_s(str(text if text is not None
                                                     else self.state.s_input or "")))

    @change("s_preset")
    def on_s_preset(self, s_preset, **_):
        if s_preset:
            self.state.s_input = s_preset
            self.state.s_preset = None
            asynchronous.create_task(self._apply_s(s_preset))

    async def _apply_s(self, text: str) -> None:
        """Re-mesh with s(x, y) = text; a refused text keeps the last mesh, its error (red,
        "not applied: …") goes under the field, the text stays there to be corrected, and the
        line below names the s the views still show."""
        self.session.stop()
        await self._when_idle()
        outcome = await self._act(lambda: self.session.apply_s(text))
        with self.state:
            self.state.s_error = "" if outcome.ok else f"not applied: {outcome.message}"
            self._settle_controls({})
            if not outcome.ok:
                self.state.s_input = text

    @change("domain_file")
    def on_domain_file(self, domain_file, **_):
        """A polygon file arrived from the browser: read it, offer it and mesh it. The file
        field is cleared either way: the domain list names what is on screen."""
        if not domain_file:
            return
        from trame.app.file_upload import ClientFile
        try:
            upload = ClientFile(domain_file)
            name, content = upload.name, upload.content
        except Exception as e:                         # noqa: BLE001  (a forged value)
            name, content = str(type(e).__name__), e
        asynchronous.create_task(self._upload(name, content))

    async def _upload(self, name, content) -> None:
        self.session.stop()
        await self._when_idle()
        if isinstance(content, Exception):
            self.session.action_messages = [f"the uploaded file could not be read: {content}"]
            self._messages()
            self._offer_domains()
        else:
            await self._act(lambda: self.session.upload(name, content), then=self._offer_domains)

    def _offer_domains(self) -> None:
        """The domain list names what is on screen (an upload added to it) and the file field
        is cleared either way."""
        with self.state:
            self.state.domain_file = None
            self.state.domain_items = self.session.domain_names()
            self._settle_controls({})

    def on_control(self, name: str, **state) -> None:
        """A slider or select moved: submit its value (the last one wins) unless it is the value
        in force with nothing newer pending (the server's own write, or no change)."""
        value = state.get(name, self.state[name])
        if value == getattr(self.session.params, name) and not self.session.has_pending(name):
            return
        self._submit(name, value)

    def on_text(self, name: str, text) -> None:
        """A text field's value, sent on Enter or blur (never per keystroke)."""
        if str(text).strip() == str(getattr(self.session.params, name)):
            return
        self._submit(name, str(text).strip())

    def _submit(self, name: str, value) -> None:
        """Hand the value to the session. Refused before any meshing: the control gets the
        value in force back and a running Run goes on; else the Run stops and the drain task
        applies it (and restarts the Run if the mesher refuses it: a refusal never stops it)."""
        running = bool(self.state.running)
        refused = self.session.submit(name, value)
        if refused is not None:
            self._messages()
            self._settle_controls({name: value})
            return
        self._resume = self._resume or running
        if self._drain_task is None or self._drain_task.done():
            self._drain_task = asynchronous.create_task(self._drain())

    async def _drain(self) -> None:
        """Apply the submitted changes, a batch at a time, until none is left."""
        while self.session.has_pending():
            await self._when_idle()
            while self.state.running:                  # the submit stopped it; let it end
                await asyncio.sleep(0.02)
            changes = self.session.take_pending()
            if not changes:
                continue
            run = self.session.controller
            outcome = await self._act(lambda: self.session.change(**changes))
            self._settle_controls(changes)
            if outcome.kind == "unchanged":
                self._messages()
            if (not outcome.ok and self._resume and self.session.controller is run
                    and not self.session.has_pending() and not self.session.at_end):
                self._resume = False
                asynchronous.create_task(self._run())      # the refused change stops nothing
            elif outcome.ok:
                self._resume = False

    # ------------------------------------------------------------------ cameras
    def _link_cameras(self) -> None:
        """After the user moves a camera: edges for the new zoom; mesh and quality share one
        camera, so both are pushed."""
        if self.view_mode == "local":
            return
        for source in VIEWS:
            iren = self.views.plotters[source].iren.interactor
            iren.AddObserver("EndInteractionEvent", lambda *_: self._after_camera())

    def _after_camera(self) -> None:
        looks_before = dict(self._edge_looks) if hasattr(self, "_edge_looks") else None
        fine_before = self.views.fine_facets
        self._edge_looks = self.views.apply_edges()
        with self.state:                  # the quality legend says which q_ij lines are drawn
            self.state.update(legend.state(self.views.legend))
        for name in ("mesh", "quality"):
            self.html_views[name].update()
        if (looks_before is not None and looks_before.get("lifted") != self._edge_looks["lifted"]
                or fine_before != self.views.fine_facets):
            self.html_views["lifted"].update()

    # ------------------------------------------------------------------ layout
    def _build_ui(self) -> None:
        with SinglePageWithDrawerLayout(self.server, width=330, full_height=True) as layout:
            layout.title.set_text("qmesh-view")
            layout.title.title = TITLE_TIP
            self.state.trame__title = TITLE
            self._toolbar(layout.toolbar)
            with layout.drawer:
                self._parameters()
            with layout.content:
                client.Script(delivery.ARRAY_BUFFER_SOCKET)   # frames decoded on arrival
                client.Style(delivery.QUIET_PAGE)             # nothing animates meanwhile
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
            v3.VProgressLinear(model_value=100, absolute=True, location="bottom",
                               v_show=("busy",), color="primary", id="busy")

    def _parameters(self) -> None:
        with v3.VContainer(classes="pa-3", style="font-size: 0.85rem"):
            html.Div("Conductivity", classes="text-subtitle-2")
            html.Div("{{ regions_text }}", v_show=("regions_text",), id="media-readout",
                     classes="my-2 text-body-2")
            with html.Div(id="q-mode", classes="my-1", v_show=("!regions_text",)):
                with v3.VBtnToggle(v_model=("q_mode",), mandatory=True, density="compact",
                                   variant="outlined", divided=True):
                    v3.VBtn("constant Q", value="constant", size="small")
                    v3.VBtn("s(x, y)", value="expression", size="small")
            with html.Div(v_show=("q_mode === 'constant' && !regions_text",)):
                html.Div("principal values and the angle of k1",
                         classes="text-caption text-medium-emphasis")
                slider("k1", "k1", 0.05, 20, 0.05, aria="k1, the conductivity along the angle")
                slider("k2", "k2", 0.05, 20, 0.05, aria="k2, the conductivity across it")
                slider("angle", "angle", 0, 180, 5, shown="angle + '°'",
                       aria="angle of k1 in degrees")
                html.Div("Q11 = {{ q11.toPrecision(4) * 1 }} · Q12 = {{ q12.toPrecision(4) * 1 }}"
                         " · Q22 = {{ q22.toPrecision(4) * 1 }}", classes="my-2", id="q-readout")
            with html.Div(v_show=("q_mode === 'expression' && !regions_text",)):
                with html.Div(id="field-s"):
                    v3.VTextField(v_model=("s_input",), label="s(x, y)", density="compact",
                                  error_messages=("s_error ? [s_error] : []",),
                                  hint="Enter re-meshes; x, y, numbers, + − * / **, exp log "
                                       "sqrt cosh …", persistent_hint=False,
                                  __events=[("on_enter", "keydown.enter")],
                                  on_enter=(self.on_s_enter, "[$event.target.value]"),
                                  classes="my-1",
                                  spellcheck="false", autocomplete="off")
                html.Div("the views show s(x, y) = {{ s_shown }}", v_show=("s_shown",),
                         id="s-shown", classes="text-caption",
                         style="overflow-wrap: anywhere")
                with html.Div(id="select-s-preset"):
                    v3.VSelect(v_model=("s_preset", None), items=("s_presets",),
                               label="presets", density="compact", hide_details=True,
                               classes="my-1")
            v3.VDivider(classes="my-2")
            html.Div("Domain and mesher", classes="text-subtitle-2")
            with html.Div(id="select-domain"):
                v3.VSelect(v_model=("domain",), label="domain", items=("domain_items",),
                           density="compact", hide_details=True, classes="my-2")
            with html.Div(id="upload-domain"):
                v3.VFileInput(v_model=("domain_file", None), label="polygon file (CSV, GeoJSON)",
                              accept=".csv,.txt,.geojson,.json", density="compact",
                              hide_details=True, prepend_icon="", clearable=True,
                              classes="my-1")
            with html.Div(v_show=(f"domain === '{DISK}'",)):
                slider("vb", "VB", 8, 512, 1, aria="VB, seed points on the disk")
                html.Div("VB (seed points) stays below the target: moving one moves the other.",
                         classes="text-caption text-medium-emphasis")
            for name, label in (("target_vertices", "target vertices"), ("seed", "seed")):
                with html.Div(id=f"field-{'target' if name == 'target_vertices' else name}"):
                    typed = f"['{name}', $event.target.value]"
                    v3.VTextField(model_value=(name,), label=label, type="number",
                                  key=(f"rev_{name}",),
                                  density="compact", hide_details=True, classes="my-2",
                                  __events=[("on_enter", "keydown.enter")],
                                  on_enter=(self.on_text, typed), blur=(self.on_text, typed),
                                  hint="Enter or leaving the field applies it")
            v3.VDivider(classes="my-2")
            html.Div("Views", classes="text-subtitle-2")
            with html.Div(v_show=("!field_view",)):        # a field has no lifted surface
                slider("z_scale", "z-scale", 0.1, 3, 0.1, shown="Number(z_scale).toFixed(1)",
                       aria="z-scale of the lifted surface")
            with html.Div(id="select-colour-by", title=COLOUR_BY_TIP):
                v3.VSelect(v_model=("colour_by",), label="colour by", density="compact",
                           items=(COLOUR_BY,),
                           hide_details=True, classes="my-2")
            with html.Div(id="switch-q-sign", v_show=("colour_by !== 'solution'",)):
                v3.VSwitch(v_model=("q_sign_edges",), label="edges by sign of q_ij",
                           density="compact", hide_details=True, color="primary")
            with html.Div(id="switch-isotropic", v_show=("colour_by === 'solution'",)):
                v3.VSwitch(v_model=("isotropic",), label="compare: isotropic mesh of the same N",
                           density="compact", hide_details=True, color="primary")
                html.Div("u_h of −div(Q∇u) = 0, u = 1 on the left of the boundary, 0 on the "
                         "rest; the legend counts the vertices outside [0, 1] on both meshes",
                         classes="text-caption text-medium-emphasis")
            with html.Div(classes="d-flex align-center", id="edges-toggle"):
                html.Span("edges", classes="mr-3")
                with v3.VBtnToggle(v_model=("edges",), mandatory=True, density="compact",
                                   variant="outlined", divided=True):
                    for mode in ("auto", "on", "off"):
                        v3.VBtn(mode, value=mode, size="small")
            html.Div("auto: drawn while they can be told apart, lighter when crowded, "
                     "hidden when denser still (zoom in to see them)",
                     classes="text-caption text-medium-emphasis")

    def _main(self) -> None:
        with v3.VContainer(fluid=True, classes="pa-2"):
            html.Div("{{ status_line }}", id="status-line",
                     classes="text-body-2 font-weight-medium px-2")
            # refusals and warnings, one per line: three lines high, so the views below never
            # move; more than three scroll (every message stays readable)
            html.Div("{{ messages }}", id="messages", title=("messages",),
                     classes="text-body-2 px-2",
                     style="height: 3.9em; line-height: 1.3em; overflow-y: auto; "
                           "white-space: pre-line; overflow-wrap: anywhere; color: #b3261e")
            with html.Div(classes="d-flex align-center px-2 mt-1", id="history-row"):
                html.Span("stage", classes="text-body-2 mr-3")
                with html.Div(style="flex: 1 1 auto"):
                    slider("history_index", None, 0, ("history_length - 1",), 1,
                           shown="history_index + ' / ' + (history_length - 1)",
                           aria="stage shown, from the history of the run",
                           disabled=("running",))
            self.html_views = {}
            with html.Div(id="views", classes="mt-1",
                          style=("{display: 'grid', gap: '6px', resize: 'vertical',"
                                 " overflow: 'hidden', minHeight: '320px',"
                                 f" height: '{VIEW_HEIGHT}',"
                                 " gridTemplateRows: 'minmax(0, 1fr) auto',"
                                 " gridTemplateColumns: maximised ? '1fr' : 'repeat(3, 1fr)'}",)):
                for name in VIEWS:
                    self._view_card(name)
            self._chart_row()

    def _view_card(self, name: str) -> None:
        """One view: title and maximise button, the picture filling the card, its legend below.

        The card spans two rows of the views' grid (picture, legend) as a subgrid, so the legend
        row is as high as the tallest of the three legends: every legend shows in full and the
        three pictures keep one height (mesh and quality share a camera, so one scale)."""
        with html.Div(v_show=(f"!maximised || maximised === '{name}'",), id=f"card-{name}",
                      classes="qmesh-card",
                      style="display: grid; grid-row: span 2; grid-template-rows: subgrid; "
                            "min-width: 0; min-height: 0; border: thin solid "
                            "rgba(0, 0, 0, 0.25); border-radius: 4px; overflow: hidden"):
            with html.Div(classes="d-flex flex-column", style="min-height: 0"):
                with html.Div(classes="d-flex align-center px-2"):
                    html.Span(f"{{{{ title_{name} }}}}", classes="text-caption text-truncate",
                              id=f"title-{name}",       # a field's first view: ellipses
                              title=(f"tip_{name}",))   # the chapter's words and numbers
                    v3.VSpacer()
                    v3.VBtn(icon=(f"maximised === '{name}' ? 'mdi-arrow-collapse' :"
                                  " 'mdi-arrow-expand'",),
                            size="x-small", variant="text", id=f"max-{name}",
                            click=f"maximised = (maximised === '{name}' ? '' : '{name}')",
                            title="maximise / restore this view")
                with html.Div(style="position: relative; flex: 1 1 auto; min-height: 160px",
                              id=f"view-{name}"):
                    if self.view_mode == "local":
                        self.html_views[name] = vtk_widgets.VtkLocalView(
                            self.views.plotters[name].render_window,
                            ref=f"view_{name}", style="position: absolute; inset: 0")
                    else:
                        self.html_views[name] = vtk_widgets.VtkRemoteView(
                            self.views.plotters[name].render_window,
                            ref=f"view_{name}", interactive_ratio=1, still_quality=90,
                            style="position: absolute; inset: 0")
            legend.html_legend(name)

    def _chart_row(self) -> None:
        """The convergence chart: E (log scale), κ2 and N at the end of every iteration."""
        with v3.VRow(classes="ma-0 mt-2", id="chart"):
            for key, label, colour in CHART_SERIES:
                with v3.VCol(cols=4, classes="pa-1"):
                    with v3.VSheet(border=True, rounded=True, classes="pa-2"):
                        # one line at any width: a caption that wrapped as the page was
                        # laid out grew the row, a ResizeObserver loop on every load
                        with html.Div(classes="d-flex text-caption flex-nowrap",
                                      title=CHART_TIPS[key]):
                            html.Span(label, classes="font-weight-medium text-truncate")
                            v3.VSpacer()
                            html.Span(f"{{{{ chart_labels.{key} }}}}",
                                      classes="flex-shrink-0 ml-2 text-no-wrap")
                        shown = {}
                        if key == "chart_energy":          # a field has no s, so no energy
                            html.Div(NO_ENERGY, v_if=("field_view",), id="no-energy",
                                     classes="text-caption text-medium-emphasis d-flex "
                                             "align-center justify-center",
                                     style="height: 60px")
                            shown = {"v_else": True}
                        v3.VSparkline(model_value=(key,), color=colour, height=60,
                                      line_width=1.5, padding=6, smooth=False,
                                      auto_line_width=False, **shown)

    # ------------------------------------------------------------------ life cycle
    def close(self) -> None:
        """Stop the worker thread and release the plotters."""
        self.state.running = False
        self._worker.shutdown(wait=True, cancel_futures=True)
        self._scene_worker.shutdown(wait=True, cancel_futures=True)
        self.views.close()
