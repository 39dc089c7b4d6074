"""qmesh_view.scene: the meshes of the three views hold what the Step says, counted independently."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull

import qmesh
from qmesh import measure
from qmesh.errors import QmeshError
from qmesh_view import scene


def _triangle_set(T):
    return {tuple(sorted(t)) for t in np.asarray(T).tolist()}


def _faces(poly):
    return poly.faces.reshape(-1, 4)[:, 1:]


def test_lifted_has_one_facet_per_triangle_and_every_vertex(steps, chapter_run):
    for step in steps.values():
        view = scene.lifted(step, chapter_run.anisotropy, domain=chapter_run.domain)
        assert view.facets.n_cells == step.mesh.n_triangles
        assert view.vertices.n_points == step.mesh.n_vertices
        assert _triangle_set(_faces(view.facets)) == _triangle_set(step.mesh.triangles)
        np.testing.assert_allclose(view.vertices.points[:, :2], step.mesh.points)
        np.testing.assert_allclose(view.facets.points[:, 2], view.vertices.points[:, 2])


def test_lifted_facets_are_the_lower_hull_after_triangulate(steps, chapter_run):
    """After a triangulate stage the drawn facets form the lower convex hull (2.74): no lifted
    vertex lies below the plane of any facet (up to round-off, so co-planar ties may go either way)."""
    for name in ("triangulate0", "final"):
        view = scene.lifted(steps[name], chapter_run.anisotropy, domain=chapter_run.domain)
        X = view.vertices.points
        F = _faces(view.facets)
        a, b, c = X[F[:, 0]], X[F[:, 1]], X[F[:, 2]]
        n = np.cross(b - a, c - a)                                  # (M, 3), n_z ≠ 0
        assert np.all(np.abs(n[:, 2]) > 0)
        # height of every vertex above every facet's plane, along z
        above = ((X[None, :, :] - a[:, None, :]) @ (n / n[:, 2:3])[:, :, None])[..., 0]
        scale = np.ptp(X[:, 2])
        assert above.min() > -1e-9 * scale, name
        # and the facets tile the same area as the lower hull Qhull finds
        hull = ConvexHull(X)
        lower = hull.simplices[hull.equations[:, 2] < -1e-12]
        assert len(lower) == len(F), name


def test_lifted_surface_lies_under_the_facets_and_scales(steps, chapter_run):
    step, A = steps["final"], chapter_run.anisotropy
    one = scene.lifted(step, A, 1.0, domain=chapter_run.domain)
    two = scene.lifted(step, A, 2.0, domain=chapter_run.domain)
    np.testing.assert_allclose(two.facets.points[:, 2], 2 * one.facets.points[:, 2])
    # s is convex, so s ≤ s_h: sample the surface's points and compare with s_h there
    S = one.surface.points
    assert np.all(qmesh.Disk(64).contains(S[:, :2], tol=1e-9))
    probe = one.facets.copy()
    probe.points[:, 2] = 0.0
    found = probe.find_containing_cell(np.column_stack([S[:, :2], np.zeros(len(S))]))
    inside = found >= 0
    assert inside.mean() > 0.95
    tri = _faces(one.facets)[found[inside]]
    P = one.facets.points
    a, b, c = P[tri[:, 0]], P[tri[:, 1]], P[tri[:, 2]]
    x = S[inside]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    l1 = ((x[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (x[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])) / det
    l2 = ((b[:, 0] - a[:, 0]) * (x[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (x[:, 0] - a[:, 0])) / det
    s_h = (1 - l1 - l2) * a[:, 2] + l1 * b[:, 2] + l2 * c[:, 2]
    assert np.all(x[:, 2] <= s_h + 1e-9)


def test_lifted_surface_is_the_same_at_every_stage():
    """s(x) is drawn to its own range: the picture of it does not move as vertices come and go
    (at 1e5 vertices it is all the lifted view shows), here with s's minimum between the
    surface's samples, where vertices come nearer to it at every stage."""
    A = qmesh.Anisotropy.from_expression("2*(y - 0.017)**2 + (x - 0.017)**2")
    domain = qmesh.Disk(32)
    steps = list(qmesh.iterate(domain, A, target_vertices=1000, seed=0))
    first, *rest = [scene.lifted(step, A, domain=domain).surface.points for step in steps]
    assert len(rest) >= 4
    for points in rest:
        np.testing.assert_array_equal(points, first)


def test_lifted_rejects_bad_z_scale(steps, chapter_run):
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(QmeshError):
            scene.lifted(steps["final"], chapter_run.anisotropy, bad)


def test_projected_marks_fixed_seeds(steps):
    step = steps["final"]
    view = scene.projected(step)
    assert view.mesh.n_cells == step.mesh.n_triangles
    assert view.fixed.n_points == int(step.mesh.fixed.sum()) == 64
    np.testing.assert_allclose(view.fixed.points[:, :2], qmesh.Disk(64).seeds, atol=1e-12)


def test_projected_highlights_inserted_points(steps):
    step = steps["insert1"]
    assert step.added is not None and len(step.added) > 0
    view = scene.projected(step)
    assert view.n_added == view.added.n_points == len(step.added)
    np.testing.assert_allclose(view.added.points[:, :2], step.mesh.points[step.added])
    assert view.arrows.n_points == 0


def test_projected_draws_a_move_arrow_per_moved_vertex(steps):
    step = steps["adjust1"]
    D = np.asarray(step.moved)
    moved = np.hypot(D[:, 0], D[:, 1]) > 0
    view = scene.projected(step)
    assert view.n_moved == moved.sum() > 0
    assert view.arrows.n_cells == 3 * moved.sum()           # shaft + two head strokes each
    assert view.added.n_points == 0
    # shafts run from the old position to the new one
    k = int(moved.sum())
    np.testing.assert_allclose(view.arrows.points[:k, :2], (step.mesh.points - D)[moved])
    np.testing.assert_allclose(view.arrows.points[k:2 * k, :2], step.mesh.points[moved])


def test_triangulate_step_has_no_arrows_or_added_points(steps):
    view = scene.projected(steps["triangulate0"])
    assert view.arrows.n_points == 0 and view.added.n_points == 0


def test_quality_is_the_metric_quality_in_0_1(steps, chapter_run):
    A = chapter_run.anisotropy
    for name in ("triangulate0", "final"):
        step = steps[name]
        view = scene.quality(step, A)
        q = view.triangles.cell_data["quality"]
        assert len(q) == step.mesh.n_triangles
        assert np.all(q > 0) and np.all(q <= 1 + 1e-12)
        np.testing.assert_allclose(q, measure.quality(step.mesh, A))
        assert view.edges is None


def test_quality_metric_area_sums_to_the_metric_area_of_the_domain(steps, chapter_run):
    """det ∇²s = 0.1 · 10 = 1 for the chapter's Q, so the metric areas add up to |Ω|."""
    view = scene.quality(steps["final"], chapter_run.anisotropy, colour_by="metric_area")
    a = view.triangles.cell_data["metric_area"]
    assert view.scalars == "metric_area"
    assert np.all(a > 0)
    assert a.sum() == pytest.approx(qmesh.Disk(64).area, rel=1e-12)


def test_q_sign_edges_cover_every_edge_and_count_negative_weights(steps, chapter_run):
    A = chapter_run.anisotropy
    for name in ("final", "adjust1"):
        step = steps[name]
        view = scene.quality(step, A, q_sign_edges=True)
        m = step.mesh
        assert view.edges.n_cells == m.n_vertices + m.n_triangles - 1        # Euler, a disk
        sign = view.edges.cell_data["q_sign"]
        assert np.sum(sign == 0) == len(m.boundary_edges)
        interior = np.sum(sign != 0)
        frac = measure.q_nonnegative_fraction(m, A)
        assert view.n_negative == np.sum(sign < 0) == round((1 - frac) * interior)
    # a Q-Delaunay mesh has every interior q_ij ≥ 0
    assert scene.quality(steps["final"], A, q_sign_edges=True).n_negative == 0


def test_quality_rejects_unknown_colouring(steps, chapter_run):
    with pytest.raises(QmeshError):
        scene.quality(steps["final"], chapter_run.anisotropy, colour_by="area")


@pytest.mark.parametrize("name", ["L-shape", "square with hole", "annulus", "plate with holes"])
def test_lifted_surface_covers_exactly_the_domain_holes_left_open(name):
    from qmesh import domains
    from qmesh_view.controller import Controller
    c = Controller(domain=name)
    view = scene.lifted(c.current, c.anisotropy, domain=c.domain)
    P = view.surface.points[:, :2]
    F = _faces(view.surface)
    a, b, d = P[F[:, 0]], P[F[:, 1]], P[F[:, 2]]
    areas = 0.5 * np.abs((b - a)[:, 0] * (d - a)[:, 1] - (b - a)[:, 1] * (d - a)[:, 0])
    assert areas.sum() == pytest.approx(domains.NAMED[name]().area, rel=1e-9)
    assert c.domain.contains((a + b + d) / 3).all()
    # the facets of s_h sit over the mesh, which fills Ω too
    assert view.facets.n_cells == c.current.mesh.n_triangles


def test_sampling_without_a_domain_uses_the_hull_of_the_mesh(steps):
    step = steps["final"]
    rings = scene.domain_rings(step)
    P, T = scene.sample_domain(rings)
    hull = ConvexHull(step.mesh.points)
    a, b, d = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    area = 0.5 * np.abs((b - a)[:, 0] * (d - a)[:, 1] - (b - a)[:, 1] * (d - a)[:, 0]).sum()
    assert area == pytest.approx(hull.volume, rel=1e-9)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(0, 6000), most=st.integers(1, 500), seed=st.integers(0, 2**32 - 1),
       scale=st.floats(1e-6, 1e6), ties=st.booleans())
def test_longest_per_cell_keeps_the_longest_of_every_occupied_cell(n, most, seed, scale, ties):
    rng = np.random.default_rng(seed)
    P = scale * rng.random((n, 2)) + rng.normal(0, 1e3, 2)
    length = rng.integers(0, 3, n).astype(float) if ties else rng.random(n)
    kept = scene.longest_per_cell(P, length, most)
    if n <= most:
        np.testing.assert_array_equal(kept, np.arange(n))
        return
    assert len(kept) <= most and len(np.unique(kept)) == len(kept)
    cells = int(np.sqrt(most))
    g = np.ptp(P, axis=0).max() / cells
    ij = np.minimum(np.floor((P - P.min(axis=0)) / g), cells - 1).astype(int)
    key = ij[:, 0] * cells + ij[:, 1]
    assert set(key[kept]) == set(key)                    # every occupied cell, once
    best = {k: length[key == k].max() for k in set(key.tolist())}
    assert all(length[i] == best[key[i]] for i in kept)  # its longest move


def _solved_outside(mesh, anisotropy):
    """The vertices outside [0, 1] of u_h with u = 1 on the boundary left of the middle, solved
    here with the solver directly (not through the view)."""
    from qmesh.compare.solve import dirichlet
    fixed = np.flatnonzero(mesh.boundary)
    x = mesh.points[:, 0]
    u = dirichlet(mesh, anisotropy, fixed, (x[fixed] < (x.min() + x.max()) / 2).astype(float))
    return np.flatnonzero((u < -1e-9) | (u > 1 + 1e-9)), u


def test_solution_marks_the_vertices_outside_0_1(steps, chapter_run):
    step, A = steps["final"], chapter_run.anisotropy
    own = scene.solution(step, A)
    assert own.triangles.n_cells == step.mesh.n_triangles
    np.testing.assert_allclose(own.triangles.points[:, :2], step.mesh.points)
    outside, u = _solved_outside(step.mesh, A)
    assert len(outside) == 0 and own.below.n_points == own.above.n_points == 0
    np.testing.assert_allclose(own.triangles.point_data["u_h"], np.clip(u, 0, 1), atol=1e-12)
    iso = scene.solution(step, A, isotropic=True)
    mesh = iso.shown.mesh
    assert mesh.n_vertices == step.mesh.n_vertices and iso.triangles.n_cells == mesh.n_triangles
    outside, u = _solved_outside(mesh, A)
    assert len(outside) > 0
    marked = np.concatenate([iso.below.points, iso.above.points])[:, :2] if len(outside) else []
    assert {tuple(p) for p in np.asarray(marked).tolist()} == \
        {tuple(p) for p in mesh.points[outside].tolist()}
    assert iso.below.n_points == np.sum(u[outside] < 0)
    info = scene.solution_info(iso)
    assert info["shown"] == "isotropic" and info["mesh"]["n_outside"] == 0
    assert info["isotropic"]["n_outside"] == len(outside)
