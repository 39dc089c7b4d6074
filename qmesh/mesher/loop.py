"""Algorithm 2.1 of the chapter: build a Q-adapted mesh.

    read the boundary points; select initial interior points
    construct the Q-weighted Delaunay triangulation
    repeat
        adjust vertices                       (adjust.py, (2.85)–(2.93))
        add new points                        (insert.py, (2.94))
        construct the Q-Delaunay triangulation (triangulate.py, (2.74)–(2.75))
    until converged

`iterate` yields a `Step` after every stage, so the CLI's progress, the GUI's stepping and the
widget all consume this one loop. Only the first triangulation is built from scratch (Qhull);
later ones restore the Q-Delaunay property by edge flips on the kept connectivity, so the cost
of an iteration is O(N) array work. A constant Q starts from the metric lattice at the target
density (seeding.py); a varying s from hexagonal lattices in the local metric, patch by patch
(seeding_varying.py). The mesher works in normalised coordinates (normalise.py) and keeps the
boundary conforming, so that every q_ij ≥ 0 on interior and boundary edges (conform.py).
"""

from __future__ import annotations

import time
from typing import Iterator

import numpy as np

from qmesh.mesher import conform
from qmesh.mesher import seeding
from qmesh.mesher import seeding_varying
from qmesh.mesher import sizing
from qmesh.geometry import topology
from qmesh.mesher.adjust import boundary_layer, limit_moves, newton_step, shape_step
from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.mesher.boundary import hold_off_boundary, hold_out_of_ellipses, snap_to_boundary
from qmesh.domain.domain import as_domain
from qmesh.errors import QmeshError
from qmesh.geometry.triangles import quadratic_form
from qmesh.mesher.insert import insert, relocate_degree3, target_area
from qmesh.mesh import Mesh, frozen
from qmesh.mesher.step import Stats, Step
from qmesh.mesher.normalise import Normalisation
from qmesh.mesher.options import check_keywords, check_options
from qmesh.mesher.triangulate import restore

BOUNDARY_FACTOR = 1.0   # split boundary edges longer than this many target metric lengths
LATTICE_FILL = 0.97     # the initial lattice holds this share of the expected interior vertices
MOVE_TOL = 0.02        # converged when the rms metric move is below this fraction of h
SHAPE_RINGS = 2         # interior vertices this many edges from the boundary take the shape step


class _State:
    """The mutable arrays of one run (normalised coordinates); Steps get read-only snapshots."""

    def __init__(self, norm: Normalisation, built):
        self.norm = norm
        self.domain, self.anisotropy = norm.domain, norm.anisotropy
        self.P, self.T, self.twin, self.edge_id = built.P, built.T, built.twin, built.edge_id
        self.fixed = np.zeros(len(self.P), bool)
        self.fixed[:len(self.domain.seeds)] = True
        self.pinned = built.pinned
        self._seen_P = self._seen_T = None
        self.mesh = self.snapshot()

    def tangents(self) -> np.ndarray:
        _, tan = self.domain.edges
        t = np.zeros_like(self.P)
        on = self.edge_id >= 0
        t[on] = tan[self.edge_id[on]]
        t[self.fixed | self.pinned] = 0.0
        return t

    def on_boundary(self) -> np.ndarray:
        """Boundary vertices: the seeds and the vertices sliding on the segments."""
        return self.fixed | (self.edge_id >= 0)

    def corner_edge(self) -> np.ndarray:
        """Segment that starts at each boundary vertex (seed k starts segment k)."""
        ce = self.edge_id.copy()
        ce[self.fixed] = np.flatnonzero(self.fixed)
        return ce

    def snapshot(self) -> Mesh:
        """The current mesh in the user's coordinates, with its tagged boundary edges; arrays
        that did not change since the last snapshot are shared with it."""
        if self.P is not self._seen_P:
            self._user_P, self._seen_P = frozen(self.norm.to_user(self.P), np.float64), self.P
        if self.T is not self._seen_T:
            hb = np.flatnonzero(self.twin < 0)
            t, e = np.divmod(hb, 3)
            a = self.T[t, e]
            self._edges = frozen(np.column_stack([a, self.T[t, topology.NXT[e]]]), np.int64)
            self._tags = frozen(self.domain.segment_tags[self.corner_edge()[a]], np.int64)
            self._user_T, self._seen_T = frozen(self.T, np.int64), self.T
        return Mesh(self._user_P, self._user_T, self.fixed, self._edges, self._tags,
                    self.domain.tag_names)

    def stats(self, **extra) -> Stats:
        return Stats(self.mesh.n_vertices, self.mesh.n_triangles,
                     source=(self.mesh, self.norm.user_anisotropy), **extra)


def iterate(domain, anisotropy, *, target_vertices: int | None = None, size: float | None = None,
            alpha: float = 0.5, quality_threshold: float = 0.5, min_area: float | None = None,
            max_iterations: int = 40, seed: int | None = 0,
            boundary_refinement: bool = True, **unknown) -> Iterator[Step]:
    """Run Algorithm 2.1, yielding a `Step` after every stage; the arguments are checked now.

    domain            a `Domain` (outline and holes), `Polygon` or `Disk`; its points are fixed;
    anisotropy        an `Anisotropy` (constant Q, principal, from_s, from_expression);
    target_vertices   final vertex count N (lands within a few percent), or
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
    """
    if getattr(domain, "regions", ()) or (not isinstance(anisotropy, Anisotropy) and hasattr(anisotropy, "items")):
        from qmesh import media   # a mapping conductivity or a domain with regions: heterogeneous media
        return media.iterate(domain, anisotropy, target_vertices=target_vertices, size=size, alpha=alpha,
                             quality_threshold=quality_threshold, min_area=min_area, max_iterations=max_iterations,
                             seed=seed, boundary_refinement=boundary_refinement, **unknown)
    check_keywords(unknown, iterate, "iterate")
    check_options(target_vertices, size, alpha, quality_threshold, min_area, max_iterations, seed,
                  boundary_refinement)
    domain = as_domain(domain)
    if not isinstance(anisotropy, Anisotropy):
        raise QmeshError(f"anisotropy must be a qmesh.Anisotropy, got {type(anisotropy).__name__}")
    norm = Normalisation(domain, anisotropy)
    dom, A = norm.domain, norm.anisotropy
    if not A.is_constant:
        with np.errstate(all="ignore"):
            probe = seeding.random_interior(dom, 256, np.random.default_rng(0))
        anisotropy.check_convex(norm.to_user(np.concatenate([dom.seeds, probe])))
    area_m = sizing.metric_area(dom, A)
    lengths = sizing.metric_edge_lengths(dom, A)
    bfac = BOUNDARY_FACTOR if boundary_refinement else None
    if target_vertices is not None:
        if target_vertices <= len(dom.seeds):
            raise QmeshError(f"target_vertices = {target_vertices} must exceed the "
                             f"{len(dom.seeds)} input points of the domain")
        h = sizing.size_for_vertices(area_m, lengths, target_vertices, bfac)
    else:
        h = norm.metric_length(float(size)) if size is not None else float(lengths.mean())
        sizing.check_vertex_count(sizing.vertices_for_size(area_m, lengths, h, bfac),
                                  f"size = {norm.scale * np.sqrt(norm.k) * h:.3g}")
    min_area = target_area(h) / 16 if min_area is None else norm.metric_area(float(min_area))
    steps = _run(norm, h, area_m, lengths, target_vertices, alpha, quality_threshold, min_area,
                 max_iterations, np.random.default_rng(seed), boundary_refinement)
    option = (f"target_vertices = {target_vertices} is too few" if target_vertices is not None
              else f"size = {norm.scale * np.sqrt(norm.k) * h:.3g} is too large")
    return _explained(steps, option)


def _explained(steps, option: str) -> Iterator[Step]:
    """The steps, with a conformity that runs out of vertices blamed on the option that set N."""
    try:
        yield from steps
    except conform.TooManySplits as e:
        raise QmeshError(f"{option} for this domain: {e}") from None


def _run(norm, h, area_m, lengths, target_vertices, alpha, quality_threshold, min_area,
         max_iterations, rng, boundary_refinement) -> Iterator[Step]:
    domain, anisotropy = norm.domain, norm.anisotropy
    seeds = domain.seeds
    bfac = BOUNDARY_FACTOR if boundary_refinement else None

    # 1. read the boundary points (the input points, and the segments split to the target
    #    size); select initial interior points: the metric lattice for a constant Q, local
    #    metric lattices for a varying s (seeding.py, seeding_varying.py)
    bpts, bseg = seeding.boundary_points(domain, anisotropy, h, bfac)
    n_b = len(seeds) + len(bpts)
    expected = target_vertices or sizing.vertices_for_size(area_m, lengths, h, bfac)
    if anisotropy.is_constant:
        if target_vertices is None:
            inner = seeding.metric_lattice(domain, anisotropy.H, h, rng)
        else:
            inner = seeding.lattice_for_count(domain, anisotropy.H,
                                              LATTICE_FILL * (target_vertices - n_b), rng)
    else:
        inner = seeding_varying.initial_points(domain, anisotropy,
                                               int(LATTICE_FILL * (expected - n_b)), rng)
    P = np.concatenate([seeds, bpts, inner])
    edge_id = np.concatenate([np.full(len(seeds), -1), bseg, np.full(len(inner), -1)]).astype(np.int64)

    # 2. construct the conforming Q-Delaunay triangulation of Ω from scratch (Qhull)
    t0 = time.perf_counter()
    cap = int(min(sizing.MAX_VERTICES, 4 * expected + 4 * len(seeds) + 100))
    built = conform.conforming_delaunay(domain, P, edge_id, anisotropy, h, cap,
                                        target=target_vertices, rng=rng)
    st = _State(norm, built)
    yield Step("triangulate", 0, st.mesh, st.stats(seconds=time.perf_counter() - t0))

    for it in range(1, max_iterations + 1):
        # 3. adjust vertices (2.91)–(2.93); those sent out of Ω go onto the boundary
        t0 = time.perf_counter()
        P0 = st.P
        d, keep = _displacements(st, alpha, boundary_refinement)
        Pn, d = limit_moves(P0, st.T, d, keep)
        Pn = _onto_edges(domain, Pn, st.edge_id)
        Hv = anisotropy.H if anisotropy.is_constant else _hessian_at_vertices(norm, P0)
        move2 = quadratic_form(d[:, None], Hv)
        max_move = float(np.sqrt(move2.max()) / h)
        rms_move = float(np.sqrt(move2.mean()) / h)
        st.P = Pn
        st.mesh = st.snapshot()
        yield Step("adjust", it, st.mesh,
                   st.stats(max_move=max_move, rms_move=rms_move, seconds=time.perf_counter() - t0),
                   moved=norm.scale * (Pn - P0))

        # 4. add new points near bad or oversized triangles (2.94)
        t0 = time.perf_counter()
        n_old = len(st.P)
        if target_vertices is not None:
            budget = target_vertices - n_old
            nb = int(st.on_boundary().sum())
            threshold = area_m / max(2 * target_vertices - nb - 2, 1)
        else:
            budget = sizing.MAX_VERTICES - n_old
            threshold = 2.0 * target_area(h)
        h_eff = np.sqrt(threshold / target_area(1.0))
        st.T, st.twin, st.P, relocated = relocate_degree3(st.P, st.T, st.twin, anisotropy,
                                                          st.on_boundary())
        ins = insert(st.P, st.T, st.twin, anisotropy, area_threshold=threshold,
                     boundary_length=BOUNDARY_FACTOR * h_eff, corner_edge=st.corner_edge(),
                     quality_threshold=quality_threshold, min_area=min_area, budget=budget,
                     refine_boundary=boundary_refinement)
        k = len(ins.points)
        st.T, st.twin = ins.T, ins.twin
        if k:
            st.P = np.concatenate([st.P, ins.points])
            st.fixed = np.concatenate([st.fixed, np.zeros(k, bool)])
            st.pinned = np.concatenate([st.pinned, np.zeros(k, bool)])
            st.edge_id = np.concatenate([st.edge_id, ins.edge_id])
        added = np.concatenate([relocated, np.arange(n_old, n_old + k)])
        st.mesh = st.snapshot()
        yield Step("insert", it, st.mesh,
                   st.stats(added=len(added), seconds=time.perf_counter() - t0), added=added)

        # 5. construct the Q-Delaunay triangulation again: flips on the kept connectivity,
        #    then split the boundary subsegments that a vertex encroaches (conform.py)
        t0 = time.perf_counter()
        st.T, st.twin, flips = restore(st.P, st.T, st.twin, anisotropy)
        c = conform.restore_conformity(st.P, st.T, st.twin, st.edge_id, st.fixed, st.pinned,
                                       anisotropy, cap)
        pushed = None if c.P[:len(st.P)] is st.P or np.array_equal(c.P[:len(st.P)], st.P) \
            else norm.scale * (c.P[:len(st.P)] - st.P)
        st.P, st.T, st.twin, st.edge_id, st.fixed, st.pinned = c.P, c.T, c.twin, c.edge_id, c.fixed, c.pinned
        flips += c.flips
        st.mesh = st.snapshot()
        n_edges = len(st.twin) // 2
        converged = (len(added) == 0 and len(c.added) == 0
                     and flips <= max(2, 1e-3 * n_edges) and rms_move < MOVE_TOL)
        yield Step("triangulate", it, st.mesh,
                   st.stats(flips=flips, added=len(c.added), seconds=time.perf_counter() - t0),
                   moved=pushed, added=c.added, converged=converged)
        if converged:
            return


def _displacements(st: _State, alpha: float, boundary_refinement: bool):
    """The adjust stage's moves before the star cap, and the vertices that move exactly so.

    The vertex step (2.91)–(2.93) for every vertex; the two rings next to a refined boundary take
    the shape step instead (adjust.shape_step; held off long unsplit boundary edges it made κ2
    worse: 15.8 against 9.05 on Disk(32)). With boundary refinement, vertices sent out of Ω join
    the boundary where they cross it (their triangle removed from `st`); without it, moves that
    would flatten a boundary triangle are undone. No move may carry a vertex into the diametral
    ellipse of the boundary edge it faces.
    """
    P0, T0, anisotropy, on_boundary = st.P, st.T, st.anisotropy, st.on_boundary()
    d = newton_step(P0, T0, anisotropy, fixed=st.fixed | st.pinned, tangent=st.tangents(),
                    alpha=alpha)
    keep = None
    if boundary_refinement:
        layer = boundary_layer(T0, on_boundary, SHAPE_RINGS)
        d[layer] = alpha * shape_step(P0, T0, anisotropy, layer, on_boundary)[layer]
        snap = snap_to_boundary(P0, T0, st.twin, d, on_boundary, st.corner_edge(), anisotropy)
        if len(snap.vertices):
            st.T, st.twin = snap.T, snap.twin
            d[snap.vertices] = snap.positions - P0[snap.vertices]
            st.edge_id = st.edge_id.copy()
            st.edge_id[snap.vertices] = snap.edge_id
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


def mesh(domain, anisotropy, *, target_vertices: int | None = None, size: float | None = None,
         alpha: float = 0.5, quality_threshold: float = 0.5, min_area: float | None = None,
         max_iterations: int = 40, seed: int | None = 0, boundary_refinement: bool = True,
         progress=None, **unknown) -> Mesh:
    """Run Algorithm 2.1 to convergence (or `max_iterations`) and return the final mesh.

    The options are `iterate`'s (see there); `progress`, when given, is called with every
    `Step` as it comes (the command line prints them). With `target_vertices`, the boundary splits that
    keep q_ij ≥ 0 can carry N past the target; when they carry it more than 10% past, the run is
    repeated once with the interior budget reduced by the excess. A mesh still more than 10% off
    raises QmeshError saying why (the boundary alone needs more vertices to keep q_ij ≥ 0, or
    cannot carry that many). Warns `QmeshWarning` when the domain is thinner than about two
    elements in the metric, saying what N would be needed.
    """
    if getattr(domain, "regions", ()) or (not isinstance(anisotropy, Anisotropy) and hasattr(anisotropy, "items")):
        from qmesh import media   # a mapping conductivity or a domain with regions: heterogeneous media
        return media.mesh(domain, anisotropy, target_vertices=target_vertices, size=size, alpha=alpha,
                          quality_threshold=quality_threshold, min_area=min_area, max_iterations=max_iterations,
                          seed=seed, boundary_refinement=boundary_refinement, progress=progress, **unknown)
    check_keywords(unknown, iterate, "mesh")
    options = dict(target_vertices=target_vertices, size=size, alpha=alpha,
                   quality_threshold=quality_threshold, min_area=min_area,
                   max_iterations=max_iterations, seed=seed, boundary_refinement=boundary_refinement)
    if progress is not None and not callable(progress):
        raise QmeshError(f"progress must be a function of one Step, got {type(progress).__name__}")
    m = _final(iterate(domain, anisotropy, **options), progress)
    target = target_vertices
    if target is not None and m.n_vertices > 1.1 * target:
        fewer = target - (m.n_vertices - target)
        if fewer > len(as_domain(domain).seeds):
            again = _final(iterate(domain, anisotropy, **{**options, "target_vertices": fewer}),
                           progress)
            if abs(again.n_vertices - target) < abs(m.n_vertices - target):
                m = again
    _check_count(m, target, boundary_refinement)
    from qmesh.mesher.diagnose import warn_if_thin   # a domain thinner than two elements: say so
    warn_if_thin(m, anisotropy)
    return m


def _final(steps, progress=None) -> Mesh:
    last = None
    for last in steps:
        if progress is not None:
            progress(last)
    return last.mesh


def _check_count(m: Mesh, target, boundary_refinement) -> None:
    if target is None or abs(m.n_vertices - target) <= 0.1 * target:
        return
    if m.n_vertices > target:
        raise QmeshError(f"target_vertices = {target} is too few: keeping every q_ij >= 0 on the "
                         f"boundary needs {m.n_vertices} vertices here; ask for at least "
                         f"{m.n_vertices}")
    interior = int((~m.boundary).sum())
    why = (" (the domain is thinner than one element at this size, so no interior vertex fits)"
           if interior == 0 else "")
    hint = "" if boundary_refinement else "; allow boundary_refinement to add boundary vertices"
    raise QmeshError(f"target_vertices = {target} cannot be met: the mesh has {m.n_vertices} "
                     f"vertices{why}{hint}")
