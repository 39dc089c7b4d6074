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
from qmesh.mesher.normalise import Normalisation
from qmesh.mesher.options import Options

BOUNDARY_FACTOR = 1.0   # split boundary edges longer than this many target metric lengths
TOLERANCE = 0.1         # the final N may miss target_vertices by this share


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

    @property
    def boundary_factor(self) -> float | None:
        return BOUNDARY_FACTOR if self.options.boundary_refinement else None

    def too_few(self) -> str:
        """The option that set N, for a message about too few vertices."""
        if self.target is not None:
            return f"target_vertices = {self.target} is too few"
        return f"size = {self.user_size():.3g} is too large"

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
    return _sized(norm, options, target, sizing.metric_area(dom, A), sizing.metric_edge_lengths(dom, A))


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
        sizing.check_vertex_count(expected, f"size = {norm.scale * np.sqrt(norm.k) * h:.3g}")
    budget.check(expected, varying=not norm.anisotropy.is_constant)   # refused before allocating
    min_area = (sizing.equilateral_area(h) / 16 if options.min_area is None
                else norm.metric_area(float(options.min_area)))
    cap = int(min(sizing.MAX_VERTICES, 4 * expected + 4 * len(dom.seeds) + 100))
    return Plan(norm, options, h, area_m, lengths, expected, min_area, cap, aim)


def check_count(mesh, plan: Plan) -> None:
    """QmeshError unless the mesh lands within TOLERANCE of target_vertices, saying why."""
    target, n = plan.target, mesh.n_vertices
    if target is None or abs(n - target) <= TOLERANCE * target:
        return
    if n > target:
        thin = thin_domain(mesh, plan.norm.user_anisotropy)      # what the input has, if thin
        why = f". {thin[0].upper()}{thin[1:]}" if thin else ""
        raise QmeshError(f"target_vertices = {target} is too few: keeping every q_ij >= 0 on the "
                         f"boundary needs {n} vertices here; ask for at least {n}{why}")
    interior = int((~mesh.boundary).sum())
    why = (" (the domain is thinner than one element at this size, so no interior vertex fits)"
           if interior == 0 else "")
    hint = "" if plan.options.boundary_refinement else "; allow boundary_refinement to add boundary vertices"
    raise QmeshError(f"target_vertices = {target} cannot be met: the mesh has {n} "
                     f"vertices{why}{hint}")
