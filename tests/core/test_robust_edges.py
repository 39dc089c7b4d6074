"""Valid input never ends in "please report": a corner too sharp for the vertices asked (under
0.1° in the metric) is refused naming the corner and what to do; a disk whose target barely
exceeds its boundary points meshes (the flips along its needle-thin metric take thousands of
rounds)."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh.geometry.triangles import signed_areas

SLIVER = [[6304.13782194677, -2909.1187856396928], [1081.9399992251927, 6870.7102961520895],
          [1485.204385879639, 6103.347754101624]]
NEAR_ISOTROPIC = qmesh.Anisotropy.constant([[374.968897314986, -65.50665312115466],
                                            [-65.50665312115466, 246.28632615637864]])


def test_a_corner_too_sharp_for_the_target_is_refused_by_name():
    """SLIVER's corner is 0.033° in the metric, below the 0.1° the corner splits are built
    for: at 3500 vertices its points crowd closer than round-off and the refusal names it (at
    2324, refused so before, the boundary's count is named instead: test below)."""
    with pytest.raises(qmesh.QmeshError) as e:
        qmesh.mesh(qmesh.Polygon(SLIVER), NEAR_ISOTROPIC, target_vertices=3500)
    message = str(e.value)
    assert "please report" not in message
    assert "(6304.14, -2909.12)" in message and "° in the metric" in message
    assert "target_vertices = 3500" in message and "blunt the corner" in message
    with pytest.raises(qmesh.QmeshError, match="target_vertices = 500 is too few"):
        qmesh.mesh(qmesh.Polygon(SLIVER), NEAR_ISOTROPIC, target_vertices=500)   # fewer: no way


@pytest.mark.slow(10)
def test_the_sliver_refused_for_its_corner_names_a_count_that_meshes():
    """At 2324 vertices SLIVER was refused for its corner; its two sides now split at matching
    distances from the apex, the refusal names the count its boundary needs, and that count
    meshes with every q_ij >= 0 (a domain thinner than an element there: warned)."""
    import re
    with pytest.raises(qmesh.QmeshError) as e:
        qmesh.mesh(qmesh.Polygon(SLIVER), NEAR_ISOTROPIC, target_vertices=2324)
    need = re.search(r"target_vertices = 2324 is too few: .* needs (\d+) vertices", str(e.value))
    assert need, str(e.value)
    with pytest.warns(qmesh.QmeshWarning, match="wide in the metric"):
        m = qmesh.mesh(qmesh.Polygon(SLIVER), NEAR_ISOTROPIC, target_vertices=int(need.group(1)))
    assert abs(m.n_vertices - int(need.group(1))) <= 0.1 * int(need.group(1))
    r = qmesh.measure.report(m, NEAR_ISOTROPIC)
    assert r["q_nonnegative_fraction"] in (1.0, None)
    assert r["q_nonnegative_fraction_boundary"] == 1.0


@pytest.mark.parametrize("vb, target", [(20000, 20001), (15468, 15469), (4000, 4080)])
def test_a_disk_with_a_target_just_above_its_boundary_points_meshes(vb, target):
    m = qmesh.mesh(qmesh.Disk(vb), qmesh.Anisotropy.constant([[0.1, 0], [0, 10]]),
                   target_vertices=target)
    assert abs(m.n_vertices - target) <= 0.1 * target
    assert m.fixed.sum() == vb


@pytest.mark.slow(12)
@settings(max_examples=12, deadline=None)
@given(aspect=st.floats(1.0, 1000.0), turn=st.floats(0.0, 180.0), k=st.floats(1.0, 100.0),
       angle=st.floats(0.0, 180.0), n=st.integers(100, 3000), corners=st.integers(3, 6))
def test_thin_polygons_mesh_or_are_refused_by_name(aspect, turn, k, angle, n, corners):
    """Thin convex polygons of aspect up to 1000 under any SPD Q: a valid mesh, or a
    QmeshError that says what the input has (never "please report")."""
    t = np.linspace(0.0, 2 * np.pi, corners, endpoint=False)
    ring = np.column_stack([np.cos(t), np.sin(t) / aspect])
    c, s = np.cos(np.radians(turn)), np.sin(np.radians(turn))
    ring = ring @ np.array([[c, s], [-s, c]])
    try:
        m = qmesh.mesh(qmesh.Polygon(ring), qmesh.Anisotropy.principal(1.0, k, angle),
                       target_vertices=n)
    except qmesh.QmeshError as e:
        assert "please report" not in str(e)
        return
    area = np.abs(signed_areas(m.points, m.triangles)).sum()
    assert np.isclose(area, qmesh.Polygon(ring).area, rtol=1e-9)


def test_a_thin_strip_under_a_rotated_strong_anisotropy_meshes():
    """A strip 0.005 wide under principal(1, 1000, 45°): nearly one curve once lifted, which
    Qhull's exact mode resolved in seconds per call; joggled it is a hundredth of that
    (the times, beside the box's, are benchmarks/bench_thin.py's)."""
    strip = qmesh.Polygon([(0, 0), (1, 0), (1, 0.005), (0, 0.005)])
    m = qmesh.mesh(strip, qmesh.Anisotropy.principal(1, 1000, 45), target_vertices=10000)
    assert abs(m.n_vertices - 10000) <= 1000
    r = qmesh.measure.report(m, qmesh.Anisotropy.principal(1, 1000, 45))
    assert r["q_nonnegative_fraction_boundary"] == 1.0


def test_a_strip_too_thin_for_its_target_is_refused_naming_its_metric_width():
    """The 1 × 0.002 strip under principal(1, 1000, 30°) at N 1e4: its boundary alone needs
    twice that. The refusal says how many vertices it needs and what the strip has, its width
    in elements of the metric; the count it names meshes."""
    import re
    strip = qmesh.Polygon([(0, 0), (1, 0), (1, 0.002), (0, 0.002)])
    A = qmesh.Anisotropy.principal(1, 1000, 30)
    with pytest.raises(qmesh.QmeshError) as e:
        qmesh.mesh(strip, A, target_vertices=10000)
    message = str(e.value)
    need = re.search(r"is too few: keeping every q_ij >= 0 on the boundary needs (\d+) vertices",
                     message)
    assert need and int(need.group(1)) > 11000
    assert re.search(r"[Tt]he domain is [\d.]+ elements wide in the metric", message), message
    with pytest.warns(qmesh.QmeshWarning, match="elements wide in the metric"):
        m = qmesh.mesh(strip, A, target_vertices=int(need.group(1)))
    assert abs(m.n_vertices - int(need.group(1))) <= 0.1 * int(need.group(1))
    assert qmesh.measure.report(m, A)["q_nonnegative_fraction_boundary"] == 1.0


@settings(max_examples=5, deadline=None)
@given(width=st.floats(0.001, 0.01), angle=st.floats(0.0, 90.0), ratio=st.floats(100.0, 1000.0),
       n=st.integers(4100, 8000))
def test_thin_strips_past_the_exact_hull_mesh_validly_or_are_refused_by_name(width, angle, ratio, n):
    """Strips thin in their metric with more points than Qhull's exact hull takes (the joggled
    2-D Delaunay, the pre-pass's rounds on what was split in, the conformity's rounds on what
    changed): a mesh of the strip's area with every q_ij ≥ 0 and N within 10% of the target,
    or a refusal that names the count the boundary needs."""
    strip = qmesh.Polygon([(0, 0), (1, 0), (1, width), (0, width)])
    A = qmesh.Anisotropy.principal(1, ratio, angle)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", qmesh.QmeshWarning)
            m = qmesh.mesh(strip, A, target_vertices=n)
    except qmesh.QmeshError as e:
        message = str(e)
        assert "please report" not in message
        assert "is too few" in message or "° in the metric" in message, message
        return
    P, T = m.points, m.triangles
    areas = signed_areas(P, T)
    assert areas.min() > 0 and np.isclose(areas.sum(), width, rtol=1e-9)
    assert abs(m.n_vertices - n) <= 0.1 * n
    r = qmesh.measure.report(m, A)
    assert r["q_nonnegative_fraction_boundary"] == 1.0
    assert r["q_nonnegative_fraction"] in (1.0, None)


def test_a_second_sized_run_refused_names_a_count_above_the_target():
    """The first run of this strip ends far past its target (its boundary needs the splits), so
    a second run is sized for a smaller interior; its splits are as many again, and they are
    capped as the first run's were: the refusal names what they need, not a count below the
    target (it said 'needs more than 1912 vertices' for a target of 4100)."""
    import re
    w = 0.001953125
    strip = qmesh.Polygon([(0, 0), (1, 0), (1, w), (0, w)])
    with pytest.raises(qmesh.QmeshError) as e:
        qmesh.mesh(strip, qmesh.Anisotropy.principal(1, 100, 0), target_vertices=4100)
    need = re.search(r"needs (?:more than )?(\d+) vertices", str(e.value))
    assert need and int(need.group(1)) > 4100, str(e.value)


def test_a_domain_near_the_largest_floats_meshes_without_overflow():
    """A quadrilateral 1e300 across centred at y ≈ 9e307 (every coordinate finite, the sum of
    its box's corners not): the mesher's centre overflowed, and a ValueError followed."""
    P = [[9.799515294107126e+299, 8.988465755002108e+307], [5.344774253635019e+299, 8.988465791991414e+307],
         [1.6234094749021628e+299, 8.988465720877404e+307], [3.0261541972660756e+299, 8.988465714209575e+307]]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = qmesh.mesh(qmesh.Polygon(P), qmesh.Anisotropy.principal(1.0, 1.0, 0.0), target_vertices=150)
    assert np.all(np.isfinite(m.points)) and abs(m.n_vertices - 150) <= 15
    lo, hi = np.min(P, axis=0), np.max(P, axis=0)
    assert np.all((m.points >= lo) & (m.points <= hi))
    assert np.all(signed_areas(m.points / 1e300, m.triangles) > 0)
