"""What a medium's refusals say: what the input has and what to do, never an option the user
did not set or a defect the input does not have; and far-off or extreme inputs that mesh."""

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings, strategies as st

import qmesh
from qmesh import measure
from qmesh.domain import media_cases

P = qmesh.Anisotropy.principal
I = qmesh.Anisotropy.constant([[1.0, 0.0], [0.0, 1.0]])
UNIT = [(0, 0), (1, 0), (1, 1), (0, 1)]


def _triangle(size):
    return np.array([(0.5, 0.5), (0.5 + size, 0.5), (0.5 + size / 2, 0.5 + size)])


@pytest.mark.parametrize("size", [1e-6, 1e-7, 1e-8])
def test_a_tiny_inclusion_meshes_with_few_vertices(size):
    # its edge points (its 100 : 1 metric splits them) are closer together than a triangulation
    # of the unit square resolves: they go into the face around it by insertion
    d = qmesh.Domain(UNIT, regions=[_triangle(size)])
    cond = {0: I, 1: P(100, 1, 30)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(d, cond, target_vertices=500)
    assert measure.q_nonnegative_fractions(m, cond) == {
        "q_nonnegative_fraction": 1.0, "q_nonnegative_fraction_boundary": 1.0,
        "q_nonnegative_fraction_interface": 1.0}
    inside = m.region_tags == 1
    assert 0 < len(np.unique(m.triangles[inside])) <= 30
    P0, P1, P2 = (m.points[m.triangles[inside, k]] for k in range(3))
    area = 0.5 * ((P1 - P0)[:, 0] * (P2 - P0)[:, 1] - (P1 - P0)[:, 1] * (P2 - P0)[:, 0]).sum()
    assert area == pytest.approx(size * size / 2, rel=1e-6)
    assert abs(m.n_vertices - 500) <= 50


def test_an_inclusion_below_the_merge_distance_is_refused_at_the_domain():
    with pytest.raises(qmesh.QmeshError, match="region 1: segment 0 is shorter.*enlarge"):
        qmesh.Domain(UNIT, regions=[_triangle(1e-10)])


@pytest.mark.filterwarnings("ignore::qmesh.QmeshWarning")
def test_a_small_inclusion_meshes():
    d = qmesh.Domain(UNIT, regions=[_triangle(1e-4)])
    m = qmesh.mesh(d, {0: I, 1: P(100, 1, 30)}, target_vertices=500)
    assert measure.q_nonnegative_fractions(m, {0: I, 1: P(100, 1, 30)})["q_nonnegative_fraction"] == 1.0


@pytest.mark.parametrize("offset", [1e6, 1e8, -1e10])
def test_cells_far_from_the_origin_mesh(offset):
    x = np.linspace(0, 1, 5) + offset
    d, cond = qmesh.Domain.from_cells(x, x, 1 + np.arange(16.0).reshape(4, 4), 1.0)
    assert len(d.regions) == 15
    m = qmesh.mesh(d, cond, target_vertices=300)
    assert measure.q_nonnegative_fractions(m, cond) == {
        "q_nonnegative_fraction": 1.0, "q_nonnegative_fraction_boundary": 1.0,
        "q_nonnegative_fraction_interface": 1.0}


@pytest.mark.filterwarnings("error::RuntimeWarning")   # det H of 1e300 must not overflow
def test_a_huge_isotropic_cell_meshes():
    x = np.linspace(0, 1, 5)
    k = np.ones((4, 4))
    k[1, 2] = 1e300
    d, cond = qmesh.Domain.from_cells(x, x, k, k)
    m = qmesh.mesh(d, cond, target_vertices=300)
    assert abs(m.n_vertices - 300) <= 30
    fr = measure.q_nonnegative_fractions(m, cond)
    assert fr["q_nonnegative_fraction"] == fr["q_nonnegative_fraction_interface"] == 1.0


def test_a_cell_whose_conductivities_are_too_far_apart_is_named():
    x = np.linspace(0, 1, 5)
    k1 = np.ones((4, 4))
    k1[1, 2] = 1e300
    with pytest.raises(qmesh.QmeshError) as e:
        qmesh.Domain.from_cells(x, x, k1, 1.0)
    msg = str(e.value)
    assert "cell (row 1, column 2)" in msg and "k1 = 1e+300" in msg and "size" not in msg


# ------------------------------------------------------------------ regions meeting at a point

CHECKER = [[(0.5, 0.5), (1, 0.5), (1, 1), (0.5, 1)], [(0, 0), (0.5, 0), (0.5, 0.5), (0, 0.5)]]


def test_a_checkerboard_no_mesh_can_serve_is_refused_naming_the_point_and_its_angles():
    cond = {0: P(66.36103410928828, 0.09223766454700554, 44.22062004206484),
            1: P(3.3259781692712456, 97.56948512002008, 36.263624895025345),
            2: P(2.991574225470465, 0.03007160472211184, 93.0456506229551)}
    d = qmesh.Domain(UNIT, regions=CHECKER)
    with pytest.raises(qmesh.QmeshError) as e:
        qmesh.mesh(d, cond, target_vertices=200)
    msg = str(e.value)
    assert "regions meet at the point [0.5, 0.5]" in msg and "region 0 4.27°" in msg
    assert "move a corner off that point" in msg


@pytest.mark.filterwarnings("ignore::qmesh.QmeshWarning")
@pytest.mark.parametrize("ratio", [100.0, 1000.0])
def test_a_checkerboard_of_axis_aligned_anisotropies_meshes(ratio):
    from tests.media.cases import check_mesh
    cond = {0: P(ratio, 1.0, 0.0), 1: P(1.0, ratio, 0.0), 2: P(1.0, 1.0 / ratio, 90.0)}
    d = qmesh.Domain(UNIT, regions=CHECKER)
    m = qmesh.mesh(d, cond, target_vertices=800)
    check_mesh(d, cond, m)


@settings(max_examples=12, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.integers(2, 3), st.integers(2, 3), st.integers(0, 2**31 - 1), st.integers(2, 4),
       st.booleans(), st.integers(200, 900))
# a longer random run: a point where 4 regions meet whose wedges leave the first lengths a 1.5%
# band; the splits handed between the faces ran into it until two vertices were 4e-13 apart
@example(2, 3, 300, 2, True, 498)
def test_regions_meeting_at_points_mesh_or_are_refused_naming_the_point(nx, ny, seed, colours,
                                                                        checker, n):
    """Cells of a grid as regions (cell (0, 0) region 0), coloured like a checkerboard or at
    random from a few anisotropies up to 1e3:1 of sizes 0.1 to 10: a valid mesh with every
    q_ij >= 0 (interior, interface, boundary), or a refusal naming where regions meet."""
    from tests.media.cases import check_mesh
    rng = np.random.default_rng(seed)
    x = np.r_[0.0, np.sort(rng.uniform(0.2, 0.8, nx - 1)), 1.0]
    y = np.r_[0.0, np.sort(rng.uniform(0.2, 0.8, ny - 1)), 1.0]
    while np.min(np.diff(x)) < 0.15 or np.min(np.diff(y)) < 0.15:
        x[1:-1] = np.sort(rng.uniform(0.2, 0.8, nx - 1))
        y[1:-1] = np.sort(rng.uniform(0.2, 0.8, ny - 1))
    palette = [P(10 ** rng.uniform(-1, 1) * 10 ** rng.uniform(0, 3), 10 ** rng.uniform(-1, 1),
                 rng.uniform(0, 180)) for _ in range(colours)]
    cells = [(i, j) for j in range(ny) for i in range(nx)]
    pick = [(i + j) % 2 if checker else int(rng.integers(colours)) for i, j in cells]
    regions = [[(x[i], y[j]), (x[i + 1], y[j]), (x[i + 1], y[j + 1]), (x[i], y[j + 1])]
               for i, j in cells[1:]]
    cond = {k: palette[c] for k, c in enumerate(pick)}
    d = qmesh.Domain(UNIT, regions=regions)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        try:
            m = qmesh.mesh(d, cond, target_vertices=n)
        except qmesh.QmeshError as e:
            assert "regions meet at the point" in str(e), str(e)
            return
    check_mesh(d, cond, m)


def _band(w, ya, yb):
    """The w × 1 box crossed by the band ya < y < yb (region 1): T-junctions on both sides."""
    return qmesh.Domain([(0, 0), (w, 0), (w, 1), (0, 1)],
                        regions=[[(0, ya), (w, ya), (w, yb), (0, yb)]])


@pytest.mark.filterwarnings("ignore::qmesh.QmeshWarning")
def test_a_band_sharp_in_its_metric_at_the_outline_meshes():
    """The band's corner at (w, ya) is 22° in its metric: the splits beside that junction land
    where neither side's first subsegment encroaches the other's, instead of ¾ of the way down
    each in turn, nearer the junction every time until the run refused the point."""
    w = 1.1875
    ya, yb = np.sort(np.random.default_rng(1).uniform(0.3, 0.7, 2)) + np.array([0, 0.1])
    d, cond = _band(w, ya, yb), {0: P(1, 1, 0), 1: P(100, 1, 75)}
    from tests.media.cases import check_mesh
    check_mesh(d, cond, qmesh.mesh(d, cond, target_vertices=300))


@settings(max_examples=16, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.floats(0.5, 2.0), st.floats(0.1, 0.8), st.floats(0.03, 0.3), st.floats(1, 3),
       st.floats(0, 180), st.sampled_from([150, 300, 600, 1200]))
@example(1.2673, 0.5640, 0.1040, np.log10(19), 141.8, 150)     # 22° corners at x = 0 too
@example(1.2700, 0.5393, 0.1790, np.log10(47), 115.5, 300)
def test_a_band_across_a_box_meshes(w, ya, thick, ratio, angle, n):
    """A band across a w × 1 box, anisotropic up to 1e3:1 at any angle in a box of Q = I: its
    corners on the outline (however sharp in its metric) are no reason to refuse it; every
    q_ij >= 0 (interior, interface, boundary)."""
    from tests.media.cases import check_mesh
    d = _band(w, ya, min(ya + thick, 0.95))
    cond = {0: P(1, 1, 0), 1: P(10 ** ratio, 1, angle)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(d, cond, target_vertices=n)
    check_mesh(d, cond, m)


def test_a_thin_region_says_what_it_needs_not_a_target_below_the_one_asked():
    """A region's thin-face note counts what the region would need; it does not tell the user
    to ask for target_vertices = that count (its share of the target is far below the target)."""
    domain, conductivity, _ = media_cases.fvca4()
    c = {**conductivity, 0: qmesh.TensorField.principal(1, 1e-2, "30*sin(pi*x)")}
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        qmesh.mesh(domain, c, target_vertices=1000)
    notes = [str(w.message) for w in said if str(w.message).startswith("region ")]
    assert notes and all("the region would need about" in n for n in notes)
    assert not [n for n in notes if "vertices (target_vertices" in n]
