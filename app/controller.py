"""One run of Algorithm 2.1 for one parameter set, and its history; the parameters themselves.

Algorithm 2.1 runs as one generator (`qmesh.iterate`); every Step it yields is kept, so the
history slider scrubs through stages already computed and Step/Iterate replay them before asking
the generator for more. A parameter change makes a new `Controller` (the session swaps it in only
once its first triangulation exists). `qmesh_view.session.Session` drives this class; the trame
app and the Jupyter widget drive the session.
"""

from __future__ import annotations

import math
from decimal import Decimal, InvalidOperation
from dataclasses import dataclass, fields

import numpy as np

import qmesh
from qmesh import measure
from qmesh.errors import QmeshError

from .ahead import Ahead
from .problem import (DISK, Q_MODES, S_PRESETS, default_target, element_means, field_text,
                      is_field_conductivity, make_anisotropy, make_domain, q_matrix, regions,
                      regions_text)

PARAMS = ("k1", "k2", "angle", "vb", "target_vertices", "alpha", "seed", "domain", "q_mode",
          "s_text")
Q_PARAMS = ("k1", "k2", "angle")


@dataclass(frozen=True)
class Params:
    """What defines one run. The chapter's case (2.95): Q = diag(0.1, 10), VB = 64, N ≈ 212.

    Q is given by its principal conductivities and the angle of k1's axis, so it is SPD by
    construction: k1 = 0.1 along x (angle 0) and k2 = 10 along y. `target_vertices` None is
    the domain's own default (`problem.default_target`: 212 but for the presets that need more).
    """

    k1: float = 0.1
    k2: float = 10.0
    angle: float = 0.0
    vb: int = 64
    target_vertices: int | None = None
    alpha: float = 0.5
    seed: int = 0
    domain: str = "disk"
    q_mode: str = "constant"
    s_text: str = S_PRESETS[0]

    def replace(self, **changes) -> "Params":
        return Params(**{**{f.name: getattr(self, f.name) for f in fields(self)}, **changes})


def _integer(name: str, value) -> int:
    """An integer: an int, an integral float, or text naming one, also with an exponent ("2e7",
    "1.5e4": what people type for large counts); anything else is refused."""
    refused = QmeshError(f"{name} must be an integer, got {value!r}")
    if isinstance(value, bool):
        raise refused
    if isinstance(value, str):
        try:
            number = Decimal(value.strip())
        except InvalidOperation:
            raise refused from None
        if not number.is_finite() or number != number.to_integral_value():
            raise refused
        if number.adjusted() > 30:              # int() of 1e999999999 would take minutes
            raise QmeshError(f"{name} is far too large, got {value!r}")
        return int(number)
    try:
        out = int(value)
        exact = out == value
    except (TypeError, ValueError, OverflowError):
        raise refused from None
    if not exact:
        raise refused
    return out


def _real(name: str, value) -> float:
    if isinstance(value, bool):
        raise QmeshError(f"{name} must be a number, got {value!r}")
    try:
        out = float(value)
    except (TypeError, ValueError, OverflowError):
        raise QmeshError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(out):
        raise QmeshError(f"{name} must be finite, got {value!r}")
    return out


def _checked(p: Params) -> Params:
    """Coerce the fields to their types and refuse bad values with QmeshError (nothing built)."""
    if not isinstance(p.domain, str):
        raise QmeshError(f"domain must be a name, got {type(p.domain).__name__}")
    k1, k2, angle, alpha = (_real(n, getattr(p, n)) for n in ("k1", "k2", "angle", "alpha"))
    if p.target_vertices is None:
        p = p.replace(target_vertices=default_target(p.domain))
    vb, target, seed = (_integer(n, getattr(p, n)) for n in ("vb", "target_vertices", "seed"))
    for name, k in (("k1", k1), ("k2", k2)):
        if k <= 0:
            raise QmeshError(f"{name} must be > 0 (Q is positive definite), got {k}")
    if vb < 3:
        raise QmeshError(f"vb must be at least 3 (a triangle), got {vb}")
    if seed < 0:
        raise QmeshError(f"seed must be ≥ 0, got {seed}")
    if not (0.0 < alpha <= 1.0):
        raise QmeshError(f"alpha must be in (0, 1], got {alpha}")
    if p.domain == DISK and target <= vb:
        raise QmeshError(f"target_vertices ({target}) must exceed VB ({vb}), the seed points")
    if p.q_mode not in Q_MODES:
        raise QmeshError(f"q_mode must be one of {Q_MODES}, got {p.q_mode!r}")
    if not isinstance(p.s_text, str):
        raise QmeshError(f"s_text must be text, got {type(p.s_text).__name__}")
    return Params(k1, k2, angle, vb, target, alpha, seed, p.domain, p.q_mode, p.s_text)


def reconcile(params: Params, changes: dict) -> dict:
    """`changes` with the dependent value adjusted so the seed count VB stays below the target N.

    The value the user just moved wins and the other follows: VB moved to ≥ N raises N to VB + 1;
    N moved to ≤ VB lowers VB to N − 1 (never below 3, the smallest polygon). Both given at once,
    or values that are not integers, are left for `_checked` to accept or reject.

    A new domain brings its own default target (`problem.default_target`) when the target in
    force is the old domain's default: a preset opens where it meshes without a warning, and a
    target the user chose stays.
    """
    out = dict(changes)
    new = changes.get("domain")
    if (isinstance(new, str) and new != params.domain and "target_vertices" not in changes
            and params.target_vertices == default_target(params.domain)):
        out["target_vertices"] = default_target(new)
    if "vb" in changes and "target_vertices" in changes:
        return out
    if out.get("domain", params.domain) != DISK:
        return out                                  # VB is the disk's; other seeds are fixed
    try:
        vb = int(out.get("vb", params.vb))
        target = int(out.get("target_vertices", params.target_vertices))
    except (TypeError, ValueError):
        return out
    if target > vb:
        return out
    if "target_vertices" in changes and target - 1 >= 3:
        out["vb"] = target - 1
    elif "vb" in changes:
        out["target_vertices"] = vb + 1
    return out


class Controller:
    """One run: its parameters (fixed), the Steps computed so far and which one is shown.

    `step()` shows the next stage, `iterate()` the end of the next iteration, `scrub(i)` shows
    stage i, `finish()` steps to the end, `reset()` starts again. `Controller(**params)` checks the parameters and builds the
    first triangulation; `uploads` (name → Domain) are the polygon files offered as domains.
    Not thread-safe: the session calls one method at a time.
    """

    def __init__(self, *, uploads: dict | None = None, **params):
        self.params = _checked(Params(**params))
        self.uploads: dict[str, qmesh.Domain] = {} if uploads is None else uploads
        self._cache: dict[int, dict] = {}
        self._figures: dict[int, dict] = {}   # quick rows with the Step's figures, by stage
        self.reset()

    # ------------------------------------------------------------------ the run
    @property
    def anisotropy(self):
        """The conductivity meshed: one `qmesh.Anisotropy`, `{region tag: Anisotropy}` for a
        media preset, or a `qmesh.TensorField` for a field preset."""
        return self._anisotropy

    @property
    def is_field(self) -> bool:
        """True when the conductivity is a field Q(x) (no s)."""
        return is_field_conductivity(self._anisotropy)

    def conductivity_of(self, step):
        """What stage `step` is measured with: a field's element means per triangle (the
        certified ones its last Step carries, else the field's own means on that mesh);
        otherwise the conductivity itself."""
        if self.is_field:
            return element_means(step.mesh, self._anisotropy)
        return self._anisotropy

    @property
    def regions(self) -> list[dict]:
        """A medium's regions (tag, name, q11, q12, q22); [] for one conductivity."""
        names = self.history[0].mesh.region_names if self.history else None
        return regions(self.params.domain, self._anisotropy, names)

    @property
    def domain(self) -> qmesh.Domain:
        return self._domain

    @property
    def q(self) -> np.ndarray:
        """The 2×2 conductivity Q of the parameters (k1, k2, angle)."""
        p = self.params
        return q_matrix(p.k1, p.k2, p.angle)

    @property
    def readout(self) -> dict:
        """Q11, Q12, Q22 of the parameters, and `regions_text`: what replaces them when they do
        not apply — a medium's Q per region, or a field preset's name and label; "" otherwise."""
        Q = self.q
        text = (field_text(self.params.domain, self._anisotropy) if self.is_field
                else regions_text(self.regions))
        return {"q11": float(Q[0, 0]), "q12": float(Q[0, 1]), "q22": float(Q[1, 1]),
                "regions_text": text}

    def reset(self) -> None:
        """Start the run again from its initial triangulation."""
        p = self.params
        self._anisotropy = make_anisotropy(p)
        self._domain = make_domain(p, self.uploads)
        self._gen = Ahead(qmesh.iterate(self._domain, self._anisotropy,
                                        target_vertices=p.target_vertices, alpha=p.alpha,
                                        seed=p.seed))
        self.history: list[qmesh.Step] = []
        self._cache.clear()
        self._figures.clear()
        self.done = False
        self.index = 0
        self._pull()    # a medium too: its first face's first triangulation, then Step and
                        # Run go through every face's run in turn

    def _pull(self) -> bool:
        """Ask the generator for one more Step; False once the run has ended. An exception from
        the mesher ends the run (the generator is spent) and goes to the caller."""
        if self.done:
            return False
        try:
            self.history.append(next(self._gen))
            if self.is_field and self.history[-1].converged:
                self._pull_tail()
        except StopIteration:
            self.done = True
            return False
        except BaseException:
            self.done = True
            raise
        return True

    def _pull_tail(self) -> None:
        """A field's certified Step is its last: end the generator now, so what it says after
        that Step (the vertices certification added, edges it could not fix) is warned during
        the same action, not lost once the run stops at its converged Step."""
        try:
            step = next(self._gen)
        except StopIteration:
            self.done = True
        else:
            self.history.append(step)          # not expected; kept rather than dropped

    @property
    def current(self) -> qmesh.Step:
        return self.history[self.index]

    @property
    def at_end(self) -> bool:
        """True when the last stage is shown and the run has converged or hit its cap."""
        return self.index == len(self.history) - 1 and (self.done or self.current.converged)

    # ------------------------------------------------------------------ moving through it
    def step(self) -> bool:
        """Show the next stage (replayed from the history, or computed). False at the end."""
        if self.index + 1 < len(self.history) or self._pull():
            self.index += 1
            return True
        return False

    def ahead(self) -> bool:
        """Mesh the run's next stage before it is asked for (the app's worker, while the page is
        idle): `step()` then shows it at once, with the warnings it raised. False when the
        whole run is meshed. Not for large runs: every stage meshed ahead is kept."""
        return not self.done and self._gen.ahead()

    @property
    def meshed_ahead(self) -> int:
        """Stages (or the run's end) meshed ahead and not shown yet."""
        return self._gen.kept

    @property
    def all_meshed(self) -> bool:
        """True when nothing is left to mesh: the run has ended, or has been meshed ahead to its
        end."""
        return self.done or self._gen.exhausted

    def warm(self) -> None:
        """A field: compute the shown stage's element means now (the caller's thread: the app's
        worker, for the stage it is about to draw), so drawing it on the event loop finds them
        ready. Moving through the run does not compute them: a Run meshes several stages while
        the views draw one, and those never drawn nor measured are never averaged. A field that
        refuses to be averaged there is left for the views and the status line to report."""
        if self.is_field:
            try:
                self.conductivity_of(self.current)
            except QmeshError:
                pass

    def iterate(self) -> bool:
        """Show stages up to and including the next triangulate stage. False if none was left."""
        moved = False
        while self.step():
            moved = True
            if self.current.stage == "triangulate":
                break
        return moved

    def finish(self) -> int:
        """Step to the end at once (scripts and tests; the front ends animate the session's
        `run`); returns the stages added."""
        n = 0
        while self.step():
            n += 1
        return n

    def scrub(self, index: int) -> qmesh.Step:
        """Show stage `index` of the history (clamped to the stages computed so far)."""
        self.index = int(np.clip(int(index), 0, len(self.history) - 1))
        return self.current

    # ------------------------------------------------------------------ measurements
    def status(self, index: int | None = None, *, quick: bool = False,
               bare: bool = False) -> dict:
        """The status line's numbers for stage `index` (default: the one shown).

        `quick=True` answers at once from the Step's own statistics, with the fraction of
        q_ij ≥ 0 and κ2 only if they were measured before (else None); measured rows are cached.
        `bare=True` (with quick) leaves out the energy and quality figures too unless measured
        before: a Step computes them on first access (a pass over the triangles).
        """
        i = self.index if index is None else int(index)
        row = self._cache.get(i)
        if row is None and quick:
            row = self._figures.get(i)
            if row is None:
                row = _stats_row(self.history[i], field=self.is_field, figures=not bare)
                if not bare:
                    self._figures[i] = row
        elif row is None:
            step = self.history[i]
            row = _stats_row(step, field=self.is_field)
            try:
                if not getattr(self._anisotropy, "is_constant", True):   # s as text
                    row["q_nonnegative_sh"] = measure.sh_convex_fraction(step.mesh, self._anisotropy)
                conductivity = self.conductivity_of(step)     # a field: per-triangle means
                if self.is_field:          # each triangle in its own mean's metric
                    q = measure.quality(step.mesh, conductivity)
                    q = q[np.isfinite(q)]
                    if len(q):
                        row["min_quality"], row["mean_quality"] = float(q.min()), float(q.mean())
                row["q_nonnegative"] = measure.q_nonnegative_fraction(step.mesh, conductivity)
                kappa = measure.conditioning(step.mesh, conductivity)
                row["kappa2"], row["kappa2_reason"] = kappa.kappa2, kappa.reason
            except QmeshError as e:     # degenerate triangles mid-run: no stiffness matrix
                row["kappa2_reason"] = str(e)
            self._cache[i] = row
        return dict(row, history_length=len(self.history), done=self.done)

    def convergence(self) -> dict:
        """E, κ2 and N at the end of every iteration computed so far (its triangulate stages)."""
        idx = [i for i, s in enumerate(self.history) if s.stage == "triangulate"]
        rows = [self.status(i) for i in idx]
        face, faces = -1, []                 # a medium: which face's run (its iteration 0 starts one)
        for i in idx:
            step = self.history[i]
            face += step.iteration == 0
            faces.append(None if self.regions and step.converged else face)
        return {"iteration": [r["iteration"] for r in rows], "face": faces,
                "energy": [r["energy"] for r in rows],
                "kappa2": [r["kappa2"] for r in rows],
                "n_vertices": [r["n_vertices"] for r in rows]}


def _stats_row(step, field: bool = False, figures: bool = True) -> dict:
    """The status numbers a Step carries itself (no stiffness matrix needed). A field's Step
    has no energy (no s), and its quality is measured in each triangle's own mean (`status`),
    not the smoothed metric the Step's statistics use: "–" until then. Without `figures` the
    energy and quality are "–" too (not computed here)."""
    st = step.stats
    figures = figures and not field
    return {"iteration": step.iteration, "stage": step.stage,
            "n_vertices": st.n_vertices, "n_triangles": st.n_triangles,
            "energy": st.energy if figures else None,
            "min_quality": st.min_quality if figures else None,
            "mean_quality": st.mean_quality if figures else None,
            "q_nonnegative": None, "kappa2": None,
            "kappa2_reason": None, "q_nonnegative_sh": None,
            "added": 0 if step.added is None else len(step.added),
            "converged": step.converged, "field": field}


def status_text(s: dict) -> str:
    """One status line: iteration, stage, N, E (not for a field: no s), min/mean quality,
    fraction q_ij ≥ 0, κ2 ("—" when the stage's Dirichlet matrix has none: the reason goes to the
    message row; "–" while not measured yet), and "converged" only for a Step that says so (a
    medium's or a field's last). A field's quality and q_ij are in each triangle's own mean."""
    def num(x, fmt):
        return "–" if x is None else format(x, fmt)
    field = bool(s.get("field"))
    energy = s["energy"]
    if energy is not None and not math.isfinite(energy):       # a metric without s
        energy = None
    share = None if s["q_nonnegative"] is None else 100 * s["q_nonnegative"]
    return (f"iteration {s['iteration']} · {s['stage']} · N = {s['n_vertices']} · "
            + ("" if field else f"E = {num(energy, '.4g')} · ")
            + f"quality min {num(s['min_quality'], '.3f')} "
            f"mean {num(s['mean_quality'], '.3f')} · "
            + ("q_ij ≥ 0 with the element means: " if field else "q_ij ≥ 0: ")
            + f"{num(share, '.1f')}% · "
            + ("" if s.get("q_nonnegative_sh") is None else
               f"for s_h: {100 * s['q_nonnegative_sh']:.1f}% · ")
            + f"κ2 = {'—' if s.get('kappa2_reason') else num(s['kappa2'], '.3g')}"
            + (" · converged" if s["converged"] else ""))
