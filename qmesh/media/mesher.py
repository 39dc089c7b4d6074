"""Meshes of heterogeneous media: a conductivity per region, q_ij ≥ 0 on interfaces too.

MEDIA.md §2–3. An interface is a boundary segment seen from both sides, each in its own
region's metric: q_ij = Σ_T q_ij^T and each side's share is ≥ 0 when its apex lies outside the
diametral ellipse of the edge in its own metric, which is what the single-region mesher already
guarantees on its boundary (GEOMETRY.md §1). So each face of the partition is meshed by
Algorithm 2.1 itself (`mesher.loop.iterate`), on shared interface points:

    size every face once, interfaces cut into pieces ≤ h in both metrics   (plan.py)
    for each face, smallest region first (small faces of one Q together: mesher.components)
        size the faces left for what the target leaves                     (plan.size_rest)
        run Algorithm 2.1 on it, every interface point known so far fixed
        insert its interface points into the finished neighbours (insert_shared.py; slivers: again)
    stitch the face meshes into one Mesh with region_tags                   (stitch.py)
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from qmesh.domain.domain import as_domain
from qmesh.errors import QmeshError, QmeshWarning
from qmesh.geometry.portable import dot2
from qmesh.geometry.triangles import worst_metric_quality
from qmesh.domain.partition import points_on_edges
from qmesh.domain.faces import face_domain
from qmesh.media.insert_shared import insert_on_boundary
from qmesh.media.plan import MediaPlan
from qmesh.mesher.face_meshes import FaceMeshes
from qmesh.media.stitch import stitch
from qmesh.mesher import loop, polish, sizing
from qmesh.mesher.components import Components, split
from qmesh.mesher.diagnose import thin_faces
from qmesh.mesher.options import Options, check_keywords
from qmesh.mesher.plan import TOLERANCE    # a mesh this share off target_vertices is warned about
from qmesh.mesher.step import Stats, Step, last_step, recording, summed_up
from qmesh.triangle_mesh import Mesh

FLOOR = 0.3            # a hand-over leaving a face's worst quality below this meshes it again
FINER = 12             # halvings of the size for a face too thin for it (6 beyond plan.COARSER)
MAX_GROWTH = 10        # ... while the face alone stays under this many times target_vertices
MIN_GROWTH = 30_000    # ... or this many vertices (a thin region of a small target meshes, warned)
MAX_HANDOVERS = 1000   # rounds of interface points handed between finished faces
MAX_NOTES = 3          # the faces' warnings shown one by one; beyond, one line counts them
TURNING = 1.5          # a field face whose run at the plan's size took this many times the plan's
                       # count (its field turns across an element there) is named if N overshoots


def iterate(domain: Any, conductivity: Any, *, target_vertices: int | None = None, size: float | None = None,
            min_area: float | None = None, **options: Any) -> Iterator[Step]:
    """Mesh a domain with regions, yielding a `Step` after every stage of every run of Algorithm
    2.1 (its mesh: the faces done so far and this run's, stitched) and a last Step, the whole
    domain, the only one `converged`. `conductivity`: one Anisotropy, or {region tag: Anisotropy}
    covering every region; `target_vertices` N of the stitched mesh, or `size` h in each region's
    metric with its size divided out (plan.py); the other options (`qmesh.iterate`'s but
    min_area) go to each run. The arguments are checked now."""
    return _run(_plan(domain, conductivity, target_vertices, size, min_area, options), options, True)


def mesh(domain: Any, conductivity: Any, *, target_vertices: int | None = None, size: float | None = None,
         min_area: float | None = None, progress: Callable[[Step], object] | None = None,
         **options: Any) -> Mesh:
    """Mesh a domain with regions to the end: the mesh of the last Step of `iterate` with the
    same arguments; `progress`, when given, is called with every Step."""
    plan = _plan(domain, conductivity, target_vertices, size, min_area, options)
    return last_step(_run(plan, options, progress is not None), progress).mesh


def _plan(domain: Any, conductivity: Any, target_vertices: int | None, size: float | None,
          min_area: float | None, options: dict) -> MediaPlan:
    if min_area is not None:
        raise QmeshError("min_area is a metric area in one metric; with regions each face uses "
                         "its own, so it cannot be given (leave it out)")
    check_keywords(options, loop.iterate, "mesh")        # the options of a run with one Q
    Options.checked(target_vertices=target_vertices, size=size, **options)
    return MediaPlan(as_domain(domain), conductivity, target_vertices, size)


def _run(plan: MediaPlan, options: dict, every: bool) -> Iterator[Step]:
    """The faces in the plan's order (several in one run: `_group`), each run to its end and shared
    with the finished ones; with `every`, a Step per stage of each run; the stitched whole last."""
    extra = plan.extra                       # interface points shared so far, per edge (counted)
    assert extra is not None                 # made with the plan's h
    meshes = FaceMeshes()                    # the finished faces, in the order they were meshed
    notes: list = []                         # (message, category) the faces' runs warned
    cond = {f.region: a for f, a in zip(plan.faces, plan.anis)}
    at, alone, redone = 0, set[int](), set[int]()   # faces of a group whose run failed; meshed again
    turned: list[str] = []                   # field faces whose runs took far more than planned
    while at < len(plan.order):
        if at and plan.resize_due(at):
            plan.size_rest(plan.order[at:], meshes.vertex_count())
        faces, dom, sizes, size = _group(plan, at, extra, meshes, alone)
        said: list = []
        try:
            for step in _face_steps(plan, faces, dom, options, said, size):
                if every:
                    m = stitch(plan.part, {**meshes, **dict(zip(faces, split(step.mesh, sizes)))}, plan.domain)
                    yield Step(step.stage, step.iteration, m, Stats(m.n_vertices, m.n_triangles,
                               seconds=step.stats.seconds, source=(m, cond)))
        except QmeshError:
            if len(faces) == 1:
                raise
            alone.update(faces)              # meshed one by one instead
            continue
        notes += [(f"{plan.face_name(faces[0])}: {w.message}", w.category) for w in said]
        if _turned(plan, faces, dom, size, step.mesh):
            turned.append(plan.face_name(faces[0]))
        ran = polish.collapse_poor_fans(step.mesh, plan.anis[faces[0]], plan.part.outline_tags)
        done = split(ran, sizes)
        for i, thin in zip(faces, thin_faces(done, plan.anis[faces[0]], plan.k[faces[0]])):
            notes += [] if thin is None else [(f"{plan.face_name(i)}: {thin}", QmeshWarning)]
        meshes.add(faces, done)
        todo = [ran]                        # a run's mesh (its poor fans mended), then the faces meshed again
        while todo:
            todo += _share(plan, meshes, todo.pop(), extra, options, redone)
        at += len(faces)
    m = stitch(plan.part, meshes, plan.domain)
    yield Step("triangulate", step.iteration, m, Stats(m.n_vertices, m.n_triangles, source=(m, cond)),
               converged=True)
    for message, category in summed_up(notes, MAX_NOTES):
        warnings.warn(message, category, stacklevel=3)
    if plan.target is not None and abs(m.n_vertices - plan.target) > TOLERANCE * plan.target:
        least = (f", about the least these regions need (their widths in their own metrics and "
                 f"q_ij >= 0 on their interfaces); ask for more for N to follow the target"
                 if m.n_vertices > plan.target and plan.h_rest > plan.h_euler else
                 " (the interfaces and q_ij >= 0 on them need these)")
        if turned and m.n_vertices > plan.target:
            one = len(turned) == 1
            holds, it = ("holds a field that turns", "it") if one else ("hold fields that turn", "them")
            least = (f": {', '.join(turned)} {holds} across an element at the size the target "
                     f"gives, and took more than {TURNING:g} times the vertices planned for {it} "
                     "to keep the triangles' shapes; ask for more for N to follow the target")
        warnings.warn(f"target_vertices = {plan.target}: the mesh has {m.n_vertices} vertices"
                      + least, QmeshWarning, stacklevel=3)


def _turned(plan: MediaPlan, faces: list, dom: Any, size: dict, mesh: Mesh) -> bool:
    """Whether one face holding a field's metric (no s), run at a size, took over TURNING times
    the vertices the plan counted for it: its run added points where the field turns across an
    element, which the plan's count of area and boundary does not foresee."""
    a = plan.anis[faces[0]]
    if len(faces) > 1 or "size" not in size or a.is_constant or a.potential:
        return False
    planned = plan.counter(faces, plan.thin)(plan.h_rest) + len(dom.seeds)
    return mesh.n_vertices > TURNING * planned


def _group(plan: MediaPlan, at: int, extra: dict, meshes: FaceMeshes, alone: set) -> tuple[list, Any, list, dict]:
    """The faces of one run from the plan's at-th on, their domain, point counts and sizing: it, and
    while all are small and of its constant Q and sizing, the next ones (not the last) touching
    none before them, taken in batches that double (a call per face cost more than its share)."""
    i, part = plan.order[at], plan.part
    try:
        dom = face_domain(part, plan.faces[i], extra, plan.face_name(i))
    except QmeshError as e:
        raise plan.too_small(i) or e from None
    first = plan.sizing_of(i, dom, meshes)
    faces, rings, tags, sizes, batch = [i], list(dom.rings), [dom.segment_tags], [len(dom.seeds)], 8
    taken, k, last = dom.seeds, at + 1, len(plan.order) - 1
    while plan.small([i], alone, i)[0] and k < last:
        chunk = np.asarray(plan.order[k:min(k + batch, last)])
        chunk = chunk[:np.argmin(np.append(plan.small(chunk, alone, i), False))]
        if not len(chunk):
            break
        r = part.faces_rings([plan.faces[j] for j in chunk.tolist()], extra)
        fits = ~r.touching(taken) & plan.same_sizing(chunk, r, first, meshes)
        n = int(np.argmin(np.append(fits, False)))
        faces += chunk[:n].tolist()
        rings += r.split(r.points, r.ring_sizes)[:int(r.face_rings[:n].sum())]
        tags.append(r.tags[:int(r.face_sizes[:n].sum())])
        sizes += r.face_sizes[:n].tolist()
        if n < batch:
            break
        taken, k, batch = np.concatenate([taken, r.points]), k + n, 2 * batch
    if len(faces) > 1:
        dom = Components(rings, tags, sizes)
        dom.media_face = True          # a side is a partition edge (corners.side_runs)
    return faces, dom, sizes, first


def _face_steps(plan: MediaPlan, faces: list, dom: Any, options: dict, said: list,
                size: dict) -> Iterator[Step]:
    """Algorithm 2.1 on the faces (one, or several as one domain `dom`) sized by `size`, its Steps as
    they come, its warnings in `said`. A face thinner (or sharper) in its metric than the shared
    size needs a finer one: its run says "too large", and its size is halved, up to FINER times."""
    i = faces[0]
    for k in range(FINER + 1 if len(faces) == 1 else 1):
        try:
            sizing = {"size": plan.h_rest * np.sqrt(plan.k[i]) / 2**k} if k else size
            for last in recording(loop.iterate(dom, plan.anis[i], **sizing, **options), said):
                yield last
            break
        except QmeshError as e:          # a group's: meshed one by one instead (`_run`)
            if len(faces) > 1 or k == FINER or ("too large" not in str(e) and "target_vertices" not in str(e)):
                raise plan.too_small(i) or QmeshError(f"{plan.face_name(i)}: {_as_asked(plan, e)}") from None
            _check_growth(plan, faces, dom, k + 1, e)


def _check_growth(plan: MediaPlan, faces: list, dom: Any, k: int, e: QmeshError) -> None:
    """Before a face's k-th halving of its size (its run refused the last one, `e`): QmeshError
    when the face alone would then take more than MAX_GROWTH times target_vertices and more than
    MIN_GROWTH vertices (a strip 0.002 wide of a target of 100 needs ~6 600: warned, meshed; each
    halving quadruples it: twelve of them made a 1e6-vertex mesh of a target of 3 000, in six
    minutes), with the run's reason and the count the next size would need."""
    if plan.target is None:
        return
    need = plan.counter(faces, plan.thin)(plan.h_rest / 2**k) + len(dom.seeds)
    if need > max(MAX_GROWTH * plan.target, MIN_GROWTH):
        raise QmeshError(f"{plan.face_name(faces[0])}: target_vertices = {plan.target} cannot be met: "
                         f"its run at {'the' if k == 1 else f'{2**(k - 1)}× finer than the'} target's size failed "
                         f"({_as_asked(plan, e)}), and the next finer size would put about "
                         f"{need:.3g} vertices in it alone, more than {MAX_GROWTH}× the target") from None


def _as_asked(plan: MediaPlan, e: QmeshError) -> str:
    """A face run's refusal in the terms the user asked in: its run was sized by the medium's
    plan (`size = …`), which a user who gave target_vertices never gave."""
    text = str(e)
    if plan.target is None or not text.startswith("size = ") or ": " not in text:
        return text
    why = text.split(": ", 1)[1].replace("ask for more vertices (a smaller size)", "ask for more vertices")
    return f"target_vertices = {plan.target} is too few for it: {why}"


def _share(plan: MediaPlan, meshes: FaceMeshes, mesh: Mesh, extra: dict, options: dict, redone: set) -> list:
    """Hand the points `mesh` (a run's) put on interfaces to the finished faces beside them (and
    into `extra`), and the points those must add in turn (a split on an interface) likewise. A
    finished face whose worst metric quality such points drop below FLOOR (a fan of them next to
    its corner, finer than its own spacing) is meshed again with them fixed, once, and kept (and
    returned, its points to share in turn) when its run, grading towards them, shapes it better."""
    part, rank, remeshed = plan.part, meshes.rank, []     # rank: kept as faces are added
    new = points_on_edges(mesh, plan.corners, int(mesh.fixed.sum()))
    queue, before = [{e: X for e, X in new.items() if part.interface[e]}], dict[int, float]()
    for _ in range(MAX_HANDOVERS):
        if not queue:
            break
        pts = queue.pop()
        for e, X in pts.items():          # old and new, without repeats, ordered along the edge
            a, b = part.points[part.edges[e]]
            X = np.unique(X if e not in extra else np.concatenate([extra[e], X]), axis=0)
            extra[e] = X[np.argsort(dot2(X - a, b - a), kind="stable")]
        given: dict[int, dict] = {}        # the finished faces beside these edges only, their points
        for e, f in zip(pts, part.edge_faces[list(pts)].tolist()):
            for j in {j for j in f if j in rank}:
                given.setdefault(j, {})[e] = pts[e]
        for j in sorted(given, key=lambda f: rank[f]):
            before[j] = before[j] if j in before else _worst(meshes[j], plan.anis[j])
            try:
                meshes[j], more = insert_on_boundary(meshes[j], plan.anis[j], given[j], part)
            except QmeshError as err:
                raise QmeshError(f"{plan.face_name(j)}: {err}") from None
            if more:
                queue.append(more)
    else:
        raise QmeshError("the faces kept handing each other interface points (more than "
                         f"{MAX_HANDOVERS} hand-overs); ask for more vertices")
    for j, q in before.items():
        if j in redone or (now := _worst(meshes[j], plan.anis[j])) >= min(q, FLOOR):
            continue
        redone.add(j)
        try:
            dom = face_domain(part, plan.faces[j], extra, plan.face_name(j))
            # the face given the count that remains is given it again, less the other faces' now
            size = (plan.sizing_of(j, dom, meshes.without(j)) if j == plan.last and plan.target
                    else {"size": plan.h_rest * np.sqrt(plan.k[j])})
            again = last_step(_face_steps(plan, [j], dom, options, [], size)).mesh
        except QmeshError:               # it keeps the points inserted, as it is
            continue
        if _worst(again, plan.anis[j]) > now:
            meshes[j] = again
            remeshed.append(again)
    return remeshed


def _worst(mesh: Mesh, anisotropy: Any) -> float:
    return worst_metric_quality(mesh.points, mesh.triangles, anisotropy)
