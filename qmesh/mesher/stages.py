"""The stages of Algorithm 2.1, one function each: it changes the `State` and returns the `Step`
that shows what it did. `loop.py` calls them in the chapter's order.

    read the boundary points; select initial interior points    initial_triangulation
    construct the Q-weighted Delaunay triangulation             (lines 1–2: Qhull, conform.py)
    repeat
        adjust vertices                                         adjust_vertices  (2.85)–(2.93)
        add new points                                          add_new_points   (2.94)
        construct the Q-Delaunay triangulation                  retriangulate    (2.74)–(2.75)
    until converged                                             converged
"""

from __future__ import annotations

import time

import numpy as np

from qmesh.errors import QmeshError
from qmesh.geometry.triangles import quadratic_form
from qmesh.mesher import conform, corners, crowding_varying, seeding, seeding_varying, sizing
from qmesh.mesher.adjust import boundary_layer, limit_moves, newton_step, shape_step
from qmesh.mesher.boundary import hold_off_boundary, hold_out_of_ellipses, snap_to_boundary
from qmesh.mesher.insert import insert, relocate_degree3
from qmesh.mesher.plan import BOUNDARY_FACTOR, Plan
from qmesh.mesher.state import State
from qmesh.mesher.step import Step
from qmesh.mesher.triangulate import restore

LATTICE_FILL = 0.97     # the initial lattice holds this share of the expected interior vertices
MOVE_TOL = 0.02         # converged when the rms metric move is below this fraction of h
SHAPE_RINGS = 2         # interior vertices this many edges from the boundary take the shape step


def initial_triangulation(plan: Plan, rng) -> tuple[Plan, State, Step]:
    """Lines 1–2 of Algorithm 2.1: the boundary points (the input points, and the segments split
    to the target size), the initial interior points (the metric lattice for a constant Q,
    local metric lattices for a varying s: seeding.py, seeding_varying.py), and their
    conforming Q-Delaunay triangulation (2.74)–(2.75) built from scratch (Qhull).

    The conformity's splits take the place of interior points (conform.conforming_delaunay);
    when they alone carry N more than 10% past the target, the run is sized again for fewer
    interior vertices before it starts (`Plan.budget_splits`), and the plan it runs with is
    returned."""
    t0 = time.perf_counter()
    built = _build(plan, rng)
    smaller = plan.budget_splits(len(built.P), len(plan.norm.domain.seeds))
    if smaller is not None:
        again = _build(smaller, rng)
        if abs(len(again.P) - plan.target) < abs(len(built.P) - plan.target):
            plan, built = smaller, again
    st = State(plan.norm, built)
    return plan, st, Step("triangulate", 0, st.mesh, st.stats(seconds=time.perf_counter() - t0))


def _build(plan: Plan, rng):
    """The seeds, boundary and interior points of `plan`, conformingly triangulated."""
    domain, anisotropy, h, target = plan.norm.domain, plan.norm.anisotropy, plan.h, plan.aim
    seeds = domain.seeds
    bpts, bseg = corners.matched_boundary_points(
        domain, anisotropy, *seeding.boundary_points(domain, anisotropy, h, plan.boundary_factor))
    n_b = len(seeds) + len(bpts)
    lattice = None
    if not anisotropy.is_constant:
        inner = seeding_varying.initial_points(domain, anisotropy,
                                               int(LATTICE_FILL * (plan.expected - n_b)), rng)
    elif target is None and hasattr(domain, "lattice_points"):   # disjoint domains (components.py)
        inner = domain.lattice_points(anisotropy.H, h, rng)
    else:
        lattice = (seeding.metric_lattice(domain, anisotropy.H, h, rng) if target is None else
                   seeding.lattice_for_count(domain, anisotropy.H, LATTICE_FILL * (target - n_b), rng))
        inner = lattice.points
    P = np.concatenate([seeds, bpts, inner])
    edge_id = np.concatenate([np.full(len(seeds), -1), bseg, np.full(len(inner), -1)]).astype(np.int64)
    pinned = None
    if not anisotropy.is_constant and not anisotropy.potential:   # settled before Qhull's build
        settled = crowding_varying.split_crowded(domain, P, edge_id, anisotropy, h, plan.cap)
        if settled is not None:
            P, edge_id, pinned = settled
    return conform.conforming_delaunay(domain, P, edge_id, anisotropy, h, plan.cap, pinned=pinned,
                                       target=target, rng=rng, lattice=lattice)


def adjust_vertices(plan: Plan, st: State, it: int) -> Step:
    """Adjust vertices: the generalised optimal-Delaunay step (2.91)–(2.93) with relaxation α,
    capped so that no triangle folds; vertices sent out of Ω go onto the boundary."""
    t0 = time.perf_counter()
    P0 = st.P
    d, keep = _displacements(st, plan.options.alpha, plan.options.boundary_refinement)
    Pn, d = limit_moves(P0, st.T, d, keep)
    st.move(_onto_edges(st.domain, Pn, st.edge_id))
    A = st.anisotropy
    move2 = quadratic_form(d[:, None], A.H if A.is_constant else _hessian_at_vertices(plan.norm, P0))
    stats = st.stats(max_move=float(np.sqrt(move2.max()) / plan.h),
                     rms_move=float(np.sqrt(move2.mean()) / plan.h), seconds=time.perf_counter() - t0)
    return Step("adjust", it, st.mesh, stats, moved=plan.norm.scale * (st.P - P0))


def add_new_points(plan: Plan, st: State, it: int) -> Step:
    """Add new points near badly shaped (metric quality (2.94) below the threshold) or
    oversized triangles, within the run's vertex budget. Vertices with three neighbours are
    first moved to the largest triangles (insert.relocate_degree3: not in the chapter; they
    leave slivers the vertex step never removes)."""
    t0 = time.perf_counter()
    o, n_old = plan.options, len(st.P)
    threshold, budget = _insertion_budget(plan, st)
    T, twin, P, relocated = relocate_degree3(st.P, st.T, st.twin, st.anisotropy, st.on_boundary())
    st.relocate(T, twin, P)
    ins = insert(st.P, st.T, st.twin, st.anisotropy, area_threshold=threshold,
                 boundary_length=BOUNDARY_FACTOR * sizing.size_of_area(threshold),
                 corner_edge=st.corner_edge(), quality_threshold=o.quality_threshold,
                 min_area=plan.min_area, budget=budget, refine_boundary=o.boundary_refinement)
    st.add(ins.T, ins.twin, ins.points, ins.edge_id)
    added = np.concatenate([relocated, np.arange(n_old, len(st.P))])
    return Step("insert", it, st.mesh, st.stats(added=len(added), seconds=time.perf_counter() - t0),
                added=added)


def retriangulate(plan: Plan, st: State, it: int) -> Step:
    """Construct the Q-Delaunay triangulation (2.74)–(2.75) again: edge flips on the kept
    connectivity, then the boundary subsegments a vertex encroaches are freed (the vertex
    pushed out) or split (conform.restore_conformity)."""
    t0 = time.perf_counter()
    T, twin, flips = restore(st.P, st.T, st.twin, st.anisotropy)
    st.retriangulate(T, twin)
    P0 = st.P
    c = conform.restore_conformity(st.P, st.T, st.twin, st.edge_id, st.fixed, st.pinned,
                                   st.anisotropy, plan.cap, domain=st.domain)
    st.conform(c)
    n = len(P0)
    pushed = None
    if not (c.P[:n] is P0 or np.array_equal(c.P[:n], P0)):   # one row per vertex: the split-in ones 0
        pushed = np.zeros_like(c.P)
        pushed[:n] = plan.norm.scale * (c.P[:n] - P0)
    return Step("triangulate", it, st.mesh,
                st.stats(flips=flips + c.flips, added=len(c.added), seconds=time.perf_counter() - t0),
                moved=pushed, added=c.added)


def converged(rms_move: float, inserted: int, triangulated) -> bool:
    """Until converged: nothing added (`inserted` points by the insert stage, none by the
    triangulate stage whose Stats are `triangulated`), (almost) nothing flipped, and vertices
    that barely move (`rms_move` of the adjust stage, in h)."""
    n_edges = 3 * triangulated.n_triangles // 2
    return (inserted == 0 and triangulated.added == 0
            and triangulated.flips <= max(2, 1e-3 * n_edges)
            and rms_move < MOVE_TOL)


# ---------------------------------------------------------------------- helpers of the stages

def _insertion_budget(plan: Plan, st: State) -> tuple[float, int]:
    """(metric area above which a triangle is oversized, how many points may be added)."""
    if plan.aim is None:
        return 2.0 * sizing.equilateral_area(plan.h), sizing.MAX_VERTICES - len(st.P)
    nb = int(st.on_boundary().sum())
    return plan.area_m / max(2 * plan.aim - nb - 2, 1), plan.aim - len(st.P)


def _displacements(st: State, alpha: float, boundary_refinement: bool):
    """The adjust stage's moves before the star cap, and the vertices that move exactly so.

    The vertex step (2.91)–(2.93) for every vertex; the two rings next to a refined boundary take
    the shape step instead (adjust.shape_step; held off long unsplit boundary edges it made κ2
    worse: 15.8 against 9.05 on Disk(32)). With boundary refinement, vertices sent out of Ω join
    the boundary where they cross it; without it, moves that would flatten a boundary triangle
    are undone. No move may carry a vertex into the diametral ellipse of the boundary edge it
    faces.
    """
    P0, T0, anisotropy, on_boundary = st.P, st.T, st.anisotropy, st.on_boundary()
    if anisotropy.potential:
        d = newton_step(P0, T0, anisotropy, fixed=st.fixed | st.pinned, tangent=st.tangents(),
                        alpha=alpha)
    else:          # a metric without s has no ‖s − s_h‖ to descend: the shape step (FIELDS.md §4)
        d = alpha * shape_step(P0, T0, anisotropy, ~on_boundary, on_boundary)
    keep = None
    if boundary_refinement:
        if anisotropy.potential:   # without s every interior vertex took this very step above
            layer = boundary_layer(T0, on_boundary, SHAPE_RINGS)
            d[layer] = alpha * shape_step(P0, T0, anisotropy, layer, on_boundary)[layer]
        snap = snap_to_boundary(P0, T0, st.twin, d, on_boundary, st.corner_edge(), anisotropy)
        if len(snap.vertices):
            st.join_boundary(snap)
            d[snap.vertices] = snap.positions - P0[snap.vertices]
            keep = np.zeros(len(P0), bool)
            keep[snap.vertices] = True
    else:
        d = hold_off_boundary(P0, T0, st.twin, d, on_boundary, anisotropy)
    d = hold_out_of_ellipses(P0, st.T, st.twin, d, st.on_boundary(), anisotropy)
    return d, keep


def _hessian_at_vertices(norm, P) -> np.ndarray:
    """∇²s at the vertices; QmeshError naming a point (user coordinates) where it is not finite
    and SPD: the probe before the run samples Ω, this catches what the probe missed."""
    with np.errstate(all="ignore"):
        H = np.asarray(norm.anisotropy.hessian(P), dtype=float)
    det = H[:, 0, 0] * H[:, 1, 1] - H[:, 0, 1] * H[:, 1, 0]
    bad = ~(np.isfinite(H).all(axis=(1, 2)) & (H[:, 0, 0] > 0) & (det > 0))
    if bad.any():
        x = norm.center + norm.scale * P[np.flatnonzero(bad)[0]]
        raise QmeshError(f"the Hessian of s is not finite and positive definite at "
                         f"({x[0]:.6g}, {x[1]:.6g}), a vertex of the mesh inside the domain")
    return H


def _onto_edges(domain, P, edge_id):
    """Put sliding boundary vertices back exactly on their polygon edge (round-off only)."""
    on = edge_id >= 0
    if on.any():
        A, tan = domain.edges
        a, t = A[edge_id[on]], tan[edge_id[on]]
        P = P.copy()
        P[on] = a + np.einsum("ni,ni->n", P[on] - a, t)[:, None] * t
    return P
