"""Conforming Q-Delaunay on domains with holes (GEOMETRY.md §1).

The encroachment test is checked against the diametral ellipse written out by hand and against
the q_ij of the boundary edge it protects; meshes of non-convex and holed domains are checked
for the invariants the issue lists, on named shapes and on random ones (hypothesis).
"""

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import qmesh
from qmesh import domains, measure
from qmesh.mesher import conform
from qmesh.geometry.triangles import signed_areas

from cases import exp_plus_y2


# --------------------------------------------------------------------------- the test itself

@settings(max_examples=60, deadline=None)
@given(k1=st.floats(-2, 2), ratio=st.floats(0, 3), angle=st.floats(0, 180),
       ab=st.lists(st.floats(-1, 1), min_size=4, max_size=4), p=st.lists(st.floats(-2, 2), min_size=2, max_size=2))
def test_encroachment_is_the_diametral_ellipse_for_constant_q(k1, ratio, angle, ab, p):
    """(p − m)ᵀH(p − m) < ¼(b − a)ᵀH(b − a), written from GEOMETRY.md §1 (not from the code)."""
    A = qmesh.Anisotropy.principal(10 ** k1, 10 ** (k1 + ratio), angle)
    a, b, c = np.array([ab[:2]]), np.array([ab[2:]]), np.array([p])
    if np.hypot(*(b - a)[0]) < 1e-3:
        return
    H = A.H
    m = 0.5 * (a + b)
    lhs = float(((c - m) @ H @ (c - m).T)[0, 0])
    rhs = 0.25 * float(((b - a) @ H @ (b - a).T)[0, 0])
    if abs(lhs - rhs) < 1e-6 * rhs:
        return                                            # too close to the ellipse to call
    assert conform.encroached(a, b, c, A)[0] == (lhs < rhs)


def test_encroachment_decides_the_sign_of_the_boundary_weight():
    """A boundary edge's q_ij is ½ cot of the metric angle facing it: ≥ 0 exactly when the apex
    is outside the diametral ellipse (GEOMETRY.md §1, 'Boundary edges get q_ij ≥ 0 too')."""
    A = qmesh.Anisotropy.principal(1.0, 30.0, 25.0)
    rng = np.random.default_rng(1)
    for _ in range(200):
        P = rng.uniform(-1, 1, (3, 2))
        if signed_areas(P, np.array([[0, 1, 2]]))[0] <= 1e-3:
            continue
        m = qmesh.Mesh(P, [[0, 1, 2]])
        edges, q, _ = measure.edge_weights(m, A)
        k = int(np.flatnonzero((edges == [0, 1]).all(axis=1))[0])
        enc = conform.encroached(P[:1], P[1:2], P[2:], A)[0]
        if abs(q[k]) > 1e-9 * np.abs(q).max():
            assert enc == (q[k] < 0)


def test_varying_s_test_is_the_plane_below_which_the_apex_lies():
    """For s = exp(x) + y² the lifted test says: c below the plane through the lifted a and b
    whose slope across ab is ∇s(m)·n (written here from GEOMETRY.md §1)."""
    A = exp_plus_y2()
    rng = np.random.default_rng(2)
    a, b, c = rng.uniform(-1, 1, (3, 300, 2))
    m = 0.5 * (a + b)
    t = (b - a) / np.linalg.norm(b - a, axis=1)[:, None]
    n = np.column_stack([-t[:, 1], t[:, 0]])
    s = lambda X: np.exp(X[:, 0]) + X[:, 1] ** 2                           # noqa: E731
    g = ((s(b) - s(a)) / np.linalg.norm(b - a, axis=1))[:, None] * t \
        + np.einsum("ki,ki->k", A.grad(m), n)[:, None] * n
    below = s(c) - s(a) - np.einsum("ki,ki->k", g, c - a)
    clear = np.abs(below) > 1e-6
    np.testing.assert_array_equal(conform.encroached(a, b, c, A)[clear], below[clear] < 0)


def test_shell_splits_next_to_an_input_point_are_powers_of_two():
    """Concentric shells: a subsegment with one input end is split at a power-of-two metric
    distance from it, so two segments sharing that corner are split at matching radii."""
    A = qmesh.Anisotropy.constant(np.eye(2))
    a = np.zeros((5, 2))
    b = np.column_stack([[0.3, 0.7, 1.0, 3.0, 5.5], np.zeros(5)])
    p = conform.split_points(a, b, np.ones(5, bool), np.zeros(5, bool), A)
    r = np.log2(p[:, 0])
    np.testing.assert_allclose(r, np.round(r), atol=1e-12)
    assert np.all((p[:, 0] > 0.25 * b[:, 0]) & (p[:, 0] < 0.75 * b[:, 0]))
    mid = conform.split_points(a, b, np.zeros(5, bool), np.zeros(5, bool), A)
    np.testing.assert_allclose(mid, 0.5 * b)


# --------------------------------------------------------------------------- meshes of Ω

def check_mesh(D, A, m, constant=True):
    """The invariants of a domain with holes on one mesh; returns nothing, asserts everything."""
    P, T = m.points, m.triangles
    assert np.isfinite(P).all()
    area = signed_areas(P, T)
    assert area.min() > 0
    assert area.sum() == pytest.approx(D.area, rel=1e-9)
    index = {p: i for i, p in enumerate(map(tuple, P.tolist()))}
    seeds = [index.get(p, -1) for p in map(tuple, D.seeds.tolist())]
    assert min(seeds) >= 0, "an input point is missing or moved"
    assert m.fixed[seeds].all() and m.fixed.sum() == len(D.seeds)
    assert D.contains(P, tol=1e-9).all()
    assert D.contains(P[T].mean(axis=1), tol=0).all(), "a triangle outside Ω"
    edges, q, interior = measure.edge_weights(m, A)
    assert m.n_vertices - len(edges) + m.n_triangles == 1 - len(D.holes)        # Euler
    # boundary edges lie on the input segments, with the segment's tag
    seg = D.edge_of(0.5 * (P[m.boundary_edges[:, 0]] + P[m.boundary_edges[:, 1]]), tol=1e-9)
    assert np.all(seg >= 0)
    np.testing.assert_array_equal(m.boundary_tags, D.segment_tags[seg])
    assert len(m.boundary_edges) == int((~interior).sum())
    if constant:
        rel = q / np.abs(q).max()
        tol = 1e-9 + coordinate_precision(P, edges)
        assert rel[interior].min() >= -tol and rel[~interior].min() >= -tol


def coordinate_precision(P, edges) -> float:
    """What the stored coordinates alone can move a q_ij by, relative to the largest: the mesher
    decides in its normalised frame, and a point mapped back far from the origin is rounded by
    half an ulp there, which tilts an edge's angles by about ulp / edge length (a q_ij that is 0
    in the mesher's frame, four points on one ellipse, then reads about −1e-9 at 5e5 sizes
    from the origin: the README's limit on far-away domains)."""
    shortest = np.hypot(*(P[edges[:, 0]] - P[edges[:, 1]]).T).min()
    return 10.0 * float(np.spacing(np.abs(P).max())) / float(shortest)


CHAPTER = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)

FAR_20GON = [(-628033618.6561793, -3.7846282118862054e-05), (-628033667.9700164, 125.82171584961382),
             (-628033731.0542207, 378.13434340906934), (-628033995.0587281, 399.326300269783),
             (-628034076.5397655, 632.8443720539814), (-628034224.6651572, 648.8308550593498),
             (-628034385.6707753, 448.24532321508786), (-628034647.2384335, 503.2308338171274),
             (-628034649.9960337, 279.39012690355787), (-628034792.67332, 176.97690165207098),
             (-628034842.0071036, -21.392682988604403), (-628034607.8784503, -124.51358463447372),
             (-628034671.1658456, -246.0582338044841), (-628034538.333489, -431.727458631043),
             (-628034492.1609607, -614.3323196388601), (-628034286.1226298, -522.7755848678822),
             (-628034053.0367248, -528.2181060984495), (-628033886.727237, -429.7820000490722),
             (-628033868.6541914, -240.80204683377522), (-628033766.7906288, -207.11095148205442)]


def test_a_domain_far_from_the_origin_keeps_q_to_its_coordinates_precision():
    """A 20-gon 1e3 wide at 6e8 from the origin (drawn by the random test below): four points on
    one ellipse give an edge whose q_ij is 0 in the mesher's frame and −1.75e-9 of the largest in
    the stored coordinates, within what their rounding allows."""
    D = qmesh.Domain(FAR_20GON)
    A = qmesh.Anisotropy.constant(np.diag([64.91730213001026, 22655.871627119046]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(D, A, target_vertices=88)
    check_mesh(D, A, m)
    edges, q, _ = measure.edge_weights(m, A)
    assert coordinate_precision(m.points, edges) > 1e-9          # the coordinates' rounding rules
ROTATED = qmesh.Anisotropy.principal(1.0, 60.0, 35.0)


@pytest.mark.parametrize("name", ["L-shape", "square with hole", "annulus", "plate with holes",
                                  "notched square"])
@pytest.mark.parametrize("A", [CHAPTER, ROTATED], ids=["chapter", "rotated"])
def test_named_domains_mesh_with_every_q_ij_nonnegative(name, A):
    D = domains.NAMED[name]()
    m = qmesh.mesh(D, A, target_vertices=600)
    check_mesh(D, A, m)
    assert abs(m.n_vertices - 600) <= 0.1 * 600
    assert set(np.unique(m.boundary_tags)) == set(np.unique(D.segment_tags))


def test_after_every_triangulate_stage_no_subsegment_is_encroached():
    D = domains.square_with_hole()
    for step in qmesh.iterate(D, ROTATED, target_vertices=500):
        if step.stage != "triangulate":
            continue
        m = step.mesh
        a, b = m.boundary_edges.T
        third = _apex(m.triangles, a, b)
        assert not conform.encroached(m.points[a], m.points[b], m.points[third], ROTATED).any()


@pytest.mark.parametrize("name", ["square with hole", "plate with holes", "annulus"])
def test_the_first_triangulation_carries_its_twins_through_the_canonical_order(name):
    """The conforming build's twins are renumbered with its triangles, not found again by a
    sort: they must be what a sort finds, on holed domains (edges to removed triangles become
    boundary edges), below and past the closed-form lattice's size."""
    from qmesh.geometry import topology
    from qmesh.mesher.options import Options
    from qmesh.mesher.plan import plan
    from qmesh.mesher.stages import initial_triangulation
    for target in (600, 8000):
        p = plan(domains.NAMED[name](), ROTATED, Options.checked(target_vertices=target))
        _, st, _ = initial_triangulation(p, np.random.default_rng(0))
        np.testing.assert_array_equal(st.twin, topology.twins(st.T))


@pytest.mark.parametrize("offset", [0, 3_000_000], ids=["one key", "lexsort"])
def test_canonical_order_is_the_sorted_rotated_triangles_with_their_twins(delaunay_mesh, offset):
    """Both ways of sorting (one int64 key per triangle below 2.09e6 vertices, lexsort above)
    give the rows rotated to their smallest vertex in lexicographic order, and the twins a sort
    of the new half-edges finds; triangles left out turn their neighbours' edges to boundary."""
    from qmesh.geometry import topology
    T = np.asarray(delaunay_mesh.triangles)[::-1] + offset
    T = np.roll(T, 1, axis=1)
    twin = topology.twins(T)
    rows = np.arange(0, len(T), 2) if offset else np.arange(len(T))
    got, got_twin = conform._canonical_order(T, twin, rows)
    want = sorted(tuple(np.roll(t, -int(np.argmin(t)))) for t in T[rows].tolist())
    assert [tuple(t) for t in got.tolist()] == want
    np.testing.assert_array_equal(got_twin, topology.twins(got))


def _apex(T, a, b):
    """The vertex opposite each directed edge a→b in its triangle."""
    lookup = {}
    for t in T.tolist():
        for k in range(3):
            lookup[(t[k], t[(k + 1) % 3])] = t[(k + 2) % 3]
    return np.array([lookup[(i, j)] for i, j in zip(a.tolist(), b.tolist())])


def test_varying_s_on_a_holed_domain():
    """q_ij ≥ 0 holds for s_h, not for the continuous Q: check validity and tags only."""
    D = domains.annulus()
    A = exp_plus_y2()
    m = qmesh.mesh(D, A, target_vertices=500)
    check_mesh(D, A, m, constant=False)


def test_small_metric_angles_do_not_run_away():
    """Disk(8) under a 100:1 anisotropy has corners of ~27° in the metric; the shells settle."""
    A = qmesh.Anisotropy.principal(1.0, 100.0, 0.0)
    m = qmesh.mesh(qmesh.Disk(8), A, target_vertices=60)
    check_mesh(qmesh.Disk(8), A, m)
    assert m.n_vertices <= 66


def test_a_domain_thinner_than_an_element_is_refused_quickly():
    """A 1000:1 triangle under a 100:1 metric cannot keep q_ij ≥ 0 with 2000 vertices: its
    corners of 0.005° in the metric, split at matching distances, leave the refusal the count
    the boundary needs (they stopped the run past a cap before)."""
    R = np.array([[np.cos(0.5236), np.sin(0.5236)], [-np.sin(0.5236), np.cos(0.5236)]])
    D = qmesh.Polygon(np.array([[0, 0], [1000, 0], [500, 1]]) @ R)
    with pytest.raises(qmesh.QmeshError, match=r"is too few: keeping every q_ij >= 0 on the "
                                               r"boundary needs \d+ vertices"):
        qmesh.mesh(D, qmesh.Anisotropy.principal(1, 1e4, 90), target_vertices=2000,
                   boundary_refinement=False)


# --------------------------------------------------------------------------- random domains

def _star(draw, n, r0, r1, c):
    """n points at increasing angles (evenly spread, jittered by up to 40% of the gap) and random
    radii: a simple polygon, star-shaped about c, non-convex in general."""
    jitter = np.array(draw(st.lists(st.floats(-0.4, 0.4), min_size=n, max_size=n)))
    t = 2 * np.pi * (np.arange(n) + jitter) / n
    r = np.array(draw(st.lists(st.floats(r0, r1), min_size=n, max_size=n)))
    return np.asarray(c) + np.column_stack([r * np.cos(t), r * np.sin(t)])


@st.composite
def holed_domains(draw):
    """Star-shaped outlines (non-convex) with up to three star-shaped holes, moved and scaled."""
    outer = _star(draw, draw(st.integers(3, 20)), 0.6, 1.0, (0, 0))
    holes = []
    for _ in range(draw(st.integers(0, 3))):
        c = draw(st.tuples(st.floats(-0.35, 0.35), st.floats(-0.35, 0.35)))
        r = draw(st.floats(0.04, 0.15))
        h = _star(draw, draw(st.integers(3, 10)), 0.5 * r, r, c)
        try:
            qmesh.Domain(outer, holes + [h])
        except qmesh.QmeshError:
            continue
        holes.append(h)
    scale = 10.0 ** draw(st.floats(-6, 6))
    shift = np.array(draw(st.tuples(st.floats(-1e6, 1e6), st.floats(-1e6, 1e6)))) * scale
    return qmesh.Domain(outer * scale + shift, [h * scale + shift for h in holes])


@settings(max_examples=40, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(D=holed_domains(), k1=st.floats(-2, 2), ratio=st.floats(0, 3), angle=st.floats(0, 180),
       extra=st.integers(30, 1500))
def test_random_holed_domains_keep_every_invariant(D, k1, ratio, angle, extra):
    A = qmesh.Anisotropy.principal(10 ** k1, 10 ** (k1 + ratio), angle)
    n = len(D.seeds) + extra
    try:
        m = qmesh.mesh(D, A, target_vertices=n)
    except qmesh.QmeshError as e:          # allowed only with a reason that names the count
        assert "target_vertices" in str(e) or "vertices here" in str(e)
        return
    check_mesh(D, A, m)
    assert abs(m.n_vertices - n) <= 0.1 * n
