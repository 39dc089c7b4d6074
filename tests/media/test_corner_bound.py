"""A region's sharp corner bounds the quality any mesh can reach there.

Every triangle of region r at a corner of r has its angle there no larger than the corner's
angle α in r's metric, and a triangle with an angle α has quality (2.94) at most
√3 sin α / (2 − cos α) (the isosceles one). The bound comes from the input polygon alone.
"""

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import qmesh
from qmesh import measure
from qmesh.domain import media_cases
from tests.media.cases import check_mesh, star


def corner_angles(ring, anisotropy) -> np.ndarray:
    """Interior angles (radians) of a simple polygon in the metric adj Q (its scale is irrelevant)."""
    X = np.asarray(ring, float)
    Y = X @ np.linalg.cholesky(np.asarray(anisotropy.H, float))     # |x|_H = |x L|, H = L Lᵀ
    if np.sum(Y[:, 0] * np.roll(Y[:, 1], -1) - np.roll(Y[:, 0], -1) * Y[:, 1]) < 0:
        Y = Y[::-1]                                                  # counter-clockwise
    a, b = np.roll(Y, -1, axis=0) - Y, np.roll(Y, 1, axis=0) - Y      # to the next, to the previous
    return np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], np.sum(a * b, axis=1)) % (2 * np.pi)


def best_quality(alpha: float) -> float:
    """The largest quality (2.94) of a triangle with an angle alpha < 60°."""
    return float(np.sqrt(3) * np.sin(alpha) / (2 - np.cos(alpha)))


def test_the_star_tips_bound_the_inclusion_and_the_mesh_reaches_the_bound():
    domain, cond, _ = media_cases.inclusion()
    alpha = corner_angles(domain.regions[0].rings[0], cond[1]).min()     # the star, region 1
    assert np.degrees(alpha) < 5                                          # 1e3 : 1 thins a tip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(domain, cond, target_vertices=2000)
    check_mesh(domain, cond, m)
    q = measure.quality(m, cond)
    assert q.min() <= best_quality(alpha) * (1 + 1e-9)
    assert q.min() >= 0.98 * best_quality(alpha)         # nothing worse than the geometry forces
    assert q[m.region_tags != 1].min() > best_quality(alpha)


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31), st.floats(0, 3), st.floats(0, 180), st.integers(3, 7))
def test_no_triangle_beats_its_regions_sharpest_corner(seed, log_ratio, angle, n):
    inclusion = star((0.5, 0.5), 0.3, n, np.random.default_rng(seed))
    domain = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=[inclusion])
    cond = {0: qmesh.Anisotropy.principal(10.0, 1.0, 0.0),
            1: qmesh.Anisotropy.principal(10 ** log_ratio, 1.0, angle)}
    alpha = corner_angles(inclusion, cond[1]).min()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(domain, cond, target_vertices=300)
    q = measure.quality(m, cond)[m.region_tags == 1]
    if alpha < np.pi / 3:
        assert q.min() <= best_quality(alpha) * (1 + 1e-9)
    assert q.min() > 0


@pytest.mark.parametrize("alpha", np.radians([1.0, 10.0, 30.0, 59.0]))
def test_the_isosceles_triangle_is_the_best_with_a_given_angle(alpha):
    """best_quality against (2.94) measured on triangles with that angle: legs 1 and t."""
    t = np.linspace(0.2, 5, 97)
    P = np.zeros((3 * len(t), 2))
    P[1::3] = [1.0, 0.0]
    P[2::3] = t[:, None] * [np.cos(alpha), np.sin(alpha)]
    mesh = qmesh.Mesh(P, np.arange(3 * len(t)).reshape(-1, 3))
    q = measure.quality(mesh, qmesh.Anisotropy.constant(np.eye(2)))
    assert q.max() == pytest.approx(best_quality(alpha), rel=1e-12)
    assert q[np.argmin(abs(t - 1))] == q.max()


@pytest.mark.parametrize("n", [2000, 8000])
def test_the_last_face_leaves_the_finished_faces_interfaces_whole(n):
    """FVCA5 test 7's barrier is meshed first; at 8000 its interface pieces are exactly the
    count's h long, which the last face's own count sized a hair finer and split every one of
    them in two, handed back to the barrier (flips only: its triangles fell to 0.56). The
    barrier's vertices when it is done are all it has at the end."""
    domain, cond, _ = media_cases.fvca7()
    band = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        for step in qmesh.iterate(domain, cond, target_vertices=n):
            tags = step.mesh.region_tags
            if (tags == 1).all():                   # the barrier alone: its run's steps
                band = np.unique(step.mesh.triangles)
    m = step.mesh
    check_mesh(domain, cond, m)
    assert len(np.unique(m.triangles[m.region_tags == 1])) == len(band) > 0
    assert abs(m.n_vertices - n) <= 0.01 * n


@pytest.mark.parametrize("shorter", [0.002, 0.009])
def test_a_face_sized_a_hair_under_its_shared_pieces_keeps_them_whole(shorter):
    """The barrier's interface pieces against an h just under their length: the face mesher
    at that h would split every one in two; `sizing_of` sizes it at the pieces' length, where
    it adds no point on them. Well under (a tenth), the h stays: those pieces are too long."""
    from qmesh.domain.faces import face_domain
    from qmesh.media.plan import MediaPlan
    from qmesh.mesher import loop, sizing

    domain, cond, _ = media_cases.fvca7()
    plan = MediaPlan(domain, cond, 8000, None)
    i = plan.order[0]
    dom = face_domain(plan.part, plan.faces[i], plan.extra, plan.face_name(i))
    inter = plan.part.interface[dom.segment_tags - 1]
    cut = sizing.metric_edge_lengths(dom, plan.anis[i], plan.k[i])[inter].max()

    def added_on_interfaces(size):
        m = loop.mesh(dom, plan.anis[i], size=size)
        b = m.boundary_edges[np.isin(m.boundary_tags - 1, np.flatnonzero(plan.part.interface))]
        return int((np.unique(b) >= len(dom.seeds)).sum())

    plan.h_rest = cut * (1 - shorter)
    assert added_on_interfaces(plan.h_rest * np.sqrt(plan.k[i])) >= inter.sum()   # each split
    size = plan.sizing_of(i, dom, {})["size"]
    assert size >= cut * np.sqrt(plan.k[i])
    assert added_on_interfaces(size) == 0
    plan.h_rest = cut * 0.9
    assert plan.sizing_of(i, dom, {})["size"] == pytest.approx(plan.h_rest * np.sqrt(plan.k[i]))
