"""A tensor field's first triangulation: the boundary's crowding settled by k-d trees before
Qhull (`mesher.crowding_varying`) leaves no point in a diametral ellipse where a brute-force test
of every subsegment against every point finds one, and the conforming rounds then build the
whole triangulation from scratch once instead of once per round."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.mesher import conform, crowding_varying

OUTLINE = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
PLASMA = ("1e-4 + (1 - 1e-4)*(4*(y - 0.5))**2/((2*(x - 0.5))**2 + (4*(y - 0.5))**2)",
          "-(1 - 1e-4)*(2*(x - 0.5))*(4*(y - 0.5))/((2*(x - 0.5))**2 + (4*(y - 0.5))**2)",
          "1e-4 + (1 - 1e-4)*(2*(x - 0.5))**2/((2*(x - 0.5))**2 + (4*(y - 0.5))**2)")


class Turning:
    """A metric without s whose major axis turns with the angle around (0.5, 0.5), det 1."""
    is_constant, potential = False, False

    def __init__(self, ratio):
        self.ratio = ratio

    def hessian(self, X):
        X = np.asarray(X, float)
        t = np.arctan2(X[:, 1] - 0.5, X[:, 0] - 0.5)
        c, s = np.cos(t), np.sin(t)
        a, b = np.sqrt(self.ratio), 1.0 / np.sqrt(self.ratio)
        return np.stack([np.stack([a * c * c + b * s * s, (a - b) * c * s], -1),
                         np.stack([(a - b) * c * s, a * s * s + b * c * c], -1)], -2)


def _start(domain, pieces, n_inner, rng):
    """Seeds, each segment cut into `pieces` equal parts, random interior points: P, edge_id."""
    A, B = domain.segment_ends
    k = np.arange(1, pieces) / pieces
    bpts = (A[:, None, :] + k[None, :, None] * (B - A)[:, None, :]).reshape(-1, 2)
    bseg = np.repeat(np.arange(len(A)), pieces - 1)
    inner = rng.uniform(0.02, 0.98, (n_inner, 2))
    inner = inner[domain.contains(inner, tol=0.0)]
    P = np.concatenate([domain.seeds, bpts, inner])
    edge_id = np.concatenate([np.full(len(domain.seeds), -1), bseg, np.full(len(inner), -1)])
    return P, edge_id.astype(np.int64)


def _subsegments(domain, P, edge_id):
    """Consecutive boundary points along each segment, ordered by their distance from its start."""
    A, B = domain.segment_ends
    s = np.maximum(edge_id, 0)
    t = np.hypot(*(P - A[s]).T) / np.hypot(*(B - A)[s].T)
    return conform._subsegments(domain, len(domain.seeds), edge_id, np.where(edge_id >= 0, t, 0.0))


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), ratio=st.sampled_from([4.0, 100.0, 1e4]),
       pieces=st.integers(2, 12), n_inner=st.integers(0, 400), hole=st.booleans())
def test_no_ellipse_holds_a_point_the_rounds_would_act_on(seed, ratio, pieces, n_inner, hole):
    """Against every subsegment and every point: no interior point on the side of Ω in the
    diametral ellipse (the metric at the midpoint) of a subsegment, short or long; no boundary
    point there that is also in the ellipse measured in its own metric. The seeds stay first and
    unchanged, every boundary point stays, interior points are only dropped, and the points
    split in lie on their segments."""
    holes = [qmesh.Disk(8, radius=0.15, center=(0.5, 0.5))] if hole else []
    domain = qmesh.Domain(OUTLINE, holes)
    A = Turning(ratio)
    P0, e0 = _start(domain, pieces, n_inner, np.random.default_rng(seed))
    h = 1.0 / np.sqrt(max(n_inner, 1))
    P, edge_id, pinned = crowding_varying.split_crowded(domain, P0, e0, A, h, None)
    n_s = len(domain.seeds)
    assert np.array_equal(P[:n_s], domain.seeds)
    bnd0 = P0[(np.arange(len(P0)) < n_s) | (e0 >= 0)]
    bnd = (np.arange(len(P)) < n_s) | (edge_id >= 0)
    assert {tuple(p) for p in bnd0} <= {tuple(p) for p in P[bnd]}
    assert {tuple(p) for p in P[~bnd]} <= {tuple(p) for p in P0[e0 < 0]}
    assert not pinned[:len(bnd0)].any()
    Sa, Sb = domain.segment_ends
    on = edge_id >= 0
    cross = lambda u, v: u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]            # noqa: E731
    E = Sb[edge_id[on]] - Sa[edge_id[on]]
    assert np.all(np.abs(cross(E, P[on] - Sa[edge_id[on]])) <= 1e-12 * np.einsum("ki,ki->k", E, E))
    a, b = _subsegments(domain, P, edge_id)
    k, j = np.meshgrid(np.arange(len(a)), np.arange(len(P)), indexing="ij")
    k, j = k.ravel(), j.ravel()
    left = (j != a[k]) & (j != b[k]) & (cross(P[b[k]] - P[a[k]], P[j] - P[a[k]]) > 0)
    k, j = k[left], j[left]
    inside = conform.encroached(P[a[k]], P[b[k]], P[j], A)
    M, E = 0.5 * (P[a[k]] + P[b[k]]), P[b[k]] - P[a[k]]
    Hj = A.hessian(P[j])
    own = np.einsum("ki,kij,kj->k", P[j] - M, Hj, P[j] - M) < 0.25 * np.einsum("ki,kij,kj->k", E, Hj, E)
    L2 = conform.metric_lengths2(P[a[k]], P[b[k]], A)
    assert not np.any(inside & ~bnd[j])
    assert not np.any(inside & own & bnd[j] & (L2 > conform.SHORTEST ** 2))


def _builds_per_conforming(monkeypatch, domain, field, n):
    """How many times each conforming build of the run's first triangulation triangulated from
    scratch."""
    builds = []
    conforming, first = conform._conforming, conform.first_triangulation

    def counted_conforming(*args, **kwargs):
        builds.append(0)
        return conforming(*args, **kwargs)

    def counted_first(P, *args, **kwargs):
        if builds and len(P) > 50:
            builds[-1] += 1
        return first(P, *args, **kwargs)

    monkeypatch.setattr(conform, "_conforming", counted_conforming)
    monkeypatch.setattr(conform, "first_triangulation", counted_first)
    next(qmesh.iterate(domain, field, target_vertices=n))
    return [b for b in builds if b]


def test_a_turning_field_is_triangulated_from_scratch_once(monkeypatch):
    """Plasma-like, 1 : 1e4 along ellipses around a hole: the rounds built it twice (the
    interior points a subsegment's ellipse holds dropped, then the subsegments boundary points
    encroach split, one Qhull build each). The build again without the interior points the
    splits take the place of (the target) is a second conforming build, itself built once."""
    domain = qmesh.Domain(OUTLINE, [qmesh.Disk(32, radius=0.15, center=(0.5, 0.5))])
    field = qmesh.TensorField.from_expressions(*PLASMA)
    assert _builds_per_conforming(monkeypatch, domain, field, 1000) == [1, 1]
