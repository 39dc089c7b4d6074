"""Certify and repair: every q_ij ≥ 0 with the stiffness matrix assembled from the element means.

FIELDS.md §2–4; the shares and the rule an edge passes by are shares.py's. Each round assembles
the shares of the triangles that changed; an edge that fails is flipped when its quadrilateral
is convex and the flip lowers the deficit of its five edges (flips.py), else split at the best of
a few points along it (splits.py); until none fails or the rounds run out, which is then said,
never passed over. Given the metric the mesh was made in, the corners of the triangles beside
failing edges first take the mesher's shape step where that mends their star without a vertex
(moves.py; a boundary vertex between two corners slides along its side), and once every edge
passes the added vertices take it where that improves their star's worst quality and breaks no
edge; then the corners of the triangles below FLOOR move in each triangle's own metric
adj Q̄_T / √det Q̄_T (the metric quality 2.94 is measured in) to the best of their shape step
and a pattern of places around them (moves.polish), and their edges flip where that raises the
worse of the two and raises no deficit. The means come from `cache.ElementMeans`: each
triangle's computed once. Certify and its steps read and update one state, the mesh under
repair with its means and shares (`repair_state.RepairState`).

A text formula's means are proven lazily (`_prove`): all of the above runs on the rule's cheap
means and estimates; once every edge passes, each triangle's bound is replaced by a proven one
(the enclosures of its 4 children), the triangles beside edges that fail by it have their bounds
refined to what the edge needs, and edges that still fail (a jump crosses them, a bump lies in
them) go back to the repair, up to PROOF_ROUNDS times, each repair followed by the polish (its
splits leave triangles below FLOOR too), whose moves are proven in turn. The mesh is certified on
proven bounds.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from qmesh.errors import QmeshError
from qmesh.fields.cache import ElementMeans
from qmesh.fields.flips import mending_flips, quality_flips
from qmesh.fields.moves import (Judged, corners, free, isosceles, movers, polish, relax, slides,
                                tangents)
from qmesh.fields.merges import compact, side_merges
from qmesh.fields.piecewise import RegionMeans
from qmesh.fields.repair_state import RepairState
from qmesh.fields.shares import FLOOR, by_bound, failing, shares
from qmesh.fields.splits import longer, split_failing, split_failing_medium
from qmesh.geometry import topology
from qmesh.geometry.portable import eigvalsh2
from qmesh.mesher import budget
from qmesh.triangle_mesh import Mesh

MAX_ROUNDS = 400    # rounds of flips and splits before the remaining edges are reported
STALL = 120         # ... or rounds without fewer failing edges than the best so far
RELAX = 3           # rounds of shape steps mending edges before the next split
SMOOTH = 4          # shape steps of the vertices the splits added, once every edge passes
POLISH = 60         # then rounds of polish (moves.polish), in each triangle's own means, of
                    # the corners of triangles below FLOOR, at most ...
IDLE = 6            # ... while the last this many raised the worst quality or lowered the
PROGRESS = 0.05     # shortfall below FLOOR, Σ max(0, FLOOR − quality), by this share at least
PROOF_ROUNDS = 8    # times the repair runs again on edges its proven bounds fail (texts)
REFINE = 3          # refinements of the proven bounds beside such edges before they go back
MARGIN = 0.9        # ... each asking for bounds within this share of the edge's q_ij
SHORTEST = 1e-9     # edges shorter than this share of the domain's extent are not split
GROWTH = 10         # the repair may take the mesh to this many times its vertices (at least
SPARE = 2000        # this many more), and never past the memory budget: refused beyond


@dataclass(frozen=True)
class Certificate:
    """What the repair did and what is left: `remaining` edges still fail (0: certified)."""

    rounds: int
    flips: int
    added: int
    remaining: int
    worst: float        # the smallest (q_ij − bound) / (Σ|q_ij^T| + bound), in [−1, 1]
                        # (≥ −ROUND when certified)


def certify(mesh: Mesh, field, max_rounds: int = MAX_ROUNDS,
            metric=None) -> tuple[Mesh, Certificate]:
    """`mesh` made to pass on every interior and boundary edge with `field`'s element means,
    and what that took; the Mesh carries the means (`Mesh.conductivity`). With the `metric`
    the mesh was made in, vertices are also moved by its shape step where that mends edges
    without a split, and the vertices the splits added are smoothed where that keeps every
    edge passing.

    A medium: `field` a mapping {region tag: Anisotropy | TensorField} over `mesh.region_tags`
    (piecewise.py: each triangle's means from its own region). An edge between two regions is
    an interface (MEDIA.md §2): never flipped, each side's share checked ≥ 0 on its own (what
    a medium guarantees, stricter than their sum), split on both sides at once (each child
    keeps its parent's tag), its vertices fixed or sliding along it; shapes are judged in each
    triangle's own means, and the mesh keeps its region tags."""
    limit = growth_limit(mesh.n_vertices)
    given = field
    reg = np.array(mesh.region_tags) if isinstance(field, Mapping) else None
    shaping = metric is not None or reg is not None
    moves = None if reg is not None else metric   # a medium's shapes: each triangle's own means
    out = np.full(mesh.n_vertices, -1, np.int64)   # the tag of the boundary edge leaving each
    out[mesh.boundary_edges[:, 0]] = mesh.boundary_tags                          # vertex
    means = ElementMeans(field) if reg is None else RegionMeans(field)   # each computed once
    st = RepairState.of(mesh.points, mesh.triangles, means, fixed=mesh.fixed, out=out, reg=reg)
    added = 0
    shortest = SHORTEST * float(np.ptp(st.P, axis=0).max())
    fewest, since = np.inf, 0
    rng = np.random.default_rng(0)
    tries = 0                                  # shape steps since the last split
    total = 0
    for attempt in range(PROOF_ROUNDS + 1):    # the repair, then the proof of what it passed
        for rounds in range(max_rounds + 1):
            st.fail()
            t = by_bound(st.s, st.b, st.cut, st.h, st.tight)
            if len(t):                             # failing by the bound only: tighter means
                st.refresh(t, tighten=True)
                st.fail()
            if len(st.h) < fewest:
                fewest, since = len(st.h), 0
            since += 1
            stalled = since > STALL and 2 * (len(st.P) - mesh.n_vertices) > limit - mesh.n_vertices
            if len(st.h) and (len(st.P) > limit or stalled):
                _refuse_growth(given, st, mesh.n_vertices, limit, stalled=len(st.P) <= limit)
            if not len(st.h) or rounds == max_rounds or since > STALL:
                break
            done = mending_flips(st, st.h[~st.seen.edges[st.h]], refused=st.seen.edges)
            t = st.flip(done)
            if not len(done) and shaping and tries < RELAX:
                tries += 1
                tan = _tangents(st)
                t = isosceles(st, st.h, tan, rng, refused=st.seen.vertices)
                ends = (free(st.T, st.cut, st.fixed, corners(st.T, st.cut, st.h), tan) if not len(t)
                        else t[:0])
                if len(ends):
                    who = movers(st.T, st.twin, ends, rng)
                    t = relax(st, moves, who[~st.seen.vertices[who]], shape=False, tangent=tan,
                              refused=st.seen.vertices)
            if not len(t):
                keep = longer(st.P, st.T, st.h, shortest)
                if not keep.any():
                    break
                split = split_failing if reg is None else split_failing_medium
                t = split(st, st.h[keep], st.q[keep])
                added = len(st.P) - mesh.n_vertices
                tries = 0
            st.refresh(t)
        if shaping and not len(st.h) and added and not attempt:
            tan = _tangents(st)
            st.seen.vertices[:] = False            # judged otherwise than the repair's moves
            new = free(st.T, st.cut, st.fixed, np.arange(mesh.n_vertices, len(st.P)), tan)
            for _ in range(SMOOTH):
                who = movers(st.T, st.twin, new, rng)
                t = relax(st, moves, who[~st.seen.vertices[who]], shape=True, tangent=tan,
                          refused=st.seen.vertices)
                st.refresh(t)
        if shaping and not len(st.h):
            tan = _tangents(st)
            st.seen = Judged(len(st.P), len(st.T))  # judged afresh: the moves are judged otherwise
            lowest, short = [], []                 # the worst quality and the shortfall below
            if st.quality is None:                 # FLOOR before each round
                st.track_quality()                 # each round: only what it changed
            for _ in range(POLISH):                # the worst shapes, each in its own means
                quality = st.quality
                low = quality < FLOOR
                lowest.append(float(quality.min()) if len(quality) else 1.0)
                short.append(float(np.sum(FLOOR - quality[low])))
                if not paying(lowest, short):
                    break                          # moves that only trade shapes among the poor
                poor = free(st.T, st.cut, st.fixed, st.T[low].ravel(), tan)
                poor = poor[~st.seen.vertices[poor]]   # none left: all refused, nothing changed since
                if not len(poor):
                    break
                t = polish(st, movers(st.T, st.twin, poor, rng), tangent=tan,
                           refused=st.seen.vertices)
                st.refresh(t)
                low = np.flatnonzero(st.quality < FLOOR)
                done = quality_flips(st, (3 * low[:, None] + np.arange(3)).ravel())
                if len(done):
                    st.refresh(st.flip(done))
                if reg is None and side_merges(st, st.T[low].ravel(), tan):
                    tan = _tangents(st)
        total += rounds
        if not means.provable:
            break
        gave_up = len(st.h) > 0
        _prove(st)
        if not len(st.h) or gave_up or attempt == PROOF_ROUNDS:
            break
        st.tight[:] = True                     # every bound proven: nothing to tighten
        st.seen = Judged(len(st.P), len(st.T))  # judged again on the proven bounds
        fewest, since = np.inf, 0
    compact(st)                                # the vertices the merges removed
    st.field = means = None                    # the means' cache: its memory back before the
                                               # whole mesh is assembled once more
    P, T, twin, tc, fixed, out = st.P, st.T, st.twin, st.cut, st.fixed, st.out
    Qbar, err, flips, reg = st.Qbar, st.err, st.flips, st.reg
    s, b = shares(P, T, Qbar, err)             # what is said is assembled afresh
    h, q, slack = failing(s, b, tc, slack=True)
    worst = float(slack.min()) if len(slack) else 0.0
    hb = np.flatnonzero(twin < 0)
    tb, kb = np.divmod(hb, 3)
    E = np.column_stack([T[tb, kb], T[tb, topology.NXT[kb]]])
    regions = {} if reg is None else {"region_tags": reg, "region_names": mesh.region_names}
    done_mesh = Mesh(P, T, fixed, E, out[E[:, 0]], mesh.tag_names, conductivity=Qbar,
                     means_sampled_at=sampled_at(given, P, T, reg), **regions)
    return done_mesh, Certificate(total, flips, added, len(h), worst)


def paying(worst: list[float], short: list[float]) -> bool:
    """Whether the polish's rounds still pay, given the worst quality and the shortfall below
    FLOOR before each round so far: the last IDLE rounds raised the worst quality or lowered the
    shortfall by PROGRESS of itself. Rounds that do neither only trade shapes among the poor:
    on a field whose worst triangle is held by a corner or a seed they would run to POLISH,
    each round a pass over the mesh, for nothing the worst quality or the shortfall shows."""
    if len(worst) <= IDLE:
        return True
    return worst[-1] > worst[-1 - IDLE] or short[-1] < (1.0 - PROGRESS) * short[-1 - IDLE]


def sampled_at(field, P, T, reg) -> float | None:
    """The spacing the means of a callable field (or of a medium's callable regions) sampled Q
    at (`TensorField.sampled_at`), None where every mean is exact or bounded."""
    parts = [(field, np.arange(len(T)))] if reg is None else \
        [(f, np.flatnonzero(reg == tag)) for tag, f in field.items()]
    h = [f.sampled_at(P, T[at]) for f, at in parts if len(at) and hasattr(f, "sampled_at")]
    h = [v for v in h if v is not None]
    return max(h) if h else None


def growth_limit(n: int) -> int:
    """The most vertices the repair may reach from n: GROWTH·n (at least n + SPARE), and no more
    than the memory budget holds (`budget.max_vertices` with a field's bytes per vertex)."""
    memory = budget.max_vertices(budget.default_budget(), varying=True)
    return min(max(GROWTH * n, n + SPARE), max(n, memory))


def _refuse_growth(field, st: RepairState, start: int, limit: int, stalled: bool = False) -> None:
    """QmeshError naming what drove the repair past `limit` (or, `stalled`, past half the way to
    it without progress for STALL rounds): of the triangles beside failing
    edges, the one whose mean has the largest eigenvalue (a mean's small eigenvalue is lost to
    round-off at such ratios, its large one is not), and in it the point of a barycentric grid
    where Q itself is the most anisotropic (its raster cell, for a raster)."""
    P, T, Qbar, h, reg = st.P, st.T, st.Qbar, st.h, st.reg
    k = np.unique(h // 3)
    k = int(k[np.argmax(eigvalsh2(Qbar[k])[:, 1])])
    u, v = np.meshgrid(np.linspace(0, 1, 11), np.linspace(0, 1, 11))
    inside = u + v <= 1
    A, B, C = P[T[k]]
    X = A + u[inside][:, None] * (B - A) + v[inside][:, None] * (C - A)
    src = field if reg is None else field[int(reg[k])]
    Q = np.asarray(src(X) if callable(src) else np.broadcast_to(src.Q(X[:1])[0], (len(X), 2, 2)),
                   float)
    w = eigvalsh2(Q)
    ratio = w[:, 1] / np.maximum(w[:, 0], np.finfo(float).tiny)
    worst = int(np.argmax(ratio))
    place = getattr(src, "place", None)
    where = place(X[worst]) if callable(place) else f"({X[worst][0]:.6g}, {X[worst][1]:.6g})"
    how = (f"stopped making progress at {len(P)} vertices (from {start}; the limit is {limit})"
           if stalled else f"took the mesh past {limit} vertices (from {start})")
    raise QmeshError(
        f"keeping every q_ij >= 0 with the element means {how} with {len(h)} edges still "
        f"failing, the worst beside {where}, where Q is "
        f"{float(ratio[worst]):.3g} : 1. A jump to an anisotropy that strong needs ever smaller "
        "triangles along it: bound or smooth Q there")


def _prove(st: RepairState) -> None:
    """The means' bounds proven (a text's: FIELDS.md §3), lazily: one enclosure of each child of
    each triangle not proven yet (`ElementMeans.prove`), then, for the edges with q_ij > 0 that
    fail only by those bounds, their triangles' bounds refined (`ElementMeans.refine`) to within
    MARGIN of q_ij, split between the two by their shares' weights, up to REFINE times while
    that asks for a tighter bound than the last. The edges that still fail are left in `st.h`
    for the repair."""
    P, T, tags = st.P, st.T, () if st.reg is None else (st.reg,)
    st.Qbar, st.err = st.field.prove(P, T, *tags)
    st.s, st.b = shares(P, T, st.Qbar, st.err)
    st.stale()
    asked = np.full(len(T), np.inf)
    for _ in range(REFINE):
        st.fail()
        h, q = st.h, st.q
        g = st.cut[h]
        inner = g >= 0
        gg = np.where(inner, g, h)
        weight = shares(P, T, st.Qbar, np.ones(len(T)))[1]    # a bound per unit of error
        ok = q > 0                                             # else no bound can pass it
        t = np.concatenate([h[ok] // 3, gg[ok & inner] // 3])
        w = weight[h[ok]] + np.where(inner[ok], weight[gg[ok]], 0.0)
        room = np.concatenate([q[ok], q[ok & inner]]) * MARGIN / np.concatenate([w, w[inner[ok]]])
        want = np.full(len(T), np.inf)
        np.minimum.at(want, t, room)
        size = np.sqrt(np.sum(st.Qbar.reshape(-1, 4) ** 2, axis=1))     # ‖Q̄_T‖_F
        rtol = np.where(size > 0, want / np.where(size > 0, size, 1.0), 0.0)
        t = np.flatnonzero((rtol < 0.5 * asked) & (want < st.err))
        if not len(t):
            break
        asked[t] = rtol[t]
        st.Qbar[t], st.err[t] = st.field.refine(P, T[t], *(v[t] for v in tags), rtol[t])
        st.s, st.b = shares(P, T, st.Qbar, st.err)
        st.stale()
    st.quality = None                          # the means changed: measured again when asked
    st.fail()


def _tangents(st: RepairState):
    """The unit tangent each vertex may slide along (moves.tangents; a medium's, moves.slides)."""
    if st.reg is None:
        return tangents(st.P, st.T, st.twin, st.fixed)
    return slides(st.P, st.T, st.cut, st.fixed)
