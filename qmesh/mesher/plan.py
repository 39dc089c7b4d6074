"""Everything a run of Algorithm 2.1 decides before it starts: the normalised problem, the
target metric edge length h, the vertex count it aims at, and the insertion budget.

Sizing once, here, is what makes `qmesh.iterate` and `qmesh.mesh` the same run: the boundary
splits that keep q_ij ≥ 0 are budgeted in advance (the first triangulation gives interior
points away for them, and insertion keeps a reserve for the later ones), so nothing has to be
run twice to land on the target.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from qmesh.errors import QmeshError
from qmesh.mesher import budget, seeding, sizing
from qmesh.mesher.diagnose import thin_domain
from qmesh.mesher.normalise import Normalisation, metric_advice, metric_name
from qmesh.mesher.options import Options

BOUNDARY_FACTOR = 1.0   # split boundary edges longer than this many target metric lengths
TOLERANCE = 0.1         # the final N may miss target_vertices by this share
RUNS = 5                # runs of Algorithm 2.1 at most, each sized from the counts before it
MAX_AIM = 4.0           # ... for no more interior than this many times the target


@dataclass(frozen=True)
class Plan:
    """The sizing of one run (metric quantities are in the normalised coordinates)."""

    norm: Normalisation
    options: Options
    h: float                # target metric edge length
    area_m: float           # metric area ∫_Ω √det ∇²s
    lengths: np.ndarray     # metric length of every segment
    expected: float         # the vertex count the run aims at
    min_area: float         # metric area below which a bad triangle gets no point
    cap: int                # the conformity gives up past this many vertices
    aim: int | None         # the vertex count the interior is sized for (target_vertices, less
                            # what the boundary splits take beyond it: `budget_splits`)

    @property
    def target(self) -> int | None:
        return self.options.target_vertices

    def budget_splits(self, n_built: int, n_seeds: int) -> "Plan | None":
        """A plan that leaves the conformity's splits room within the target, when the first
        triangulation (`n_built` vertices) already carries N more than TOLERANCE past it; None
        when it does not, or when no interior would be left to give away. Its cap is at least
        this plan's: the boundary needs as many splits again, and a cap sized for the smaller
        interior would refuse them naming a count below both N and the target."""
        if self.target is None or n_built <= (1 + TOLERANCE) * self.target:
            return None
        aim = self.aim - (n_built - self.target)
        if aim <= n_seeds:
            return None
        smaller = _sized(self.norm, self.options, aim, self.area_m, self.lengths)
        return replace(smaller, cap=max(smaller.cap, self.cap))

    def resized(self, tried: list[tuple[int, int]], n_seeds: int) -> "Plan | None":
        """The plan of one more run when the runs `tried` so far, (aim, N) each, the last this
        plan's, end more than TOLERANCE off the target; None when the last is on target, when
        RUNS were made, or when no new aim is left. A thin domain's boundary splits make N a
        jumpy function of the aim, so the aim is searched: halfway between the largest aim that
        gave too few and the smallest that gave too many when the first is below the second,
        else the aim of the run nearest the target less its miss (of the next nearest when that
        aim was tried; the first correction is `budget_splits`' before a run). Its cap is at
        least this plan's, as in `budget_splits`."""
        target = self.target
        if target is None or abs(tried[-1][1] - target) <= TOLERANCE * target or len(tried) >= RUNS:
            return None
        lo = max((a for a, n in tried if n < target), default=None)   # the bracket's aims
        hi = min((a for a, n in tried if n > target), default=None)
        aims = [a - (n - target) for a, n in sorted(tried, key=lambda t: abs(t[1] - target))]
        if lo is not None and hi is not None and lo < hi:
            aims.insert(0, (lo + hi) // 2)
        new = [a for a in (int(min(a, MAX_AIM * target)) for a in aims)
               if a > n_seeds and all(a != b for b, _ in tried)]
        if not new:
            return None
        aim = new[0]
        resized = _sized(self.norm, self.options, aim, self.area_m, self.lengths)
        return replace(resized, cap=max(resized.cap, self.cap))

    @property
    def boundary_factor(self) -> float | None:
        return BOUNDARY_FACTOR if self.options.boundary_refinement else None

    def too_few(self) -> str:
        """The option that set N, for a message about too few vertices."""
        return f"{self.asked()} is too {'few' if self.target is not None else 'large'}"

    def asked(self) -> str:
        """The option that set N, as the user gave it."""
        if self.target is not None:
            return f"target_vertices = {self.target}"
        return _size_text(self.options.size, self.user_size())

    def user_size(self) -> float:
        return self.norm.scale * np.sqrt(self.norm.k) * self.h


def plan(domain, anisotropy, options: Options) -> Plan:
    """Normalise the problem and size the run; QmeshError when s is not convex on Ω or the
    options ask for an impossible vertex count."""
    norm = Normalisation(domain, anisotropy)
    dom, A = norm.domain, norm.anisotropy
    if not A.is_constant and A.potential:
        with np.errstate(all="ignore"):
            probe = seeding.random_interior(dom, 256, np.random.default_rng(0))
        anisotropy.check_convex(norm.to_user(np.concatenate([dom.seeds, probe])))
    target = options.target_vertices
    if target is not None and target <= len(dom.seeds):
        raise QmeshError(f"target_vertices = {target} must exceed the "
                         f"{len(dom.seeds)} input points of the domain")
    with np.errstate(all="ignore"):
        area_m, lengths = sizing.metric_area(dom, A), sizing.metric_edge_lengths(dom, A)
    if not (np.isfinite(area_m) and area_m > 0 and np.all(np.isfinite(lengths))):
        raise QmeshError(f"{metric_name(anisotropy)} overflows or underflows on the domain: the "
                         f"domain's area in it is {area_m:.3g}{metric_advice(anisotropy)}")
    return _sized(norm, options, target, area_m, lengths)


def _size_text(given: float | None, h: float) -> str:
    """The size that set N, as a message names it: the user's, or the default no one typed."""
    if given is not None:
        return f"size = {h:.3g}"
    return f"the default size (the domain's mean edge length in the metric, {h:.3g})"


def _sized(norm, options: Options, aim: int | None, area_m: float, lengths: np.ndarray) -> Plan:
    """The plan whose interior is sized for `aim` vertices (or for options.size when None)."""
    dom = norm.domain
    bfac = BOUNDARY_FACTOR if options.boundary_refinement else None
    if aim is not None:
        h = sizing.size_for_vertices(area_m, lengths, aim, bfac)
        expected = aim
    else:
        h = norm.metric_length(float(options.size)) if options.size is not None else float(lengths.mean())
        expected = sizing.vertices_for_size(area_m, lengths, h, bfac)
        sizing.check_vertex_count(expected, _size_text(options.size, norm.scale * np.sqrt(norm.k) * h))
    budget.check(expected, varying=not norm.anisotropy.is_constant,   # refused before allocating
                 field=not norm.anisotropy.potential)
    min_area = (sizing.equilateral_area(h) / 16 if options.min_area is None
                else norm.metric_area(float(options.min_area)))
    cap = int(min(sizing.MAX_VERTICES, 4 * expected + 4 * len(dom.seeds) + 100))
    return Plan(norm, options, h, area_m, lengths, expected, min_area, cap, aim)


def check_count(mesh, plan: Plan, counts=()) -> None:
    """QmeshError unless the mesh lands within TOLERANCE of target_vertices, saying why; `counts`
    the N of every run sized for it (the fewest above the target is the one to ask for)."""
    target, n = plan.target, mesh.n_vertices
    if target is None or abs(n - target) <= TOLERANCE * target:
        return
    if n > target:
        n = min([c for c in counts if c > target] + [n])
        thin = thin_domain(mesh, plan.norm.user_anisotropy)      # what the input has, if thin
        why = f". {thin[0].upper()}{thin[1:]}" if thin else ""
        raise QmeshError(f"target_vertices = {target} is too few: keeping every q_ij >= 0 on the "
                         f"boundary needs {n} vertices here; ask for at least {n}{why}")
    interior = int((~mesh.boundary).sum())
    why = (" (the domain is thinner than one element at this size, so no interior vertex fits)"
           if interior == 0 else "")
    hint = "" if plan.options.boundary_refinement else "; allow boundary_refinement to add boundary vertices"
    over = [c for c in counts if c > target]
    if over:                  # the runs jumped over the target: the next count up is reachable
        under = max([c for c in counts if c < target] + [n])
        hint = (f"; the runs sized for it end on {under} vertices or fewer, or on {min(over)} or "
                "more (the splits that keep q_ij >= 0 on the boundary of a domain this thin in "
                f"the metric come in jumps): ask for at least {min(over)}{hint}")
    elif interior == 0 and (thin := thin_domain(mesh, plan.norm.user_anisotropy)):
        hint = f". {thin[0].upper()}{thin[1:]}{hint}"      # how many would put elements across
    raise QmeshError(f"target_vertices = {target} cannot be met: the mesh has {n} "
                     f"vertices{why}{hint}")
