"""The viewer's one source of truth, free of any UI toolkit: what the trame app and the widget bind to.

A `Session` holds the parameters in force and the run on screen (a `Controller`: its history of
Steps and which one is shown). Every action returns an `Outcome`:

- `change(name, value)` / `change(**changes)`: applied; adjusted (a dependent value moved with
  it, VB and the target, and the message says so); refused (the reason; everything kept);
  unchanged. A new parameter set is checked, its whole request (mesher, kept stages, measures
  and views) measured against the memory budget (`qmesh_view.memory`) and triangulated *before* it replaces the run on screen, so a refusal
  or any exception (MemoryError, RecursionError …) leaves the previous mesh and history in place.
- `apply_s(text)`, `upload(name, content)`, `step()`, `iterate()`, `scrub(i)`, `reset()`.
- `run(on_step, work=…)`: the one animated run loop (async), stopped by `stop()` or by the next
  change submitted.

Changes arriving faster than a re-mesh are coalesced: `submit(name, value)` keeps the last value
per control (and stops a run), `take_pending()` hands them over in the order they were last
changed, so the last value always wins. `messages` are the refusals and warnings (every
`QmeshWarning` and the run's own diagnosis) to show next to the status line.
"""

from __future__ import annotations

import asyncio
import inspect
import re
import threading
import warnings
from dataclasses import asdict, dataclass

from qmesh.errors import QmeshError, QmeshWarning
from qmesh.mesher import diagnose

from . import memory
from .controller import PARAMS, Controller, Params, _checked, reconcile
from .problem import FILE_PREFIX, domain_names, read_upload

REGION_WORD = re.compile(r"\bregion (\d+)\b(?! \()")
RUN_PAUSE = 0.05     # seconds between animated stages, so every frame reaches the screen
MAX_RUN_PAUSE = 60.0  # seconds: Run's longest hold per stage the viewer accepts


def check_run_pause(value) -> float:
    """Seconds Run holds each stage: a number from 0 to MAX_RUN_PAUSE, else a QmeshError."""
    try:
        pause = float(value)
    except (TypeError, ValueError):
        raise QmeshError(f"the run pause must be a number of seconds, got {value!r}") from None
    if not 0 <= pause <= MAX_RUN_PAUSE:
        raise QmeshError(f"the run pause must be from 0 to {MAX_RUN_PAUSE:g} seconds, "
                         f"got {value!r}")
    return pause
LABELS = {"vb": "VB", "target_vertices": "target vertices"}


@dataclass(frozen=True)
class Outcome:
    """What became of an action: "applied", "adjusted", "refused" or "unchanged", and why."""

    kind: str
    message: str = ""

    @property
    def ok(self) -> bool:
        return self.kind != "refused"


def describe(error: BaseException) -> str:
    """An exception as one line for the page: QmeshError's own message, others with their type."""
    if isinstance(error, QmeshError):
        return str(error)
    text = str(error) or "no message"
    return f"{type(error).__name__}: {text}"[:400]


class Session:
    """Parameters in force, the run on screen, pending changes and the messages for the page."""

    def __init__(self, *, memory_budget: int | None = None, **params):
        self.memory_budget = None if memory_budget is None else int(memory_budget)
        self.uploads: dict = {}
        p = _checked(Params(**params))
        self._check_budget(p)
        self.action_messages: list[str] = []
        with warnings.catch_warnings(record=True) as caught:     # to the message row, not stderr
            warnings.simplefilter("always", QmeshWarning)
            self._run = Controller(uploads=self.uploads, **asdict(p))
        self.action_messages = self._said(caught)
        self._pending: dict = {}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.running = False
        self._notes: dict = {}

    # ------------------------------------------------------------------ what is on screen
    @property
    def params(self) -> Params:
        return self._run.params

    @property
    def controller(self) -> Controller:
        return self._run

    history = property(lambda self: self._run.history)
    index = property(lambda self: self._run.index)
    current = property(lambda self: self._run.current)
    at_end = property(lambda self: self._run.at_end)
    done = property(lambda self: self._run.done)
    anisotropy = property(lambda self: self._run.anisotropy)
    domain = property(lambda self: self._run.domain)
    readout = property(lambda self: self._run.readout)
    q = property(lambda self: self._run.q)
    regions = property(lambda self: self._run.regions)      # a medium's regions, else []

    def domain_names(self) -> list[str]:
        return domain_names(self.uploads)

    def status(self, index: int | None = None, *, quick: bool = False,
               bare: bool = False) -> dict:
        """The status line's numbers of stage `index` (default: shown) and its `notes`: the
        warnings about that stage (a domain too thin for the size, κ2 undefined); `quick` and
        `bare` as `Controller.status`."""
        i = self.index if index is None else int(index)
        row = self._run.status(i, quick=quick, bare=bare)
        row["notes"] = [] if quick else self._stage_notes(i, row)
        return row

    def convergence(self) -> dict:
        return self._run.convergence()

    @property
    def messages(self) -> list[str]:
        """Refusals and warnings of the last action, then those about the stage on screen."""
        return list(self.action_messages) + list(self._notes.get((id(self._run), self.index), []))

    def _stage_notes(self, i: int, row: dict) -> list[str]:
        key = (id(self._run), i)
        if key not in self._notes:
            notes = []
            step = self._run.history[i]
            if step.stage == "triangulate" and not self._run.is_field:   # a field's mesher warns itself
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    try:
                        thin = diagnose.thin_domain(step.mesh, self._run.anisotropy)
                    except Exception:                          # a diagnosis never breaks a view
                        thin = None
                if thin:
                    notes.append(f"warning: {thin}")
            if row.get("kappa2_reason"):                     # shown as "—" in the status line
                notes.append(f"κ2 is undefined: {row['kappa2_reason']}")
            if self._run.done and i == len(self._run.history) - 1 or step.converged:
                target, n = self.params.target_vertices, step.mesh.n_vertices
                if abs(n - target) > 0.1 * target:
                    notes.append(f"warning: the run ended with N = {n}, "
                                 f"{100 * (n - target) / target:+.0f}% off the target {target}")
            if len(self._notes) > 64:
                self._notes.clear()
            self._notes[key] = notes
        return self._notes[key]

    # ------------------------------------------------------------------ every action
    def _guard(self, action) -> Outcome:
        """Run `action()`; any exception becomes a refusal (the state it left is the old one),
        every QmeshWarning it raised a message."""
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", QmeshWarning)
            try:
                outcome = action()
            except Exception as e:                     # noqa: BLE001  (MemoryError included)
                outcome = Outcome("refused", describe(e))
        self.action_messages = ([self.named(outcome.message)] if outcome.message else []
                                ) + self._said(caught)
        return outcome

    def _said(self, caught) -> list[str]:
        return [self.named(f"warning: {w.message}") for w in caught
                if issubclass(w.category, QmeshWarning)]

    def named(self, text: str) -> str:
        """`text` with a medium's "region 3" also named as the legend names it: "region 3
        (layer 4)" (the mesher numbers regions by tag; the viewer's names count from 1)."""
        try:
            names = {r["tag"]: r["name"] for r in self._run.regions}
        except Exception:                              # noqa: BLE001  a message never fails
            names = {}
        if not names:
            return text
        def name(m):
            tag = int(m.group(1))
            return f"region {tag} ({names[tag]})" if tag in names else m.group(0)
        return REGION_WORD.sub(name, text)

    def _check_budget(self, p: Params) -> None:
        """Refuse `p` when its whole request (mesher, kept stages, measures, views) would not
        fit beside what the process holds now (`qmesh_view.memory`)."""
        memory.check(p.target_vertices, memory.kind_of(p), self.memory_budget)

    def _start(self, p: Params, uploads: dict | None = None) -> None:
        """Build the run of `p` (its first triangulation); swap it in only when that worked."""
        self._check_budget(p)
        uploads = self.uploads if uploads is None else uploads
        run = Controller(uploads=uploads, **asdict(p))
        self._run, self.uploads = run, uploads

    # ------------------------------------------------------------------ parameters
    def change(self, name: str | None = None, value=None, /, **changes) -> Outcome:
        """Set parameters (in the order given: a later one wins over an earlier one); the run
        restarts from its first triangulation. VB and the target move together."""
        if name is not None:
            changes = {name: value, **changes}
        return self._guard(lambda: self._change(changes))

    def _plan(self, changes: dict) -> tuple[Params, list[str], list[str]]:
        """The parameters `changes` lead to (each checked in turn; a refused one skipped), the
        notes on values adjusted with them, and the refusals."""
        unknown = sorted(set(changes) - set(PARAMS))
        if unknown:
            raise QmeshError(f"unknown parameter(s) {unknown}; known: {PARAMS}")
        p, notes, refusals = self.params, [], []
        for name, value in changes.items():
            step = reconcile(p, {name: value})
            try:
                q = _checked(p.replace(**step))
            except QmeshError as e:
                refusals.append(str(e))
                continue
            for other in step:
                if name == "domain":        # the domain's own default target: said by its field
                    continue
                if other != name and getattr(q, other) != getattr(p, other):
                    notes.append(f"{LABELS[other]} set to {getattr(q, other)} so that VB stays "
                                 f"below the target")
            p = q
        return p, notes, refusals

    def refusal(self, name: str, value) -> Outcome | None:
        """The refusal of setting `name` to `value` after what is pending, when it can be told
        without meshing (not a number, out of range, over the memory budget); else None."""
        with self._lock:
            pending = {k: v for k, v in self._pending.items() if k != name}
        try:
            before, _, _ = self._plan(pending)
            after, _, refusals = self._plan({**pending, name: value})
            if refusals and after == before:
                return Outcome("refused", self.named("; ".join(refusals)))
            if after != before:
                self._check_budget(after)
        except QmeshError as e:
            return Outcome("refused", self.named(str(e)))
        return None

    def _change(self, changes: dict) -> Outcome:
        p, notes, refusals = self._plan(changes)
        if p == self.params:
            return Outcome("refused", "; ".join(refusals)) if refusals else Outcome("unchanged")
        self._start(p)
        kind = "adjusted" if notes or refusals else "applied"
        return Outcome(kind, "; ".join(refusals + notes))

    def apply_s(self, text) -> Outcome:
        """Mesh s(x, y) = `text` from the start (also when it is the text in force)."""
        def apply():
            p = _checked(self.params.replace(q_mode="expression", s_text=text))
            self._start(p)
            return Outcome("applied")
        return self._guard(apply)

    def upload(self, name: str, content) -> Outcome:
        """Read a polygon file (CSV or GeoJSON), offer it as the domain "file: <name>" and mesh
        it; a bad file, or one the target cannot fill, changes nothing."""
        def add():
            if not isinstance(name, str) or not name:
                raise QmeshError(f"an uploaded file needs a name, got {name!r}")
            domain = read_upload(name, content)
            p = self.params.replace(domain=FILE_PREFIX + name)
            self._start(_checked(p), {**self.uploads, name: domain})
            return Outcome("applied")
        return self._guard(add)

    # ------------------------------------------------------------------ coalescing
    def submit(self, name: str, value) -> Outcome | None:
        """A control moved: keep its value (the last one wins) and stop a run in progress.

        A value refused before any meshing (`refusal`) is not kept and stops nothing: a running
        Run goes on, the refusal is returned and becomes the message."""
        refused = self.refusal(name, value)
        with self._lock:
            self._pending.pop(name, None)
            if refused is None:
                self._pending[name] = value
        if refused is not None:
            self.action_messages = [refused.message]
            return refused
        self._stop.set()
        return None

    def take_pending(self) -> dict:
        """The changes submitted since the last call, in the order they were last changed."""
        with self._lock:
            out, self._pending = self._pending, {}
        return out

    def has_pending(self, name: str | None = None) -> bool:
        with self._lock:
            return bool(self._pending) if name is None else name in self._pending

    def apply_pending(self) -> Outcome | None:
        """Apply what was submitted, in one re-mesh; None when nothing was pending."""
        changes = self.take_pending()
        return self.change(**changes) if changes else None

    # ------------------------------------------------------------------ moving through the run
    def _move(self, move) -> Outcome:
        return self._guard(lambda: Outcome("applied" if move() is not False else "unchanged"))

    def step(self) -> Outcome:
        return self._move(self._run.step)

    def iterate(self) -> Outcome:
        return self._move(self._run.iterate)

    def scrub(self, index) -> Outcome:
        return self._move(lambda: self._run.scrub(index))

    def reset(self) -> Outcome:
        """Back to the first triangulation (a new run of the same parameters)."""
        def again():
            self._start(self.params)
            return Outcome("applied")
        return self._guard(again)

    async def run(self, on_step=None, *, work=None, pause: float = RUN_PAUSE) -> Outcome:
        """Step until the end, `stop()` or a submitted change; after every stage await
        `on_step(outcome)` (draw there). `work(fn)` runs a stage (e.g. in a worker thread: an
        awaitable); by default on the calling thread. The last stage's outcome is returned."""
        self._stop.clear()
        self.running = True
        outcome = Outcome("unchanged")
        try:
            while not self._stop.is_set() and not self.at_end:
                outcome = self.step() if work is None else await work(self.step)
                if outcome.kind != "applied":
                    break
                if on_step is not None:
                    done = on_step(outcome)
                    if inspect.isawaitable(done):
                        await done
                if pause:
                    await asyncio.sleep(pause)
        finally:
            self.running = False
        return outcome

    def stop(self) -> None:
        """Ask a `run` to return after its current stage."""
        self._stop.set()

    @property
    def stopping(self) -> bool:
        """True once a `run` was asked to stop (`stop()` or a submitted change)."""
        return self._stop.is_set()
