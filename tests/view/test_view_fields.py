"""Conductivity fields in the viewer: the `rotating` (FVCA5 test 5) and `raster` presets through
the session, Q(x) as ellipses in the first view (checked against the field, and drawn: coloured
pixels counted off-screen, the pictures written to test-artifacts/), the quality view and the
q_ij signs in each triangle's own element mean, the status line, the legend, refusals."""

import asyncio
import re
import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image

import qmesh
from qmesh import measure
from qmesh_view import draw, legend, problem, scene
from qmesh_view.controller import Controller, Params, status_text
from qmesh_view.session import Session
from view_cases import ARTIFACTS

SIZE = (360, 360)
DELTA = 1e-3


def fvca5(P):
    """FVCA5 test 5 written out here (not the preset's texts): K(x, y) (n, 2, 2)."""
    x, y = P[:, 0], P[:, 1]
    r2 = x * x + y * y
    K = np.empty((len(P), 2, 2))
    K[:, 0, 0] = (DELTA * x * x + y * y) / r2
    K[:, 0, 1] = K[:, 1, 0] = (DELTA - 1) * x * y / r2
    K[:, 1, 1] = (x * x + DELTA * y * y) / r2
    return K


def coloured(image: np.ndarray, spread: int = 60) -> float:
    """Share of pixels that are coloured, not white, grey or black (largest minus smallest
    channel above `spread`): the ellipses, never the grey mesh or the background."""
    rgb = np.asarray(image)[..., :3].astype(int)
    return float(np.mean(rgb.max(axis=-1) - rgb.min(axis=-1) > spread))


def run_to_end(session: Session) -> None:
    outcome = asyncio.run(session.run(pause=0))
    assert outcome.ok, outcome.message
    assert session.at_end


@pytest.fixture(scope="module")
def rotating():
    s = Session(domain="rotating")
    first = s.current
    run_to_end(s)
    return s, first


@pytest.fixture(scope="module")
def raster():
    s = Session(domain="raster")
    run_to_end(s)
    return s


def test_field_presets_are_offered_and_build_the_unit_square_and_a_field():
    names = Session().domain_names()
    assert {"rotating", "raster", "layered", "inclusion"} <= set(names)
    for name in ("rotating", "raster"):
        p = Params(domain=name)
        assert problem.is_field(p) and problem.varying(p)    # the budget's larger figure
        assert isinstance(problem.make_anisotropy(p), qmesh.TensorField)
        np.testing.assert_array_equal(np.ravel(problem.make_domain(p, {}).bounds), [0, 0, 1, 1])


def test_rotating_is_fvca5_test5():
    field = problem.rotating_field()
    P = np.random.default_rng(3).uniform(0.01, 1, (50, 2))
    np.testing.assert_allclose(field(P), fvca5(P), rtol=1e-12, atol=1e-15)


def test_raster_is_a_fixed_64_by_64_lognormal_raster_with_random_angles():
    a, b = problem.raster_field(), problem.raster_field()
    assert a.is_raster and a.label == "raster 64 × 64"
    centres = (np.arange(64) + 0.5) / 64
    C = np.column_stack([g.ravel() for g in np.meshgrid(centres, centres)])
    Qa, Qb = a(C), b(C)
    np.testing.assert_array_equal(Qa, Qb)                    # the same seed, the same raster
    lam, V = np.linalg.eigh(Qa)
    k = np.log(lam)
    assert -0.5 < k.mean() < 0.5                             # exp(N(0, 1)): log ~ N(0, 1)
    assert len(np.unique(np.round(Qa[:, 0, 0], 12))) == 64 * 64      # every cell differs
    angle = np.degrees(np.arctan2(V[:, 1, 1], V[:, 0, 1])) % 180
    assert np.histogram(angle, bins=6, range=(0, 180))[0].min() > 64 * 64 / 6 * 0.8


def test_the_session_runs_a_field_like_a_conductivity(rotating):
    s, first = rotating
    assert isinstance(s.anisotropy, qmesh.TensorField)
    text = s.readout["regions_text"]
    assert "do not apply" in text and "FVCA5 test 5" in text and s.anisotropy.label in text
    assert s.regions == []
    last = s.current
    assert last.converged and last.mesh.conductivity is not None
    assert first.mesh.conductivity is None                   # a stage before certification
    line = status_text(s.status())
    assert "E = " not in line                                # no s, no energy
    assert "q_ij ≥ 0 with the element means: 100.0%" in line and "converged" in line
    assert re.search(r"κ2 = \d", line)
    # what certification added is said (warned after the last Step: not lost)
    n, target = last.mesh.n_vertices, s.params.target_vertices
    if n > 1.1 * target:
        assert any("more vertices" in m or "off the target" in m for m in s.messages)
    # stepping back and forth replays the history
    assert s.scrub(0).ok and s.current is first
    assert s.step().ok and s.index == 1
    assert s.scrub(len(s.history) - 1).ok and s.current is last


def test_status_quality_is_each_triangles_own_mean(rotating):
    s, first = rotating
    for i in (0, len(s.history) - 1):
        step = s.history[i]
        row = s.status(i)
        Q = step.mesh.conductivity if step.mesh.conductivity is not None else \
            s.anisotropy.means(step.mesh.points, step.mesh.triangles)
        q = measure.quality(step.mesh, Q)
        assert row["min_quality"] == pytest.approx(q.min()) and row["mean_quality"] == pytest.approx(q.mean())
        assert row["q_nonnegative"] == pytest.approx(measure.q_nonnegative_fraction(step.mesh, Q))


def test_a_refused_input_keeps_the_field_mesh_on_screen(rotating):
    s = Session(domain="rotating")
    s.step()
    before, history, index = s.current, list(s.history), s.index
    for name, value in (("target_vertices", 3), ("target_vertices", "many"), ("domain", "nowhere")):
        outcome = s.change(name, value)
        assert outcome.kind == "refused" and outcome.message
        assert s.current is before and s.history == history and s.index == index
        assert s.params.domain == "rotating"
    # Q sliders do not apply to a field: the field stays the conductivity
    assert s.change("k1", 2.0).ok and isinstance(s.anisotropy, qmesh.TensorField)
    assert s.change("domain", "disk").ok and not isinstance(s.anisotropy, qmesh.TensorField)


def test_ellipses_follow_the_field(rotating):
    """One ellipse per grid cell of Ω; each one's axes along Q's eigenvectors at its centre,
    their lengths in the ratio of √eigenvalues — measured from the drawn points."""
    s, first = rotating
    view = scene.ellipses(first, s.anisotropy, domain=s.domain)
    n = scene.GLYPH_CELLS ** 2                               # the unit square: every cell inside
    assert len(view.centres) == n and view.ellipses.n_cells == n and view.n_skipped == 0
    assert view.outlines.n_cells == n
    np.testing.assert_allclose(view.tensors, fvca5(view.centres), rtol=1e-12)
    X = view.ellipses.points[:, :2].reshape(n, scene.ELLIPSE_SEGMENTS, 2)
    for c, pts in zip(view.centres, X):
        d = pts - c
        r = np.linalg.norm(d, axis=1)
        major = d[np.argmax(r)] / r.max()
        radial = c / np.linalg.norm(c)                       # FVCA5 test 5: δ along (x, y)
        assert abs(major @ radial) < 1e-6                    # the long axis is tangential
        assert r.max() / r.min() == pytest.approx(np.sqrt(1 / DELTA), rel=0.02)
        assert r.max() == pytest.approx(scene.GLYPH_FILL / scene.GLYPH_CELLS, rel=1e-9)
    assert np.all(view.ellipses.points[:, 2] > 0)            # just above the flat mesh
    assert view.mesh.n_cells == first.mesh.n_triangles


def test_ellipses_are_made_once_per_field_and_domain(rotating):
    """A Run draws the same ellipses at every stage: the field is evaluated at the glyph
    centres once, each stage gets only its own mesh under them; another field its own."""
    s, first = rotating
    field = qmesh.TensorField(lambda x, y: fvca5(np.column_stack([x, y])), "FVCA5 by hand")
    a = scene.ellipses(first, field, domain=s.domain)
    asked = field.evaluations.points
    assert asked == len(a.centres) == scene.GLYPH_CELLS ** 2
    b = scene.ellipses(s.current, field, domain=s.domain)
    assert field.evaluations.points == asked
    np.testing.assert_array_equal(b.tensors, a.tensors)
    assert (a.mesh.n_cells, b.mesh.n_cells) == (first.mesh.n_triangles, s.current.mesh.n_triangles)
    other = qmesh.TensorField.from_expressions("2 + x", "0", "1")
    np.testing.assert_allclose(scene.ellipses(s.current, other, domain=s.domain).tensors[:, 0, 0],
                               2 + a.centres[:, 0], rtol=1e-12)


def test_moving_through_a_field_run_averages_only_the_stages_asked_for():
    """Step and scrub compute no element means (a Run meshes stages the views never draw);
    `warm` (the app's worker, for the stage it draws next) computes the shown stage's once, and
    its measures and views find them."""
    c = Controller(domain="rotating")
    field, averaged = c.anisotropy, []
    means_with_error = field.means_with_error

    def counted(points, triangles, **options):
        averaged.append(len(triangles))
        return means_with_error(points, triangles, **options)
    field.means_with_error = counted
    for _ in range(3):
        assert c.step() and not c.current.converged
    assert c.scrub(1).stage and averaged == []
    c.warm()
    assert averaged == [c.current.mesh.n_triangles]
    c.warm()
    scene.quality(c.current, field)
    assert c.status()["q_nonnegative"] is not None
    assert averaged == [c.current.mesh.n_triangles]


def test_ellipses_of_a_raster_and_a_field_that_refuses_some_points(raster):
    view = scene.ellipses(raster.current, raster.anisotropy, domain=raster.domain)
    lam = np.linalg.eigvalsh(view.tensors)
    np.testing.assert_allclose(view.ellipses.cell_data["log10_k_max"], np.log10(lam[:, 1]))
    assert view.clim[0] < view.clim[1]
    # a field not SPD on part of the domain loses those glyphs, not the view
    def half(x, y):
        Q = np.zeros(np.shape(x) + (2, 2))
        Q[..., 0, 0] = Q[..., 1, 1] = np.where(np.asarray(x) < 0.5, 1.0, -1.0)
        return Q
    view = scene.ellipses(raster.current, qmesh.TensorField(half, "half SPD"), domain=raster.domain)
    assert 0 < len(view.centres) < scene.GLYPH_CELLS ** 2 and view.n_skipped > 0
    assert np.all(view.centres[:, 0] < 0.5)


def test_quality_and_q_signs_use_each_triangles_own_mean(rotating):
    s, first = rotating
    field = s.anisotropy
    means = field.means_with_error(first.mesh.points, first.mesh.triangles,
                                   rtol=problem.SHOWN_RTOL, bound_rtol=None)[0]
    full = field.means(first.mesh.points, first.mesh.triangles)     # at the field's tolerance
    assert 0 < np.abs(means - full).max() <= 10 * problem.SHOWN_RTOL * np.abs(full).max()
    view = scene.quality(first, field, q_sign_edges=True)
    np.testing.assert_allclose(view.triangles.cell_data["quality"],
                               measure.quality(first.mesh, means), rtol=1e-12)
    E, q, interior = measure.edge_weights(first.mesh, means)
    scale = np.abs(q).max()
    assert view.n_negative == int(np.sum(interior & (q < -1e-9 * scale))) > 0
    # the last Step: the certified means it carries, every interior q_ij >= 0
    last = s.current
    assert problem.element_means(last.mesh, field) is last.mesh.conductivity or np.array_equal(
        problem.element_means(last.mesh, field), last.mesh.conductivity)
    view = scene.quality(last, field, q_sign_edges=True)
    assert view.n_negative == 0
    np.testing.assert_allclose(view.triangles.cell_data["quality"],
                               measure.quality(last.mesh, None), rtol=1e-12)
    area = scene.quality(last, field, "metric_area").triangles.cell_data["metric_area"]
    assert np.all(np.isfinite(area)) and np.all(area > 0)


@pytest.mark.parametrize("preset", ["rotating", "raster"])
def test_field_views_are_drawn_off_screen(preset, rotating, raster):
    """The three views of a field's first and last Step: the first view shows coloured
    ellipses over the grey mesh (coloured pixels counted), none of the lifted surface."""
    s = rotating[0] if preset == "rotating" else raster
    ARTIFACTS.mkdir(exist_ok=True)
    views = draw.ViewSet(SIZE)
    try:
        for which, i in (("first", 0), ("last", len(s.history) - 1)):
            views.draw(s.history[i], s.anisotropy, domain=s.domain, q_sign_edges=True)
            images = views.images()
            lifted = views.plotters["lifted"]
            assert "ellipses" in lifted.actors and "ellipse_outlines" in lifted.actors
            assert "surface" not in lifted.actors and "vertices" not in lifted.actors
            assert lifted.camera.parallel_projection
            assert coloured(images["lifted"]) > 0.01, (preset, which)
            grey = np.asarray(images["lifted"]).astype(int)
            spread = grey.max(axis=-1) - grey.min(axis=-1)
            mesh_px = np.mean((spread < 12) & (grey.max(axis=-1) < 200))
            assert mesh_px > 0.005, (preset, which)           # the mesh's edges under them
            for name in ("mesh", "quality"):
                assert coloured(images[name], 30) > 0.01 or name == "mesh", (preset, which, name)
            row = np.concatenate([images[n] for n in draw.VIEWS], axis=1)
            Image.fromarray(row).save(ARTIFACTS / f"field_{preset}_{which}.png")
            info = views.legend
            assert info["field"] and info["means"] == ("certified" if which == "last" else "field")
            html = legend.html("lifted", info)
            assert "ellipses" in html and "eigenvalue" in html
            assert "own element mean" in legend.html("quality", info)
            assert legend.title("lifted", info) == legend.FIELD_TITLE
            assert legend.state(info)["field_view"] is True
    finally:
        views.close()


def test_back_from_a_field_the_lifted_view_is_a_surface_again(rotating):
    s, first = rotating
    disk = Session()
    views = draw.ViewSet(SIZE)
    try:
        views.draw(first, s.anisotropy, domain=s.domain)
        views.draw(disk.current, disk.anisotropy, domain=disk.domain)
        lifted = views.plotters["lifted"]
        assert "ellipses" not in lifted.actors and "ellipse_outlines" not in lifted.actors
        assert "surface" in lifted.actors and not lifted.camera.parallel_projection
        assert "sample" not in lifted.actors
        assert legend.title("lifted", views.legend) == legend.VIEW_TITLES["lifted"]
        assert legend.state(views.legend)["field_view"] is False
        fresh = draw.render_views(disk.current, disk.anisotropy, window_size=SIZE,
                                  domain=disk.domain)
        assert np.array_equal(views.images()["lifted"], fresh["lifted"])
    finally:
        views.close()


def test_help_lists_every_preset():
    exe = shutil.which("qmesh-view")
    assert exe
    out = subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0
    text = " ".join(out.stdout.split())
    for name in Session().domain_names():
        assert name in text, name


def test_a_stage_with_fewer_moves_than_vertices_is_drawn(rotating):
    """A metric without s may split edges after its vertex step, so a stage can hold the moves
    of the vertices there were before: arrows for those, the appended ones without."""
    from dataclasses import replace
    s, first = rotating
    adjust = next(st for st in s.history if st.stage == "adjust")
    n = adjust.mesh.n_vertices
    shorter = replace(adjust, moved=np.asarray(adjust.moved)[: n - 7],
                      added=np.array([0, n + 3], dtype=np.int64))
    view = scene.projected(shorter)
    whole = scene.projected(adjust)
    moved = np.hypot(*np.asarray(adjust.moved)[: n - 7].T)
    assert view.n_moved == int(np.sum(moved > 0)) <= whole.n_moved
    assert view.n_added == 1
