"""An evaluator independent of qmesh's own measurements: what every mesh must satisfy against
its input.

`defects(mesh, rings, ...)` returns a list of strings, one per broken invariant, each starting
with a short category ("area: …"), so a test asserts the list is empty and the stress script
counts categories. Everything here is computed from the input rings and the mesh arrays with
NumPy; nothing calls qmesh.measure or the mesher's geometry.

Round-off: coordinates are floats, so a vertex placed on a segment of a domain lying at distance
|c| from the origin can only be there to within about eps·|c|. The tolerances are therefore
`1e-9 × (the domain's size)` plus a few eps × the largest |coordinate|; for a domain at the
origin this is the relative 1e-9 of the brief.
"""

from __future__ import annotations

import math
import resource
import signal
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

import qmesh

if __package__:                 # imported as tests.properties.invariants (tests/fields)
    from . import field_invariants
else:                           # from this folder, on sys.path (the suite, benchmarks/stress.py)
    import field_invariants

EPS = np.finfo(float).eps
REL = 1e-9
MEMORY_CAP = 1 << 30
"""Extra address space one case may take: a mesh of a few thousand vertices that needs more
than 1 GiB breaks "cost follows N"; the cap turns it into a MemoryError (recorded as
a defect) instead of swapping a machine shared by other jobs."""


# --------------------------------------------------------------------------- geometry helpers

def _edges(T: np.ndarray, n: int):
    """Unique undirected edges (k, 2) and how many triangles hold each."""
    pairs = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    key = pairs[:, 0].astype(np.int64) * n + pairs[:, 1]
    u, inverse, count = np.unique(key, return_inverse=True, return_counts=True)
    return np.column_stack([u // n, u % n]), count, inverse


def _ring_area(R: np.ndarray, ref: np.ndarray) -> float:
    """|area| of a ring by the shoelace formula in coordinates relative to ref, summed exactly."""
    x, y = (R - ref).T
    return abs(0.5 * math.fsum(np.concatenate([x * np.roll(y, -1), -y * np.roll(x, -1)])))


def _segments(rings) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start points A (S, 2), end points B (S, 2) and ring index (S,) of every input segment."""
    A = np.concatenate(rings)
    B = np.concatenate([np.roll(R, -1, axis=0) for R in rings])
    ring = np.concatenate([np.full(len(R), k) for k, R in enumerate(rings)])
    return A, B, ring


def _distance_to_segments(X: np.ndarray, A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Distance of every point X (n, 2) to every segment AB: (n, S)."""
    AB = B - A
    L2 = np.einsum("si,si->s", AB, AB)
    AX = X[:, None, :] - A[None]
    t = np.clip(np.einsum("nsi,si->ns", AX, AB) / L2, 0.0, 1.0)
    D = AX - t[..., None] * AB[None]
    return np.hypot(D[..., 0], D[..., 1])


def _inside(X: np.ndarray, A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Even-odd rule over all segments (outline and holes): True strictly inside Ω."""
    y0, y1 = A[None, :, 1], B[None, :, 1]
    crosses = (y0 > X[:, None, 1]) != (y1 > X[:, None, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = A[None, :, 0] + (X[:, None, 1] - y0) * (B[None, :, 0] - A[None, :, 0]) / (y1 - y0)
    return (np.sum(crosses & (X[:, None, 0] < xc), axis=1) % 2) == 1


def _metric_cotangents(P: np.ndarray, T: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """cot of the metric angle at each corner of each triangle, (M, 3), for H = adj Q.

    In x' = Lᵀx (LLᵀ = H): u'·v' = uᵀHv and u'×v' = √det H · (u×v)."""
    H = np.array([[Q[1, 1], -Q[0, 1]], [-Q[1, 0], Q[0, 0]]])
    sq = math.sqrt(H[0, 0] * H[1, 1] - H[0, 1] * H[1, 0])
    X = P[T]
    cot = np.empty(T.shape)
    for c in range(3):
        u, v = X[:, (c + 1) % 3] - X[:, c], X[:, (c + 2) % 3] - X[:, c]
        dot = np.einsum("mi,ij,mj->m", u, H, v)
        cross = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
        cot[:, c] = dot / (sq * cross)
    return cot


# --------------------------------------------------------------------------- the invariants

def defects(mesh, rings, *, Q=None, target=None, n_holes=None, regions=()) -> list[str]:
    """Every broken invariant of `mesh` made for the domain given by `rings` (outline first).

    Q: the constant conductivity (then every interior and boundary q_ij must be ≥ 0);
    target: the requested vertex count (N must land within 10%); regions: a medium's region
    rings, whose points are input points too.
    """
    rings = [np.asarray(R, dtype=float) for R in rings]
    n_holes = len(rings) - 1 if n_holes is None else n_holes
    P = np.asarray(mesh.points, dtype=float)
    T = np.asarray(mesh.triangles, dtype=np.int64)
    fixed = np.asarray(mesh.fixed, dtype=bool)
    out = []
    n = len(P)

    if not np.isfinite(P).all():
        bad = np.flatnonzero(~np.isfinite(P).all(axis=1))
        return [f"finite: {len(bad)} of {n} vertices are not finite (vertex {bad[0]}: {P[bad[0]].tolist()}, "
                f"fixed={bool(fixed[bad[0]])})"]
    if len(T) == 0:
        return ["triangles: the mesh has no triangle"]
    if T.min() < 0 or T.max() >= n:
        return ["indices: triangles refer to vertices that do not exist"]
    rep = (T[:, 0] == T[:, 1]) | (T[:, 1] == T[:, 2]) | (T[:, 0] == T[:, 2])
    if rep.any():
        out.append(f"repeated: {int(rep.sum())} triangles repeat a vertex (first {T[rep][0].tolist()})")
    used = np.zeros(n, bool)
    used[T.ravel()] = True
    if not used.all():
        out.append(f"unused: {int((~used).sum())} vertices are in no triangle")
    if len(np.unique(P, axis=0)) != n:
        out.append(f"duplicates: {n - len(np.unique(P, axis=0))} vertices share their coordinates with another")

    ref = rings[0][0]
    L = P - ref
    scale = max(float(np.abs(np.concatenate(rings)).max()), float(np.abs(P).max()))
    diam = float(np.ptp(np.concatenate(rings), axis=0).max())
    tol = REL * diam + 16 * EPS * scale            # absolute distance tolerance

    X = L[T]
    area = 0.5 * ((X[:, 1, 0] - X[:, 0, 0]) * (X[:, 2, 1] - X[:, 0, 1])
                  - (X[:, 1, 1] - X[:, 0, 1]) * (X[:, 2, 0] - X[:, 0, 0]))
    if not (area > 0).all():
        out.append(f"orientation: {int((area <= 0).sum())} of {len(T)} triangles are not "
                   f"counter-clockwise with positive area (min area {area.min():.3g})")

    E, count, _ = _edges(T, n)
    if np.any(count > 2):
        out.append(f"manifold: {int((count > 2).sum())} edges are shared by more than two triangles")
    euler = n - len(E) + len(T)
    if euler != 1 - n_holes:
        out.append(f"euler: V - E + F = {n} - {len(E)} + {len(T)} = {euler}, expected {1 - n_holes}")

    # every input point kept bit-exactly and flagged fixed
    inputs = np.unique(np.concatenate(rings + [np.asarray(R, dtype=float) for R in regions]), axis=0)
    key_in = np.ascontiguousarray(inputs + 0.0).view(np.dtype((np.void, 16))).ravel()   # -0.0 → 0.0
    key_mesh = np.ascontiguousarray(P + 0.0).view(np.dtype((np.void, 16))).ravel()
    order = np.argsort(key_mesh)
    pos = np.clip(np.searchsorted(key_mesh[order], key_in), 0, n - 1)
    found = key_mesh[order][pos] == key_in
    if not found.all():
        i = int(np.flatnonzero(~found)[0])
        out.append(f"inputs: {int((~found).sum())} of {len(inputs)} input points are not vertices "
                   f"bit-exactly (first {inputs[i].tolist()})")
    elif not fixed[order[pos]].all():
        out.append(f"fixed: {int((~fixed[order[pos]]).sum())} input points are not flagged fixed")
    if fixed.sum() != len(inputs):
        out.append(f"fixed: {int(fixed.sum())} vertices flagged fixed, {len(inputs)} input points")

    # inside Ω (or on its boundary)
    A, B, seg_ring = _segments([R - ref for R in rings])
    dist = _distance_to_segments(L, A, B)
    near = dist.min(axis=1) <= tol
    outside = ~near & ~_inside(L, A, B)
    if outside.any():
        i = int(np.flatnonzero(outside)[0])
        out.append(f"inside: {int(outside.sum())} vertices lie outside the domain (first {P[i].tolist()}, "
                   f"{dist[i].min():.3g} from the boundary)")

    # mesh area = domain area
    want = _ring_area(rings[0], ref) - sum(_ring_area(R, ref) for R in rings[1:])
    perimeter = float(np.hypot(*(B - A).T).sum())
    got = math.fsum(area)
    area_tol = REL * want + 16 * EPS * scale * perimeter
    if not abs(got - want) <= area_tol:
        out.append(f"area: mesh area {got:.17g} differs from the domain's {want:.17g} by "
                   f"{abs(got - want) / want:.3g} (relative; allowed {area_tol / want:.3g})")

    # boundary edges lie on the input segments and cover them
    bnd = E[count == 1]
    if len(bnd):
        d0, d1 = dist[bnd[:, 0]], dist[bnd[:, 1]]
        on_one = ((d0 <= tol) & (d1 <= tol)).any(axis=1)
        if not on_one.all():
            i = int(np.flatnonzero(~on_one)[0])
            out.append(f"boundary: {int((~on_one).sum())} boundary edges do not lie on an input segment "
                       f"(first {P[bnd[i]].tolist()})")
        length = float(np.hypot(*(L[bnd[:, 1]] - L[bnd[:, 0]]).T).sum())
        if not abs(length - perimeter) <= REL * perimeter + 16 * EPS * scale * len(bnd):
            out.append(f"boundary: boundary edges have total length {length:.17g}, the input "
                       f"segments {perimeter:.17g}")

    # q_ij ≥ 0 on every interior and every boundary edge (constant Q)
    if Q is not None and not out:
        cot = _metric_cotangents(L, T, np.asarray(Q, dtype=float))
        _, count, inverse = _edges(T, n)
        # edge (c+1, c+2) of each triangle is opposite corner c: order of _edges' pairs
        opposite = np.concatenate([cot[:, 2], cot[:, 0], cot[:, 1]])
        w = np.bincount(inverse, weights=opposite, minlength=len(count))
        # the output coordinates are rounded to eps·|x|: an angle of a triangle of edge h moves
        # by up to ~eps·|x|/h, which is the weight's own round-off far from the origin
        E = L[T[:, [1, 2, 0]]] - L[T]
        h_min = float(np.hypot(E[..., 0], E[..., 1]).min())
        rounding = 64 * EPS * float(np.abs(P).max()) / max(h_min, 1e-300)
        neg = w < -(REL + rounding) * np.abs(w).max()
        for name, mask in (("interior", count == 2), ("boundary", count == 1)):
            if (neg & mask).any():
                out.append(f"q_ij-{name}: {int((neg & mask).sum())} of {int(mask.sum())} {name} edges have "
                           f"q_ij < 0 (min relative {w[mask].min() / np.abs(w).max():.3g})")

    if target is not None and not abs(n - target) <= 0.1 * target:
        out.append(f"count: N = {n} for target_vertices = {target} (off by {100 * (n - target) / target:+.0f}%)")
    return out


def tag_defects(mesh, domain) -> list[str]:
    """Boundary tags, when the mesh and domain carry them: each boundary edge has the tag of the
    input segment it lies on."""
    if not (hasattr(mesh, "boundary_tags") and hasattr(domain, "segment_tags")):
        return []
    E = np.asarray(mesh.boundary_edges)
    tags = np.asarray(mesh.boundary_tags)
    seeds, seg = np.asarray(domain.seeds), np.asarray(domain.segments)
    P = np.asarray(mesh.points)
    ref = seeds[0]
    A, B = seeds[seg[:, 0]] - ref, seeds[seg[:, 1]] - ref
    mid = 0.5 * (P[E[:, 0]] + P[E[:, 1]]) - ref
    which = _distance_to_segments(mid, A, B).argmin(axis=1)
    wrong = np.asarray(domain.segment_tags)[which] != tags
    if wrong.any():
        return [f"tags: {int(wrong.sum())} of {len(E)} boundary edges do not carry their segment's tag"]
    return []


# --------------------------------------------------------------------------- running one case

@dataclass
class Outcome:
    """What one case gave: the mesh (or None), its defects, seconds, and the error if refused."""

    mesh: object = None
    defects: list = field(default_factory=list)
    seconds: float = 0.0
    error: str | None = None
    warned: list = field(default_factory=list)
    """The QmeshWarnings' texts."""
    corner: tuple | None = None
    """A corner refusal: (the angle qmesh states, the smallest metric angle at that corner
    measured here), degrees."""
    sharpest: float | None = None
    """The smallest corner angle of the domain and its regions in the metric, degrees (None for
    a varying s)."""


def _with_memory_cap(f):
    """Run f() with at most MEMORY_CAP more address space than now (Linux), then restore."""
    try:
        soft, hard = resource.getrlimit(resource.RLIMIT_AS)
        with open("/proc/self/statm") as fh:
            now = int(fh.read().split()[0]) * resource.getpagesize()
    except (OSError, ValueError, AttributeError):
        return f()
    cap = now + MEMORY_CAP
    if hard != resource.RLIM_INFINITY:
        cap = min(cap, hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        return f()
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


ADVICE = ("vertices would follow it", "blunt the corner", "bound or smooth Q")
"""What a refusal of a field or a corner tells the user to change: the vertex count a field
needs, the corner, or a field too strong to follow."""


def says_why(error: qmesh.QmeshError, options: dict) -> bool:
    """A QmeshError on valid input is acceptable only when it explains that the request cannot
    be met: it names the option it cannot honour (target_vertices or size) or says what to
    change (`ADVICE`)."""
    text = str(error)
    return (any(name in text for name in ("target_vertices", "size") if name in options)
            or any(a in text for a in ADVICE))


def refusal_reason(message: str) -> str:
    """A refusal's class, for the stress summary."""
    for words, reason in (("° in the metric", "sharp corner"), ("can follow", "field varies too fast"),
                          ("not integrable", "field not integrable"),
                          ("still failing", "repair: edges still failing"),
                          ("target_vertices", "target too small"), ("size", "size")):
        if words in message:
            return reason
    return "other"


class TooSlow(Exception):
    """A case ran past its time limit."""


def _alarm(signum, frame):
    raise TooSlow


def run(case, time_limit: float | None = None) -> Outcome:
    """Build the case's domain and anisotropy, mesh it, and return the defects found.

    A QmeshError while building a valid domain or anisotropy is a defect; while meshing it is
    one unless it says why the request cannot be met (`says_why`); any other exception, and any
    warning other than a QmeshWarning, is a defect; so is a run past `time_limit` seconds (a
    small mesh that takes minutes; main thread only).
    """
    if time_limit is not None:
        old = signal.signal(signal.SIGALRM, _alarm)
        signal.setitimer(signal.ITIMER_REAL, time_limit)
        try:
            return _run(case, time_limit)
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, old)
    return _run(case, None)


def _run(case, time_limit) -> Outcome:
    res = Outcome()
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            domain = case.domain.build()
        except qmesh.QmeshError as e:
            res.defects.append(f"refused-domain: a valid domain is refused: {e}")
            return res
        try:
            anisotropy = case.conductivity.build()
            res.mesh = _with_memory_cap(lambda: qmesh.mesh(domain, anisotropy, **case.options))
        except qmesh.QmeshError as e:
            res.error = str(e)
            if not says_why(e, case.options):
                res.defects.append(f"error: QmeshError on valid input: {e}")
        except MemoryError:
            res.defects.append(f"memory: more than {MEMORY_CAP >> 20} MiB for N = "
                               f"{case.options.get('target_vertices')}")
        except TooSlow:
            res.defects.append(f"slow: unfinished after {time_limit:g} s for N = "
                               f"{case.options.get('target_vertices')}")
        except Exception as e:       # noqa: BLE001 - any other exception is the defect we record
            res.defects.append(f"exception: {type(e).__name__}: {e}")
    res.seconds = time.perf_counter() - t0
    for w in caught:
        if w.category.__name__ != "QmeshWarning":
            res.defects.append(f"warning: {w.category.__name__}: {w.message} "
                               f"({w.filename.rsplit('/', 1)[-1]}:{w.lineno})")
        else:
            res.warned.append(str(w.message))
    rings = case.domain.rings if case.domain.rings is not None else _rings_of(domain)
    Q_of, Q = case.conductivity.Q_of, case.conductivity.Q
    at = Q_of if Q is None else {0: lambda X: np.broadcast_to(np.asarray(Q, float), (len(X), 2, 2))}
    if at is not None:
        res.sharpest = field_invariants.sharpest_corner(rings, case.domain.regions, at)
        if res.error is not None and field_invariants.refused_corner(res.error):
            _judge_corner(res, rings, case.domain.regions, at)
    if res.mesh is not None:
        target = case.options.get("target_vertices")
        res.defects += defects(res.mesh, rings, Q=Q, target=target if Q_of is None else None,
                               regions=case.domain.regions)
        res.defects += tag_defects(res.mesh, domain)
        if Q_of is not None and not any(category(d) in STRUCTURAL for d in res.defects):
            means = field_invariants.triangle_conductivity(res.mesh, Q_of)
            res.defects += field_invariants.q_defects(res.mesh.points, res.mesh.triangles, means,
                                                      res.mesh.region_tags)
        n = res.mesh.n_vertices
        if Q_of is not None and target is not None and not abs(n - target) <= 0.1 * target \
                and not res.warned:
            res.defects.append(f"count: N = {n} for target_vertices = {target} (off by "
                               f"{100 * (n - target) / target:+.0f}%) with no warning")
    return res


STRUCTURAL = ("finite", "triangles", "indices", "repeated", "orientation", "manifold")
"""Defects after which no q_ij can be computed."""


def _judge_corner(res: Outcome, rings, regions, Q_of: dict) -> None:
    """A corner refusal: the smallest metric angle at that corner, a defect from 0.1° up."""
    x, y, stated = field_invariants.refused_corner(res.error)
    p = field_invariants.nearest_corner((x, y), rings, regions)
    angles = [a for a, _ in field_invariants.corner_angles(p, rings, regions, Q_of)]
    measured = min(angles) if angles else float("nan")
    res.corner = (stated, measured)
    if not measured < field_invariants.CORNER_FLOOR:
        res.defects.append(f"corner-refusal: the corner at {p.tolist()} is {measured:.3g}° in the "
                           f"metric (qmesh says {stated:.3g}°), at least "
                           f"{field_invariants.CORNER_FLOOR}°, and refused: {res.error}")


def _rings_of(domain) -> list[np.ndarray]:
    """The rings of a qmesh domain (a Domain's, or a Polygon's points on today's core)."""
    return list(domain.rings) if hasattr(domain, "rings") else [np.asarray(domain.points)]


def category(defect: str) -> str:
    return defect.split(":", 1)[0]


# --------------------------------------------------------------------------- two meshes alike

def difference(a, b, shift=(0.0, 0.0), scale: float = 1.0) -> str | None:
    """None when mesh b is mesh a scaled by `scale` then moved by `shift` (same N, every vertex
    where it should be within 1e-6 of the domain's size, the same triangles), else what differs.

    Vertices are matched by position, so the two meshes may number them differently."""
    from scipy.spatial import cKDTree

    if a.n_vertices != b.n_vertices:
        return f"N = {a.n_vertices} and {b.n_vertices}"
    Pa = np.asarray(a.points) * scale + np.asarray(shift, dtype=float)
    Pb = np.asarray(b.points)
    size = float(np.ptp(Pb, axis=0).max())
    dist, match = cKDTree(Pb).query(Pa)
    tol = 1e-6 * size + 16 * EPS * float(np.abs(Pb).max())
    if dist.max() > tol or len(np.unique(match)) != len(match):
        return (f"same N = {a.n_vertices}, but {int((dist > tol).sum())} vertices are not where the "
                f"moved mesh has one (max distance {dist.max() / size:.3g} of the size)")
    ta = np.sort(match[np.asarray(a.triangles)], axis=1)
    tb = np.sort(np.asarray(b.triangles), axis=1)
    both = np.concatenate([np.unique(ta, axis=0), np.unique(tb, axis=0)])
    common = len(both) - len(np.unique(both, axis=0))
    if common != len(ta) or len(ta) != len(tb):
        return f"same N = {a.n_vertices}, {common} of {len(ta)} and {len(tb)} triangles in common"
    return None
