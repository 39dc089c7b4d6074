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
density (seeding.py); a varying s starts from random points and grows coarse to fine.
"""

from __future__ import annotations

import time
from typing import Iterator

import numpy as np

from . import seeding, sizing, topology
from .adjust import limit_moves, newton_step
from .boundary import hold_off_boundary, snap_to_boundary
from .errors import QmeshError
from .geometry import quadratic_form
from .insert import insert, relocate_degree3, target_area
from .mesh import Mesh, Stats, Step
from .options import check_keywords, check_options
from .triangulate import q_delaunay, restore

BOUNDARY_FACTOR = 1.0   # split boundary edges longer than this many target metric lengths
LATTICE_FILL = 0.97     # the initial lattice holds this share of the expected interior vertices
MOVE_TOL = 0.02        # converged when the rms metric move is below this fraction of h


def _check_options(target_vertices, size, alpha, quality_threshold, min_area, max_iterations,
                   seed, boundary_refinement=True):
    check_options(target_vertices, size, alpha, quality_threshold, min_area, max_iterations,
                  seed, boundary_refinement)


class _State:
    """The mutable arrays of one run; Steps get read-only snapshots of them."""

    def __init__(self, domain, anisotropy, P, fixed, edge_id):
        self.domain, self.anisotropy = domain, anisotropy
        self.P, self.fixed, self.edge_id = P, fixed, edge_id
        self.T = q_delaunay(P, anisotropy)
        self.twin = topology.twins(self.T)
        self.mesh = Mesh(P, self.T, fixed)

    def tangents(self) -> np.ndarray:
        _, tan = self.domain.edges
        t = np.zeros_like(self.P)
        on = self.edge_id >= 0
        t[on] = tan[self.edge_id[on]]
        t[self.fixed] = 0.0
        return t

    def on_boundary(self) -> np.ndarray:
        """Boundary vertices: the seeds and the vertices sliding on the polygon's edges."""
        return self.fixed | (self.edge_id >= 0)

    def corner_edge(self) -> np.ndarray:
        """Polygon edge that starts at each boundary vertex (seeds: their outgoing edge)."""
        ce = self.edge_id.copy()
        ce[self.fixed] = np.arange(int(self.fixed.sum()))
        return ce

    def stats(self, **extra) -> Stats:
        return Stats(self.mesh.n_vertices, self.mesh.n_triangles,
                     source=(self.mesh, self.anisotropy), **extra)


def iterate(domain, anisotropy, *, target_vertices: int | None = None, size: float | None = None,
            alpha: float = 0.5, quality_threshold: float = 0.5, min_area: float | None = None,
            max_iterations: int = 40, seed: int | None = 0,
            boundary_refinement: bool = True) -> Iterator[Step]:
    """Run Algorithm 2.1, yielding a `Step` after every stage.

    target_vertices   final vertex count N (lands within a few percent), or
    size              target metric edge length h (default: the mean metric length of the
                      domain's edges, so the seed points set the size as in the chapter);
    alpha             relaxation of the vertex step (2.92); ½ as in the chapter;
    quality_threshold triangles of metric quality (2.94) below it get a point, unless
    min_area          their metric area is below this (default: 1/16 of the target triangle's);
    max_iterations    cap on the repeat loop;
    seed              seed of the random initial interior points, or of the tiny jitter of
                      the lattice for a constant Q (same seed ⇒ same mesh);
    boundary_refinement  allow vertices on the boundary between the seed points.
    """
    _check_options(target_vertices, size, alpha, quality_threshold, min_area, max_iterations, seed,
                   boundary_refinement)
    seeds = domain.seeds
    anisotropy.check_convex(np.concatenate([seeds, seeds.mean(axis=0, keepdims=True)]))
    area_m = sizing.metric_area(domain, anisotropy)
    lengths = sizing.metric_edge_lengths(domain, anisotropy)
    bfac = BOUNDARY_FACTOR if boundary_refinement else None
    if target_vertices is not None:
        if target_vertices <= len(seeds):
            raise QmeshError(f"target_vertices = {target_vertices} must exceed the "
                             f"{len(seeds)} seed boundary points")
        h = sizing.size_for_vertices(area_m, lengths, target_vertices, bfac)
    else:
        h = float(size) if size is not None else float(lengths.mean())
        sizing.check_vertex_count(sizing.vertices_for_size(area_m, lengths, h, bfac),
                                  f"size = {h:.3g}")
    min_area = target_area(h) / 16 if min_area is None else float(min_area)
    rng = np.random.default_rng(seed)

    # 1. read the boundary points; select initial interior points: the metric lattice for a
    #    constant Q, else about as many random points as boundary points (seeding.py)
    if anisotropy.is_constant:
        if target_vertices is None:
            inner = seeding.metric_lattice(domain, anisotropy.H, h, rng)
        else:
            n_b = sizing.boundary_vertices(lengths, h, bfac)
            inner = seeding.lattice_for_count(domain, anisotropy.H,
                                              LATTICE_FILL * (target_vertices - n_b), rng)
    else:
        n_int = len(seeds) if target_vertices is None else min(len(seeds),
                                                                target_vertices - len(seeds))
        inner = seeding.random_interior(domain, n_int, rng)
    P = np.concatenate([seeds, inner])
    fixed = np.zeros(len(P), bool)
    fixed[:len(seeds)] = True
    edge_id = np.full(len(P), -1, np.int64)

    # 2. construct the Q-weighted Delaunay triangulation from scratch (Qhull)
    t0 = time.perf_counter()
    st = _State(domain, anisotropy, P, fixed, edge_id)
    yield Step("triangulate", 0, st.mesh, st.stats(seconds=time.perf_counter() - t0))

    for it in range(1, max_iterations + 1):
        # 3. adjust vertices (2.91)–(2.93); those sent out of Ω go onto the boundary
        t0 = time.perf_counter()
        P0, T0 = st.P, st.T
        d = newton_step(P0, T0, anisotropy, fixed=st.fixed, tangent=st.tangents(), alpha=alpha)
        keep = None
        if boundary_refinement:
            snap = snap_to_boundary(P0, T0, st.twin, d, st.on_boundary(), st.corner_edge(),
                                    anisotropy)
            if len(snap.vertices):
                st.T, st.twin = snap.T, snap.twin
                d[snap.vertices] = snap.positions - P0[snap.vertices]
                st.edge_id = st.edge_id.copy()
                st.edge_id[snap.vertices] = snap.edge_id
                keep = np.zeros(len(P0), bool)
                keep[snap.vertices] = True
        else:
            d = hold_off_boundary(P0, T0, st.twin, d, st.on_boundary(), anisotropy)
        Pn, d = limit_moves(P0, st.T, d, keep)
        Pn = _onto_edges(domain, Pn, st.edge_id)
        Hv = anisotropy.H if anisotropy.is_constant else np.asarray(anisotropy.hessian(P0))
        move2 = quadratic_form(d[:, None], Hv)
        max_move = float(np.sqrt(move2.max()) / h)
        rms_move = float(np.sqrt(move2.mean()) / h)
        st.P = Pn
        st.mesh = Mesh(Pn, st.T if st.T is not T0 else st.mesh.triangles, st.fixed)
        yield Step("adjust", it, st.mesh,
                   st.stats(max_move=max_move, rms_move=rms_move, seconds=time.perf_counter() - t0), moved=Pn - P0)

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
        st.P = np.concatenate([st.P, ins.points])
        st.fixed = np.concatenate([st.fixed, np.zeros(k, bool)])
        st.edge_id = np.concatenate([st.edge_id, ins.edge_id])
        added = np.concatenate([relocated, np.arange(n_old, n_old + k)])
        st.mesh = Mesh(st.P, st.T, st.fixed) if len(added) else st.mesh
        yield Step("insert", it, st.mesh,
                   st.stats(added=len(added), seconds=time.perf_counter() - t0), added=added)

        # 5. construct the Q-Delaunay triangulation again, by flips on the kept connectivity
        t0 = time.perf_counter()
        st.T, st.twin, flips = restore(st.P, st.T, st.twin, anisotropy)
        st.mesh = Mesh(st.mesh.points, st.T, st.fixed) if flips else st.mesh
        n_edges = len(st.twin) // 2
        converged = (len(added) == 0 and flips <= max(2, 1e-3 * n_edges) and rms_move < MOVE_TOL)
        yield Step("triangulate", it, st.mesh,
                   st.stats(flips=flips, seconds=time.perf_counter() - t0), converged=converged)
        if converged:
            return


def _onto_edges(domain, P, edge_id):
    """Put sliding boundary vertices back exactly on their polygon edge (round-off only)."""
    on = edge_id >= 0
    if on.any():
        A, tan = domain.edges
        a, t = A[edge_id[on]], tan[edge_id[on]]
        P = P.copy()
        P[on] = a + np.einsum("ni,ni->n", P[on] - a, t)[:, None] * t
    return P


def mesh(domain, anisotropy, **options) -> Mesh:
    """Run Algorithm 2.1 to convergence (or `max_iterations`) and return the final mesh."""
    check_keywords(options, iterate, "mesh")
    last = None
    for last in iterate(domain, anisotropy, **options):
        pass
    return last.mesh
