"""The splits a part thin in the metric needs before its first Qhull build (conform._split_crowded),
and the rounds of `restore_conformity` that test only what the last round changed.

Across a strip thin in its metric each split encroaches the opposite side's subsegments in turn;
these splits are made with a k-d tree before Qhull runs, so the initial conforming
triangulation takes one build where it took one per step. Checked here: the boundary points
are those the build-by-build rounds reach (the rounds alone, with the pre-pass switched off, are
the reference), no vertex lies in a boundary edge's diametral ellipse (written out from
GEOMETRY.md §1), and the builds stay few.
"""

from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh import measure
from qmesh.mesher import conform


def _first_step(domain, anisotropy, n, presplit=True):
    """The first Step (the initial conforming triangulation) and the Qhull builds it took."""
    builds = [0]
    build = conform.first_triangulation

    def counted(*a, **k):
        builds[0] += 1
        return build(*a, **k)
    off = {} if presplit else {"_split_crowded": lambda *a, **k: None}
    with mock.patch.multiple(conform, first_triangulation=counted, **off):
        step = next(iter(qmesh.iterate(domain, anisotropy, target_vertices=n)))
    return step, builds[0]


def _in_ellipses(mesh, H):
    """Boundary edges whose diametral ellipse in H holds a vertex: (p−m)ᵀH(p−m) < ¼(b−a)ᵀH(b−a)."""
    P, E = mesh.points, mesh.boundary_edges
    a, b = P[E[:, 0]], P[E[:, 1]]
    m, d = 0.5 * (a + b), b - a
    r2 = 0.25 * np.einsum("ki,ij,kj->k", d, H, d)
    D = P[None, :, :] - m[:, None, :]
    inside = np.einsum("kpi,ij,kpj->kp", D, H, D) < r2[:, None] * (1 - 1e-6)
    return int(inside.sum())


@pytest.mark.slow(30)
@settings(max_examples=6, deadline=None)
@given(width=st.floats(0.002, 0.02), angle=st.floats(10, 80), ratio=st.floats(100, 1000),
       n=st.integers(800, 2500))
def test_thin_strips_conform_in_few_builds_at_the_rounds_own_points(width, angle, ratio, n):
    strip = qmesh.Polygon([(0, 0), (1, 0), (1, width), (0, width)])
    A = qmesh.Anisotropy.principal(1, ratio, angle)
    try:
        ref, ref_builds = _first_step(strip, A, n, presplit=False)
    except qmesh.QmeshError as e:             # too few vertices for the strip: refused alike
        with pytest.raises(qmesh.QmeshError) as again:
            _first_step(strip, A, n)
        assert str(again.value).split(":")[0] == str(e).split(":")[0]
        return
    step, builds = _first_step(strip, A, n)
    m, r = step.mesh, ref.mesh
    assert builds <= min(ref_builds, 4)
    on = np.unique(m.boundary_edges)
    on_ref = np.unique(r.boundary_edges)
    assert np.array_equal(np.unique(m.points[on], axis=0), np.unique(r.points[on_ref], axis=0))
    assert _in_ellipses(m, A.H) == 0
    assert measure.q_nonnegative_fraction(m, A) == 1.0


@pytest.mark.slow(17)
def test_the_rotated_strip_needs_one_build_where_the_rounds_took_many():
    strip = qmesh.Polygon([(0, 0), (1, 0), (1, 0.005), (0, 0.005)])
    A = qmesh.Anisotropy.principal(1, 1000, 45)
    _, builds = _first_step(strip, A, 3000)
    _, ref_builds = _first_step(strip, A, 3000, presplit=False)
    assert ref_builds > 3 and builds <= 2


def _star(tips: int, depth: float) -> qmesh.Polygon:
    t = np.pi * np.arange(2 * tips) / tips
    r = np.where(np.arange(2 * tips) % 2 == 0, 1.0, depth)
    return qmesh.Polygon(np.column_stack([r * np.cos(t), r * np.sin(t)]))


@pytest.mark.slow(20)
@settings(max_examples=6, deadline=None)
@given(name=st.sampled_from(["L-shape", "notched square", "plate with holes", "star"]),
       angle=st.floats(0, 180), ratio=st.floats(10, 1000), n=st.integers(600, 1500))
def test_non_convex_domains_split_only_for_points_on_their_own_side(name, angle, ratio, n):
    """A point across a notch or a tip (outside Ω) lies in a subsegment's ellipse on the far
    side; the rounds never test it, and neither does the pre-pass (the same boundary points)."""
    from qmesh import domains
    domain = _star(5, 0.3) if name == "star" else domains.NAMED[name]()
    A = qmesh.Anisotropy.principal(1, ratio, angle)
    try:
        ref, _ = _first_step(domain, A, n, presplit=False)
    except qmesh.QmeshError:
        return
    step, _ = _first_step(domain, A, n)
    m, r = step.mesh, ref.mesh
    assert np.array_equal(np.unique(m.points[np.unique(m.boundary_edges)], axis=0),
                          np.unique(r.points[np.unique(r.boundary_edges)], axis=0))
    assert measure.q_nonnegative_fraction(m, A) == 1.0


@pytest.mark.slow(15)
@settings(max_examples=5, deadline=None)
@given(width=st.floats(0.003, 0.05), angle=st.floats(0, 90), ratio=st.floats(10, 1000),
       n=st.integers(800, 3000))
def test_restoring_conformity_on_what_changed_finds_what_a_full_scan_finds(width, angle, ratio, n):
    """`restore_conformity` tests only the half-edges a round changed or left encroached
    (`_changed`); with every boundary half-edge tested each round the mesh is the same."""
    strip = qmesh.Polygon([(0, 0), (1, 0), (1, width), (0, width)])
    A = qmesh.Anisotropy.principal(1, ratio, angle)
    try:
        m = qmesh.mesh(strip, A, target_vertices=n)
    except qmesh.QmeshError as e:
        with mock.patch.object(conform, "_changed", lambda *a: None), pytest.raises(qmesh.QmeshError) as again:
            qmesh.mesh(strip, A, target_vertices=n)
        assert str(again.value) == str(e)
        return
    with mock.patch.object(conform, "_changed", lambda *a: None):
        full = qmesh.mesh(strip, A, target_vertices=n)
    assert np.array_equal(m.points, full.points) and np.array_equal(m.triangles, full.triangles)


def _all_against_all(X, a, b, first, n_old, anisotropy, P):
    """The pre-pass's later rounds as its first: every subsegment against every boundary point."""
    from scipy.spatial import cKDTree
    bnd = np.concatenate([first[0], np.arange(first[2], len(X))])
    k, _ = conform._in_ellipses(X, a, b, cKDTree(X[bnd]), bnd, anisotropy, P)
    return k


@pytest.mark.slow(15)
@settings(max_examples=6, deadline=None)
@given(name=st.sampled_from(["strip", "L-shape", "star"]), width=st.floats(0.002, 0.02),
       angle=st.floats(0, 90), ratio=st.floats(10, 1000), n=st.integers(800, 3000))
def test_pre_pass_rounds_on_what_was_split_in_find_what_a_full_scan_finds(name, width, angle,
                                                                          ratio, n):
    """After its first round the pre-pass tests the subsegments that stood against the points
    the last round split in, and the new subsegments against every boundary point
    (`_in_ellipses_since`); testing every subsegment against every boundary point in each
    round gives the same first triangulation, bit for bit."""
    from qmesh import domains
    domain = {"strip": qmesh.Polygon([(0, 0), (1, 0), (1, width), (0, width)]),
              "star": _star(5, 0.3)}.get(name) or domains.NAMED[name]()
    A = qmesh.Anisotropy.principal(1, ratio, angle)
    try:
        step, _ = _first_step(domain, A, n)
    except qmesh.QmeshError as e:
        with mock.patch.object(conform, "_in_ellipses_since", _all_against_all), \
                pytest.raises(qmesh.QmeshError) as again:
            _first_step(domain, A, n)
        assert str(again.value) == str(e)
        return
    with mock.patch.object(conform, "_in_ellipses_since", _all_against_all):
        full, _ = _first_step(domain, A, n)
    m, r = step.mesh, full.mesh
    assert np.array_equal(m.points, r.points) and np.array_equal(m.triangles, r.triangles)
    assert measure.q_nonnegative_fraction(m, A) in (1.0, None)
