"""Media presets in the viewer: `layered` and `inclusion` through the session,
a conductivity per region, the mesh view coloured by region, a legend entry per region with its
Q, interface edges marked, one lifted piece per region; the disk unchanged after switching back."""

import numpy as np
import pytest

from qmesh import measure
from qmesh_view import draw, legend, scene
from qmesh_view.draw import ViewSet
from qmesh_view.problem import MEDIA
from qmesh_view.session import Session

SIZE = (260, 220)


@pytest.fixture(scope="module")
def layered():
    s = Session()
    assert s.change("domain", "layered").ok
    s.controller.finish()               # a medium opens on its first face: the whole medium
    return s


def shown_region_colours(image: np.ndarray, tags) -> list[int]:
    """The regions among `tags` whose colour covers at least 1% of the picture."""
    px = image.reshape(-1, 3).astype(int)
    out = []
    for tag in tags:
        rgb = np.asarray(scene.region_rgb(np.array([tag]))[0], dtype=int)
        if np.mean(np.abs(px - rgb).max(axis=1) <= 8) >= 0.01:
            out.append(int(tag))
    return out


def test_media_are_offered_as_domains():
    assert {"layered", "inclusion"} <= set(Session().domain_names())


def test_layered_meshes_regions_and_each_has_its_own_q(layered):
    tags = layered.current.mesh.region_tags
    assert len(np.unique(tags)) >= 2
    assert isinstance(layered.anisotropy, dict) and set(np.unique(tags)) <= set(layered.anisotropy)
    rows = layered.regions
    assert [r["tag"] for r in rows] == sorted(layered.anisotropy)
    text = layered.readout["regions_text"]
    assert "do not apply" in text
    for r in rows:
        Q = layered.anisotropy[r["tag"]].matrix
        assert r["name"] in text and (r["q11"], r["q12"], r["q22"]) == pytest.approx(
            (Q[0, 0], Q[0, 1], Q[1, 1]))
    status = layered.status()
    assert status["q_nonnegative"] is not None and status["kappa2"] is not None


def test_the_legend_names_every_region_with_its_q(layered):
    views = ViewSet(SIZE)
    try:
        views.draw(layered.current, layered.anisotropy, domain=layered.domain,
                   regions=layered.regions, q_sign_edges=True)
        mesh = legend.html("mesh", views.legend)
        views.legend["quality_edges"] = "dark"       # zoomed in: every kind of q_ij line drawn
        for r in layered.regions:
            assert f"{r['name']}: Q = [[{r['q11']:.3g}" in mesh
            assert scene.region_colour(r["tag"]) in mesh
        quality = legend.html("quality", views.legend)
        assert "interface, q_ij ≥ 0" in quality
        assert all(colour in quality for _, _, colour, _ in draw.Q_SIGN_LINES)
        assert "one s per region" in legend.html("lifted", views.legend)
    finally:
        views.close()


def test_quality_uses_each_triangles_own_metric_and_interface_edges_are_marked(layered):
    step, Q = layered.current, layered.anisotropy
    q = scene.quality(step, Q, q_sign_edges=True)
    np.testing.assert_allclose(q.triangles.cell_data["quality"], measure.quality(step.mesh, Q))
    E, sign = scene.q_signs(step, Q)
    across = scene.interface_mask(step.mesh, E)
    # an interface edge: its two triangles carry different tags
    T, tags = step.mesh.triangles, step.mesh.region_tags
    i, j = E[np.flatnonzero(across)[0]]
    touching = np.flatnonzero((T == i).any(axis=1) & (T == j).any(axis=1))
    assert len(touching) == 2 and tags[touching[0]] != tags[touching[1]]
    assert across.any() and set(np.unique(sign[across])) <= {2, -1}
    assert q.n_interface == int(np.sum(sign == 2)) > 0


def test_the_lifted_view_has_one_piece_per_region(layered):
    view = scene.lifted(layered.current, layered.anisotropy, domain=layered.domain)
    assert view.surface.n_points == 0                          # no single surface
    assert view.facets.n_cells == layered.current.mesh.n_triangles
    assert set(np.unique(view.facets.cell_data["region"])) == set(
        np.unique(layered.current.mesh.region_tags))


@pytest.mark.parametrize("name", list(MEDIA))
def test_the_mesh_view_of_a_medium_has_the_region_colours(name):
    s = Session(domain=name)
    s.controller.finish()
    views = ViewSet(SIZE)
    try:
        views.draw(s.current, s.anisotropy, domain=s.domain, regions=s.regions)
        images = views.images()
        views.draw(s.current, s.anisotropy, domain=s.domain, regions=s.regions, edges="off")
        faces = views.images()["mesh"]          # the face colours alone, edges hidden
    finally:
        views.close()
    tags = np.unique(s.current.mesh.region_tags)
    shown = shown_region_colours(faces, tags)
    assert len(shown) >= 2, (name, shown)                        # more than one hue
    px = images["mesh"].reshape(-1, 3)
    assert len(np.unique(px[(px.max(axis=1) - px.min(axis=1)) > 20], axis=0)) > 2
    for image in images.values():
        assert len(np.unique(image.reshape(-1, 3), axis=0)) > 10   # no empty card


def test_back_to_the_disk_is_todays_behaviour_exactly():
    fresh = Session()
    s = Session()
    assert s.change("domain", "inclusion").ok and s.readout["regions_text"]
    assert s.change("domain", "disk").ok
    assert s.readout == fresh.readout and s.readout["regions_text"] == ""
    np.testing.assert_array_equal(s.current.mesh.points, fresh.current.mesh.points)
    np.testing.assert_array_equal(s.current.mesh.triangles, fresh.current.mesh.triangles)
    assert s.regions == [] and not isinstance(s.anisotropy, dict)
