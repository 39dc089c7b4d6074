"""Algorithm 2.1 of the chapter: build a Q-adapted mesh.

    read the boundary points; select initial interior points
    construct the Q-weighted Delaunay triangulation
    repeat
        adjust vertices                       (adjust.py, (2.85)–(2.93))
        add new points                        (insert.py, (2.94))
        construct the Q-Delaunay triangulation (triangulate.py, (2.74)–(2.75))
    until converged

`_algorithm_2_1` below is those lines; each stage is a function of `stages.py`, the run is sized
once beforehand (`plan.py`) and the options are one record (`options.py`).

`iterate` yields a `Step` after every stage, so the CLI's progress, the GUI's stepping and the
widget all consume this one loop. Only the first triangulation is built from scratch (Qhull);
later ones restore the Q-Delaunay property by edge flips on the kept connectivity, so the cost
of an iteration is O(N) array work. A constant Q starts from the metric lattice at the target
density (seeding.py); a varying s from hexagonal lattices in the local metric, patch by patch
(seeding_varying.py). The mesher works in normalised coordinates (normalise.py) and keeps the
boundary conforming, so that every q_ij ≥ 0 on interior and boundary edges (conform.py).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Iterator

import numpy as np

from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.domain.domain import as_domain
from qmesh.errors import QmeshError
from qmesh.triangle_mesh import Mesh
from qmesh.mesher import conform
from qmesh.mesher.diagnose import warn_if_thin
from qmesh.mesher.options import Options, check_keywords
from qmesh.mesher.plan import Plan, check_count, plan as plan_run
from qmesh.mesher.stages import (add_new_points, adjust_vertices, converged,
                                 initial_triangulation, retriangulate)
from qmesh.mesher.step import Step, last_step


def _algorithm_2_1(plan: Plan, rng) -> Iterator[Step]:
    """Algorithm 2.1, a Step after every stage; returns the last. It keeps no Step it has
    yielded: each holds its stage's mesh."""
    plan, st, step = initial_triangulation(plan, rng)    # boundary points, initial points, Qhull
    yield step
    for it in range(1, plan.options.max_iterations + 1):
        step = adjust_vertices(plan, st, it)             # (2.85)–(2.93)
        moved = step.stats.rms_move
        yield step
        step = add_new_points(plan, st, it)              # (2.94)
        added = step.stats.added
        yield step
        step = retriangulate(plan, st, it)               # (2.74)–(2.75)
        step = replace(step, converged=converged(moved, added, step.stats))
        yield step
        if step.converged:                               # until converged
            break
    return step


def _sized_runs(plan: Plan, seed, tried: list[tuple[int, int]]) -> Iterator[Step]:
    """Algorithm 2.1 with the plan sized before it starts; when the run ends more than 10% off
    the target (boundary splits made during it, in a domain thin in the metric), it runs again
    sized from the counts of the runs so far, up to `RUNS` runs (plan.py: `Plan.resized`; the steps
    of every run are yielded: the last is the mesh; each run's (aim, N) is appended to
    `tried`)."""
    run: Plan | None = plan
    while run is not None:
        last = yield from _algorithm_2_1(run, np.random.default_rng(seed))
        tried.append((run.aim or 0, last.mesh.n_vertices))
        run = run.resized(tried, len(run.norm.domain.seeds))


def iterate(domain, anisotropy, *, target_vertices: int | None = None, size: float | None = None,
            alpha: float = 0.5, quality_threshold: float = 0.5, min_area: float | None = None,
            max_iterations: int = 40, seed: int | None = 0,
            boundary_refinement: bool = True, **unknown) -> Iterator[Step]:
    """Run Algorithm 2.1, yielding a `Step` after every stage; the arguments are checked now.

    domain            a `Domain` (outline and holes), `Polygon` or `Disk`; its points are fixed;
    anisotropy        an `Anisotropy` (constant Q, principal, from_s, from_expression);
    target_vertices   final vertex count N (lands on it or within a few percent), or
    size              target metric edge length h in the metric ∇²s (default: the mean metric
                      length of the domain's segments, so the input points set the size);
    alpha             relaxation of the vertex step (2.92); ½ as in the chapter;
    quality_threshold triangles of metric quality (2.94) below it get a point, unless
    min_area          their metric area is below this (default: 1/16 of the target triangle's);
    max_iterations    cap on the repeat loop;
    seed              seed of the random initial interior points, or of the tiny jitter of
                      the lattice for a constant Q (same seed ⇒ same mesh);
    boundary_refinement  allow vertices on the boundary between the input points (without
                      it, only the splits that keep q_ij ≥ 0 on boundary edges are made).

    The last Step's mesh is the one `mesh` returns. With `target_vertices`, the boundary splits
    that keep q_ij ≥ 0 are budgeted in advance; when a run still ends more than 10% off the
    target (a domain thin in the metric), the steps of up to three more runs, each sized from
    the counts of the runs before, follow (each first Step is iteration 0 again). A last mesh
    that misses the target by more than 10% raises QmeshError after that Step, saying why.
    """
    check_keywords(unknown, iterate, "iterate")
    options = Options.checked(target_vertices=target_vertices, size=size, alpha=alpha,
                              quality_threshold=quality_threshold, min_area=min_area,
                              max_iterations=max_iterations, seed=seed,
                              boundary_refinement=boundary_refinement)
    domain = as_domain(domain)
    if not isinstance(anisotropy, Anisotropy):
        raise QmeshError(f"anisotropy must be a qmesh.Anisotropy, got {type(anisotropy).__name__}")
    plan = plan_run(domain, anisotropy, options)
    tried: list[tuple[int, int]] = []
    return _checked(plan, _sized_runs(plan, seed, tried), tried)


def _checked(plan: Plan, steps, tried: list[tuple[int, int]]) -> Iterator[Step]:
    """The steps; a conformity that runs out of vertices is blamed on the option that set N,
    and a last mesh off target raises after it is yielded."""
    last = None
    try:
        for last in steps:
            yield last
    except conform.TooManySplits as e:
        raise QmeshError(f"{plan.too_few()} for this domain: {e}") from None
    except conform.SharpCorner as e:
        x, y = plan.norm.user_domain.seeds[e.seed]
        raise QmeshError(f"the corner at ({x:.6g}, {y:.6g}) is {e.angle:.3g}° in the metric: "
                         f"too sharp for the {e.n} vertices the run reached at {plan.asked()}: "
                         "the points that keep q_ij >= 0 on its sides crowd closer than "
                         "round-off allows; blunt the corner (fewer vertices help only where "
                         "the boundary then needs fewer)") from None
    check_count(last.mesh, plan, [n for _, n in tried])


def mesh(domain, anisotropy, *, target_vertices: int | None = None, size: float | None = None,
         alpha: float = 0.5, quality_threshold: float = 0.5, min_area: float | None = None,
         max_iterations: int = 40, seed: int | None = 0, boundary_refinement: bool = True,
         progress=None, **unknown) -> Mesh:
    """Run Algorithm 2.1 to convergence (or `max_iterations`) and return the final mesh: the
    mesh of the last Step of `iterate` with the same arguments.

    The options are `iterate`'s (see there); `progress`, when given, is called with every
    `Step` as it comes (the command line prints them). With `target_vertices`, the boundary
    splits that keep q_ij ≥ 0 are budgeted as `iterate` says; a mesh still more than 10%
    off the target raises QmeshError saying why (the boundary alone needs more vertices to keep
    q_ij ≥ 0, or cannot carry that many). Warns `QmeshWarning` when the domain is thinner than
    about two elements in the metric, saying what N would be needed.
    """
    check_keywords(unknown, iterate, "mesh")
    last = last_step(iterate(domain, anisotropy, target_vertices=target_vertices, size=size,
                             alpha=alpha, quality_threshold=quality_threshold, min_area=min_area,
                             max_iterations=max_iterations, seed=seed,
                             boundary_refinement=boundary_refinement), progress)
    warn_if_thin(last.mesh, anisotropy)   # a domain thinner than two elements: say so
    return last.mesh
