"""Meshes of heterogeneous media: a conductivity per region, q_ij ≥ 0 on interfaces too.

MEDIA.md §2–3. An interface is a boundary segment seen from both sides, each in its own
region's metric: q_ij = Σ_T q_ij^T and each side's share is ≥ 0 when its apex lies outside the
diametral ellipse of the edge in its own metric, which is what the single-region mesher already
guarantees on its boundary (GEOMETRY.md §1). So each face of the partition (partition.py) is
meshed on its own by Algorithm 2.1 (qmesh.mesher.loop), on shared interface points:

    cut every interface edge into pieces ≤ h in the metric of both sides (sizing.py)
    for each face in turn
        mesh it, every interface point known so far fixed
        insert the points it added on an interface into the finished neighbours:
            split their boundary edge there, flip back to Q-Delaunay (insert_shared.py)
    stitch the face meshes into one Mesh with region_tags (stitch.py)

Re-meshing a neighbour instead (the first version) made two faces meeting at a small metric
angle hand each other ever closer split points (a cascade of concentric shells that never
lined up); inserting adds no point, so the pass ends, and keeps q_ij ≥ 0 (insert_shared.py).
Input points stay fixed, points the face meshers add on the outline or a hole slide as usual,
interface points are fixed once shared (junctions are input points). Each triangle is meshed,
adjusted and measured in its own region's metric.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping
from typing import Iterator

import numpy as np

from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.domain.domain import as_domain
from qmesh import measure
from qmesh.errors import QmeshError, QmeshWarning
from qmesh.media import faces as _faces
from qmesh.media import sizing as _sizing
from qmesh.media.insert_shared import insert_on_boundary
from qmesh.domain.partition import Ring, partition
from qmesh.media.stitch import stitch
from qmesh.mesher.loop import mesh as mesh_one       # the single-region mesher, untouched
from qmesh.mesher.options import Options
from qmesh.triangle_mesh import Mesh
from qmesh.mesher import sizing as _msizing
from qmesh.mesher.step import Stats, Step

CORRECTIONS = 3      # reruns of mesh() that correct N towards target_vertices
_PASSED = ("alpha", "quality_threshold", "max_iterations", "seed", "boundary_refinement")


def partition_of(domain):
    """The domain's partition (one face per connected piece of Ω when it has no regions)."""
    if domain._partition is not None:
        return domain._partition
    rings = [Ring(np.asarray(R), 0, "the outline" if j == 0 else f"hole {j}")
             for j, R in enumerate(domain.rings)]
    offs = np.cumsum([0] + [len(R) for R in domain.rings])
    tags = [domain.segment_tags[o:o + len(R)] for o, R in zip(offs, domain.rings)]
    return partition(rings, tags, domain.diameter)


def conductivities(domain, conductivity, part) -> dict:
    """{region tag: Anisotropy} for every region that has a face; QmeshError for a missing
    region, an unknown tag or a value that is not an Anisotropy."""
    present = sorted({f.region for f in part.faces})
    if isinstance(conductivity, Anisotropy):
        return {r: conductivity for r in present}
    if not isinstance(conductivity, Mapping):
        raise QmeshError("the conductivity must be a qmesh.Anisotropy or a mapping {region tag: "
                         f"Anisotropy}}, got {type(conductivity).__name__}")
    out = {}
    for k, v in conductivity.items():
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise QmeshError(f"conductivity keys must be region tags (integers), got {k!r}")
        if not isinstance(v, Anisotropy):
            raise QmeshError(f"the conductivity of region {k} must be a qmesh.Anisotropy, "
                             f"got {type(v).__name__}")
        if not 0 <= int(k) <= len(domain.regions):
            raise QmeshError(f"the conductivity names region {k}, but the domain has regions "
                             f"0 to {len(domain.regions)}")
        out[int(k)] = v
    missing = [r for r in present if r not in out]
    if missing:
        names = domain.region_names
        what = ", ".join(f"{r}" + (f" ({names[r]})" if r in names else "") for r in missing)
        raise QmeshError(f"no conductivity for region {what}: give one Anisotropy per region "
                         f"(tags {present})")
    return out


def iterate(domain, conductivity, *, target_vertices: int | None = None, size: float | None = None,
            min_area: float | None = None, _every: bool = True, **options) -> Iterator[Step]:
    """Mesh a domain with regions, yielding a `Step` after each face (the stitched, conforming
    mesh of the faces done so far; the last one is the whole domain, `converged`).

    `conductivity`: one Anisotropy, or {region tag: Anisotropy} covering every region;
    `target_vertices` N of the stitched mesh (shared between faces by metric area), or `size`
    the metric edge length h in each region's metric with its size divided out (sizing.py);
    the other options (alpha, quality_threshold,
    max_iterations, seed, boundary_refinement) go to each face's mesher.
    """
    if min_area is not None:
        raise QmeshError("min_area is a metric area in one metric; with regions each face uses "
                         "its own, so it cannot be given (leave it out)")
    unknown = set(options) - set(_PASSED)
    if unknown:
        raise QmeshError(f"unknown option {sorted(unknown)[0]!r} for a domain with regions "
                         f"(allowed: target_vertices, size, {', '.join(_PASSED)})")
    domain = as_domain(domain)
    Options.checked(target_vertices=target_vertices, size=size,
                    **{k: options[k] for k in _PASSED if k in options})
    part = partition_of(domain)
    cond = conductivities(domain, conductivity, part)
    plan = lambda ask: _Plan(domain, part, cond, ask, size)                    # noqa: E731
    return _corrected(plan, lambda p: _faces_in_turn(p, options, _every), target_vertices)


def _corrected(plan, run, target: int | None) -> Iterator[Step]:
    """The steps of the first pass; with a target, a result more than 5% off is redone (at most
    CORRECTIONS times) with the request scaled by the ratio missed (the interface cuts make the
    first estimate high). The closest pass's mesh is the last Step, so `mesh` returns it; its
    faces' warnings are given at the end (not those of the passes left behind), and a
    QmeshWarning says when it is still more than 10% off."""
    kept = plan(target)
    for step in run(kept):
        yield step
    best = step
    ask = target
    for _ in range(CORRECTIONS if target is not None else 0):
        if abs(best.mesh.n_vertices - target) <= 0.05 * target:
            break
        ask = int(round(ask * target / best.mesh.n_vertices))
        try:
            again = plan(ask)
            for step in run(again):
                yield step
        except QmeshError:
            break
        if abs(step.mesh.n_vertices - target) < abs(best.mesh.n_vertices - target):
            best, kept = step, again
    if step is not best:
        yield best                                   # the closest pass ends the run
    for message, category in kept.notes:    # a face's own warning (a thin face, say)
        warnings.warn(message, category, stacklevel=3)
    if target is not None and abs(best.mesh.n_vertices - target) > 0.1 * target:
        warnings.warn(f"target_vertices = {target}: the mesh has {best.mesh.n_vertices} vertices "
                      "(the interfaces and q_ij >= 0 on them need these)", QmeshWarning, stacklevel=3)


class _Plan:
    """Per face: its anisotropy, size k, metric area; the global h; the first interface cuts."""

    def __init__(self, domain, part, cond, target_vertices, size):
        self.domain, self.part = domain, part
        self.faces = part.faces
        self.anis = [cond[f.region] for f in self.faces]
        bare = [_faces.face_domain(part, f, {}, self.face_name(i)) for i, f in enumerate(self.faces)]
        self.k = [_sizing.region_scale(a, d.seeds) for a, d in zip(self.anis, bare)]
        area = [_msizing.metric_area(d, a) / k for d, a, k in zip(bare, self.anis, self.k)]
        lengths = [_sizing.edge_lengths(*d.segment_ends, a, k)
                   for d, a, k in zip(bare, self.anis, self.k)]

        def pieces(h):
            return _sizing.interface_pieces(part, self.anis, self.k, h)
        if target_vertices is not None:
            if target_vertices <= len(part.points):
                raise QmeshError(f"target_vertices = {target_vertices} must exceed the "
                                 f"{len(part.points)} input points of the domain and its regions")
            self.h = _sizing.size_for_vertices(part, area, lengths, target_vertices, pieces)
        else:
            self.h = float(size) if size is not None else float(np.mean(np.concatenate(lengths)))
            n = _sizing.expected_vertices(part, area, lengths, self.h, pieces)
            _msizing.check_vertex_count(n, f"size = {self.h:.3g}")
        self.target = target_vertices
        self.extra = self._cuts(pieces(self.h))
        self.notes: list = []       # (message, category) the faces' meshers warned in this pass

    def face_name(self, i: int) -> str:
        r = self.faces[i].region
        names = self.domain.region_names
        return f"region {r}" + (f" ({names[r]})" if r in names else "")

    def _cuts(self, pieces) -> dict:
        """Evenly spaced points on every interface edge cut into more than one piece."""
        V, E = self.part.points, self.part.edges
        out = {}
        for e in np.flatnonzero(pieces > 1):
            t = (np.arange(1, pieces[e]) / pieces[e])[:, None]
            out[int(e)] = V[E[e, 0]] + t * (V[E[e, 1]] - V[E[e, 0]])
        return out

    def size_of(self, i: int) -> float:
        """The face mesher's `size`: h in the user's metric ∇²s_r (= h·√k_r)."""
        return self.h * np.sqrt(self.k[i])


def _mesh_face(plan, i, extra, options):
    dom = _faces.face_domain(plan.part, plan.faces[i], extra, plan.face_name(i))
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        # a face thinner (or sharper) in its metric than the shared size needs a finer one:
        # its own mesher says "too large"; halve the size for this face, a few times
        for k in range(FINER + 1):
            try:
                m = mesh_one(dom, plan.anis[i], size=plan.size_of(i) / 2**k, **options)
                break
            except QmeshError as e:
                if k == FINER or "too large" not in str(e):
                    raise QmeshError(f"{plan.face_name(i)}: {e}") from None
    # a face's own warning (a thin face, say), naming its region, for the end of the run
    plan.notes += [(f"{plan.face_name(i)}: {w.message}", w.category) for w in said]
    return m, len(dom.seeds)


def _faces_in_turn(plan, options, every: bool = True) -> Iterator[Step]:
    """Mesh the faces one after another, each with every interface point known so far fixed;
    the points a face adds on an interface go into the finished neighbours at once
    (insert_shared.py), so every Step's mesh is conforming and the pass ends."""
    part, n_faces = plan.part, len(plan.faces)
    extra = dict(plan.extra)                 # interface points shared so far, per edge
    meshes = [None] * n_faces
    face_edges = [np.unique(np.concatenate([part.cycle(c) for c in f.cycles]) >> 1)
                  for f in plan.faces]
    order = sorted(range(n_faces), key=lambda i: -plan.faces[i].region)   # regions first
    done = []
    for step, i in enumerate(order, start=1):
        t0 = time.perf_counter()
        meshes[i], n_seeds = _mesh_face(plan, i, extra, options)
        new = {e: X for e, X in _faces.points_on_edges(meshes[i], part, n_seeds).items()
               if part.interface[e]}
        for e, X in new.items():
            extra[e] = _faces.merge_points(part, e, extra.get(e), X)
        added = sum(len(X) for X in new.values())
        done.append(i)
        _share(plan, meshes, done, face_edges, new, extra)
        if not every and step < n_faces:     # mesh() without progress: the last Step only
            continue
        m = stitch(part, [meshes[k] for k in done], [plan.faces[k].region for k in done],
                   plan.domain)
        seconds = time.perf_counter() - t0
        cond = {plan.faces[k].region: plan.anis[k] for k in done}
        q = measure.quality(m, cond)
        yield Step("triangulate", step, m,
                   Stats(m.n_vertices, m.n_triangles, measure.energy(m, cond), float(q.min()),
                         float(q.mean()), added=added, seconds=seconds),
                   converged=step == n_faces)


MAX_HANDOVERS = 1000
FINER = 6              # halvings of the size a face that is too thin for it may take


def _share(plan, meshes, done, face_edges, new, extra) -> None:
    """Hand the interface points `new` {edge: points} to the finished faces beside them; the
    points those must add in turn (a shell split on an interface) are handed on likewise."""
    part = plan.part
    queue = [new]
    for _ in range(MAX_HANDOVERS):
        if not queue:
            return
        pts = queue.pop()
        for j in done:
            give = {e: X for e, X in pts.items() if e in set(face_edges[j].tolist())}
            if not give:
                continue
            try:
                meshes[j], more = insert_on_boundary(meshes[j], plan.anis[j], give, part)
            except ValueError as err:
                raise QmeshError(f"{plan.face_name(j)}: {err}") from None
            for e, X in more.items():
                extra[e] = _faces.merge_points(part, e, extra.get(e), X)
            if more:
                queue.append(more)
    raise QmeshError("the faces kept handing each other interface points (more than "
                     f"{MAX_HANDOVERS} hand-overs); ask for more vertices")


def mesh(domain, conductivity, *, target_vertices: int | None = None, progress=None,
         **options) -> Mesh:
    """Mesh a domain with regions to the end: the mesh of the last Step of `iterate` with the
    same arguments (its corrections towards target_vertices included)."""
    if progress is not None and not callable(progress):
        raise QmeshError(f"progress must be a function of one Step, got {type(progress).__name__}")
    return _last(iterate(domain, conductivity, target_vertices=target_vertices,
                         _every=progress is not None, **options), progress)


def _last(steps, progress) -> Mesh:
    last = None
    for last in steps:
        if progress is not None:
            progress(last)
    return last.mesh
