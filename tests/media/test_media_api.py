"""qmesh.mesh / qmesh.iterate with a conductivity per region, and measure.report with one."""

import warnings

import numpy as np
import pytest

import qmesh
from qmesh import Anisotropy, measure

SQUARE = [(0, 0), (1, 0), (1, 1), (0, 1)]
FAULT = qmesh.Domain(SQUARE, regions=[[(0.5, 0), (1, 0), (1, 1), (0.5, 1)]], region_names=["right"])
COND = {0: Anisotropy.constant([[1, 0], [0, 1]]), 1: Anisotropy.principal(100, 1, 30)}


def test_a_missing_region_is_refused():
    with pytest.raises(qmesh.QmeshError, match="no conductivity for region 1 \\(right\\)"):
        qmesh.mesh(FAULT, {0: COND[0]}, target_vertices=200)


def test_bad_conductivity_mappings_are_refused():
    with pytest.raises(qmesh.QmeshError, match="must be a qmesh.Anisotropy"):
        qmesh.mesh(FAULT, {0: COND[0], 1: [[1, 0], [0, 1]]}, target_vertices=200)
    with pytest.raises(qmesh.QmeshError, match="region 5"):
        qmesh.mesh(FAULT, {**COND, 5: COND[0]}, target_vertices=200)


def test_mesh_meets_the_target_and_tags_regions():
    m = qmesh.mesh(FAULT, COND, target_vertices=600)
    assert abs(m.n_vertices - 600) <= 60
    assert set(np.unique(m.region_tags)) == {0, 1} and m.region_names == {1: "right"}
    r = measure.report(m, COND)
    assert r["q_nonnegative_fraction"] == r["q_nonnegative_fraction_interface"] == 1.0
    assert r["q_nonnegative_fraction_boundary"] == 1.0
    # the interface x = 0.5 is covered by interface edges
    E, inter = measure.interface_edges(m)
    L = np.linalg.norm(m.points[E[inter, 0]] - m.points[E[inter, 1]], axis=1).sum()
    assert L == pytest.approx(1.0, rel=1e-12)
    # boundary edges: the outline's tag, none on the interface x = 0.5 (unless on y = 0 or 1)
    assert set(m.boundary_tags.tolist()) == {1}
    B = m.points[m.boundary_edges]
    on_outline = np.isclose(B, 0).all(axis=1) | np.isclose(B, 1).all(axis=1)
    assert on_outline.any(axis=1).all()


def test_iterate_yields_a_step_per_stage_and_only_the_last_converged():
    """A medium's run yields every stage of every face's Algorithm 2.1 (stitched with the faces
    done before it), like a single conductivity's; only the whole, last, is converged."""
    steps = list(qmesh.iterate(FAULT, COND, target_vertices=300))
    assert all(isinstance(s, qmesh.Step) for s in steps)
    assert steps[-1].converged and not any(s.converged for s in steps[:-1])
    assert steps[0].stage == "triangulate" and steps[0].iteration == 0
    assert {"triangulate", "adjust", "insert"} <= {s.stage for s in steps}
    # the faces done so far are in every later step: its regions only grow
    regions = [set(s.mesh.region_tags.tolist()) for s in steps]
    assert all(a <= b for a, b in zip(regions, regions[1:]))
    assert regions[-1] == set(COND) and len(regions[0]) == 1
    m = qmesh.mesh(FAULT, COND, target_vertices=300)
    assert np.array_equal(m.points, steps[-1].mesh.points)
    assert np.array_equal(m.triangles, steps[-1].mesh.triangles)
    assert steps[5].stats.min_quality > 0          # lazy Stats of a stitched medium


def test_a_single_anisotropy_without_regions_is_todays_mesher():
    """qmesh.mesh / iterate take Algorithm 2.1's own path (mesher.loop) for one conductivity."""
    A = Anisotropy.constant(qmesh.CHAPTER_Q)
    from qmesh.mesher import loop
    m1 = qmesh.mesh(qmesh.Disk(32), A, target_vertices=150)
    m2 = loop.mesh(qmesh.Disk(32), A, target_vertices=150)
    assert np.array_equal(m1.points, m2.points) and np.array_equal(m1.triangles, m2.triangles)
    steps = list(qmesh.iterate(qmesh.Disk(32), A, target_vertices=150))
    assert any(s.stage == "adjust" for s in steps)         # the media path only yields faces
    assert np.array_equal(steps[-1].mesh.points, m1.points)


def test_a_mapping_on_a_domain_without_regions():
    m = qmesh.mesh(qmesh.Disk(24), {0: COND[1]}, target_vertices=150)
    assert (m.region_tags == 0).all()
    assert measure.report(m, {0: COND[1]})["kappa2"] == pytest.approx(
        measure.report(m, COND[1])["kappa2"], rel=1e-12)


def test_report_with_a_mapping_uses_each_triangles_q():
    m = qmesh.mesh(FAULT, COND, target_vertices=300)
    K = measure.stiffness(m, COND).toarray()
    # assemble by hand, region by region, from sub-meshes of the same points
    K2 = np.zeros_like(K)
    for r, A in COND.items():
        sub = qmesh.Mesh(m.points, m.triangles[m.region_tags == r])
        K2 += measure.stiffness(sub, A).toarray()
    assert np.allclose(K, K2, atol=1e-12 * np.abs(K).max())
    one = measure.report(m, COND[0])              # one Q for every triangle: different matrix
    assert one["kappa2"] != measure.report(m, COND)["kappa2"]
    with pytest.raises(qmesh.QmeshError, match="no conductivity for region 1"):
        measure.report(m, {0: COND[0]})


def test_thin_face_warnings_name_their_region():
    d = qmesh.Domain(SQUARE, regions=[[(0, 0.45), (1, 0.45), (1, 0.47), (0, 0.47)]])
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        qmesh.mesh(d, {0: COND[0], 1: COND[0]}, target_vertices=300)
    assert all(str(w.message).startswith("region") for w in said if w.category is qmesh.QmeshWarning)


def test_a_sharp_notch_under_strong_anisotropy_is_meshed_finer_not_refused():
    """Found by the random media property test: a triangular notch on the bottom side whose
    corners are very sharp in its metric (anisotropy 1000 at 162°) needed one more halving of
    the shared size than the face mesher allowed, and the whole run was refused."""
    w = 0.8125
    notch = [(0.28533550700689586, 0.0), (0.36658550700689585, 0.0),
             (0.3259605070068959, 0.19504636963259353)]
    d = qmesh.Domain([(0, 0), (w, 0), (w, 1), (0, 1)], regions=[notch])
    cond = {0: Anisotropy.principal(1, 1, 0), 1: Anisotropy.principal(1000, 1, 162)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(d, cond, target_vertices=300)
    assert set(np.unique(m.region_tags)) == {0, 1}
    assert all(v == 1.0 for v in measure.q_nonnegative_fractions(m, cond).values())


def test_only_the_kept_passs_face_warnings_are_given():
    """A target the interfaces overshoot is met by meshing again with a smaller request; the
    faces' warnings of the pass left behind (their N no longer true) are not given, so each
    region is warned about at most once, and the final N is the last warning's."""
    d = qmesh.Domain(SQUARE, regions=[[(0.5, 0), (1, 0), (1, 1), (0.5, 1)],
                                      [(0.1, 0.1), (0.3, 0.1), (0.2, 0.3)]])
    cond = {0: Anisotropy.constant(qmesh.CHAPTER_Q), 1: Anisotropy.principal(100, 1, 30),
            2: Anisotropy.constant([[0.01, 0], [0, 0.01]])}
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        m = qmesh.mesh(d, cond, target_vertices=40)
    faces = [str(w.message).split(":")[0] for w in said if str(w.message).startswith("region")]
    assert faces and len(faces) == len(set(faces)), faces
    assert str(said[-1].message).startswith(f"target_vertices = 40: the mesh has {m.n_vertices}")


def test_nested_regions_holes_and_a_varying_s():
    from tests.media.cases import check_mesh
    ring = qmesh.Domain([(1, 0.2), (1.8, 0.2), (1.8, 0.8), (1, 0.8)], [[(1.2, 0.4), (1.4, 0.4), (1.3, 0.6)]])
    d = qmesh.Domain([(0, 0), (2, 0), (2, 1), (0, 1)], [[(0.2, 0.2), (0.4, 0.2), (0.3, 0.4)]],
                     regions=[ring, [(1.2, 0.4), (1.4, 0.4), (1.3, 0.6)]])
    cond = {0: Anisotropy.from_expression("exp(x) + y**2"), 1: Anisotropy.principal(100, 1, 20),
            2: Anisotropy.constant(0.01 * np.eye(2))}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(d, cond, target_vertices=600)
    check_mesh(d, cond, m)
    assert set(np.unique(m.region_tags)) == {0, 1, 2}
    assert set(m.boundary_tags.tolist()) == {1, 2}          # the outline's and the hole's


@pytest.mark.parametrize("target", [212, 300, 2000])
def test_iterate_ends_on_the_mesh_of_mesh_for_a_medium(target):
    """The viewer steps through iterate, the CLI calls mesh: both are one run, so they end on
    the same mesh. The last face is given what the target leaves, so N lands on it once the
    regions' own needs are met (5 thin anisotropic layers need about 240 vertices: at 212 the
    run says so with a warning)."""
    from qmesh.domain import media_cases as cases
    domain, cond, _ = cases.layered()
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always", qmesh.QmeshWarning)
        m = qmesh.mesh(domain, cond, target_vertices=target)
        last = list(qmesh.iterate(domain, cond, target_vertices=target))[-1].mesh
    assert np.array_equal(m.points, last.points) and np.array_equal(m.triangles, last.triangles)
    assert np.array_equal(m.region_tags, last.region_tags)
    off = abs(m.n_vertices - target) > 0.1 * target
    assert off == any(f"target_vertices = {target}: the mesh has" in str(w.message) for w in said)
    assert not off or target < 240
