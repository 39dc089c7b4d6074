"""Media whose regions hold tensor fields: qmesh.mesh(domain, {tag: Anisotropy | TensorField}).

Every mesh is checked against means recomputed here (tests/fields/media_reference.py: a constant
itself, a collapsed-Gauss rule of another family than the mesher's for a formula, exact clipping
for a raster): a valid triangulation of Ω with every input point and the regions' tags
(tests/media/cases.check_mesh, which also solves a Dirichlet problem for the discrete maximum
principle), and q_ij ≥ 0 on every interior edge, on each side of every interface on its own
and on every boundary edge; N within 10% of the target or a warning that says so."""

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import qmesh
from qmesh.fields.certify import certify
from qmesh.media import field_regions
from tests.fields.media_reference import failing_edges, region_means
from tests.fields.reference import principal
from tests.fields.test_field_mesh import cell_tensors, meshed, raster_reference_means
from tests.media.cases import check_mesh, media

UNIT = [(0, 0), (1, 0), (1, 1), (0, 1)]


def smooth_field(size, ratio, tilt, turn, wave):
    """A random smooth SPD field as (TensorField from texts, the same formula in NumPy): the
    axis turning `turn` degrees per unit of x + y/2, k1 rippling by half along a wave."""
    k1 = f"{size * ratio}*(1 + 0.5*sin({wave}*x + {0.5 * wave}*y))"
    angle = f"{tilt} + {turn}*(x + 0.5*y)"
    F = qmesh.TensorField.principal(k1, size, angle)

    def f(x, y):
        return principal(size * ratio * (1 + 0.5 * np.sin(wave * x + 0.5 * wave * y)),
                         size + 0 * x, tilt + turn * (x + 0.5 * y))
    return F, f


def meshed_certified(domain, cond, target):
    """`meshed` (the field tests': N off target said; the count of edges a warning says fail),
    where no edge may be said to fail."""
    m, failing = meshed(domain, cond, target)
    assert failing == 0, failing
    return m


def assert_certified(domain, m, parts, failing=0):
    """Means recomputed here; the mesh's within their error, and every edge passing on them
    unless the run said that some fail (`failing`, its warning's count): never a silent one."""
    ref = region_means(m.points, m.triangles, m.region_tags, parts)
    assert m.conductivity.shape == (m.n_triangles, 2, 2)
    scale = np.linalg.norm(ref, axis=(1, 2))[:, None, None]
    assert np.all(np.abs(m.conductivity - ref) <= 1e-6 * scale)
    said = failing > 0
    if said:                              # a few edges a fast-turning field left, not a repair skipped
        assert failing <= 0.02 * 1.5 * m.n_triangles, failing
    else:
        assert failing_edges(m.points, m.triangles, m.region_tags, ref) == \
            {"interior": 0, "interface": 0, "boundary": 0}
    check_mesh(domain, ref, m, signs=not said)


@st.composite
def media_with_fields(draw):
    """(domain, {tag: Anisotropy | TensorField}, {tag: Q or f}): tests/media's random domains and
    regions, each region a random smooth field (anisotropy up to 1e3, turning up to 60° per
    unit) or its random constant, at least one a field."""
    domain, cond = draw(media())
    fields = draw(st.lists(st.booleans(), min_size=len(cond), max_size=len(cond)))
    fields[draw(st.integers(0, len(cond) - 1))] = True
    out, parts = {}, {}
    for (r, a), field in zip(sorted(cond.items()), fields):
        if not field:
            out[r], parts[r] = a, a.matrix
            continue
        F, f = smooth_field(10 ** draw(st.floats(-1, 1)), 10 ** draw(st.floats(0, 3)),
                            draw(st.floats(0, 180)), draw(st.floats(-60, 60)),
                            draw(st.floats(0, 6)))
        out[r], parts[r] = F, f
    return domain, out, parts


@pytest.mark.slow(20)
@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(media_with_fields())
def test_random_media_with_fields_are_certified_or_say_what_fails(case):
    """Certified on means recomputed here, or (a field turning fast for N = 300: 1000 : 1 at 60°
    a unit) a warning counting the few edges left failing (at most 2%), the rest of the mesh
    still checked."""
    domain, cond, parts = case
    m, failing = meshed(domain, cond, 300)
    assert_certified(domain, m, parts, failing)


def inclusion():
    """media_cases.inclusion with a rotating field in the background (tag 0)."""
    from qmesh.domain import media_cases
    domain, cond, _ = media_cases.inclusion()
    F, f = smooth_field(1.0, 10.0, 0.0, 60.0, 2.0)
    return domain, {**cond, 0: F}, {0: f, 1: cond[1].matrix, 2: cond[2].matrix}


def test_a_field_in_the_background_of_an_inclusion():
    domain, cond, parts = inclusion()
    m = meshed_certified(domain, cond, 800)
    assert_certified(domain, m, parts)
    assert m.region_names == domain.region_names and set(m.boundary_tags.tolist()) == {1}
    # the Anisotropy regions carry their constants exactly
    for r in (1, 2):
        assert np.array_equal(m.conductivity[m.region_tags == r],
                              np.broadcast_to(parts[r], ((m.region_tags == r).sum(), 2, 2)))


def test_iterate_ends_on_the_certified_mesh_and_only_the_last_step_is_converged():
    domain, cond, _ = inclusion()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        steps = list(qmesh.iterate(domain, cond, target_vertices=300))
        shown = []
        m = qmesh.mesh(domain, cond, target_vertices=300, progress=shown.append)
    assert steps[-1].converged and not any(s.converged for s in steps[:-1])
    assert {"triangulate", "adjust", "insert"} <= {s.stage for s in steps}
    assert shown[-1].converged and shown[-1].stats.min_quality > 0
    for a in (steps[-1].mesh, shown[-1].mesh):
        assert np.array_equal(a.points, m.points) and np.array_equal(a.triangles, m.triangles)
        assert np.array_equal(a.conductivity, m.conductivity)
        assert np.array_equal(a.region_tags, m.region_tags)


def test_one_field_on_a_domain_with_regions_holds_in_every_region():
    domain = qmesh.Domain(UNIT, regions=[[(0.5, 0), (1, 0), (1, 1), (0.5, 1)]])
    F, f = smooth_field(1.0, 30.0, 20.0, 40.0, 3.0)
    m = meshed_certified(domain, F, 400)
    assert set(np.unique(m.region_tags).tolist()) == {0, 1}
    assert_certified(domain, m, {0: f, 1: f})


def test_a_raster_region_is_certified_by_exact_clipping():
    """The lens of the inclusion holds a raster over its box only, every cell different."""
    from qmesh.domain import media_cases
    domain, cond, _ = media_cases.inclusion()
    rng = np.random.default_rng(3)
    x, y = np.linspace(0.56, 0.88, 9), np.linspace(0.21, 0.39, 7)
    k1, k2, ang = rng.lognormal(0, 1, (6, 8)), rng.lognormal(0, 1, (6, 8)), rng.uniform(0, 180, (6, 8))
    R = qmesh.TensorField.from_raster(x, y, k1, k2, ang)
    m = meshed_certified(domain, {**cond, 2: R}, 600)
    lens = m.region_tags == 2
    ref = raster_reference_means(x, y, cell_tensors(k1, k2, ang), m.points, m.triangles[lens])
    assert np.allclose(m.conductivity[lens], ref, rtol=1e-9, atol=1e-12)
    parts = {0: cond[0].matrix, 1: cond[1].matrix}
    full = region_means(m.points, m.triangles, np.where(lens, 0, m.region_tags), parts)
    full[lens] = ref
    assert failing_edges(m.points, m.triangles, m.region_tags, full) == \
        {"interior": 0, "interface": 0, "boundary": 0}
    check_mesh(domain, full, m)


def test_an_interface_side_that_fails_alone_is_mended_though_the_sum_passes():
    """Two regions of Q = I across the edge (0,0)–(1,0): the apex above it makes a 136° angle
    (its share < 0), the one below a 28° angle (the sum > 0). A medium keeps each side ≥ 0 on
    its own, so the edge may not be flipped away (it is the interface): it is split on both
    sides, each child keeping its parent's region."""
    P = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.2], [0.5, -2.0]])
    T = np.array([[0, 1, 2], [1, 0, 3]])
    mesh = qmesh.Mesh(P, T, fixed=np.ones(4, bool), region_tags=[0, 1])
    I = np.eye(2)
    before = failing_edges(P, T, mesh.region_tags, np.stack([I, I]))
    assert before == {"interior": 0, "interface": 1, "boundary": 0}
    m, cert = certify(mesh, {0: qmesh.Anisotropy.constant(I), 1: qmesh.Anisotropy.constant(I)})
    assert cert.remaining == 0 and cert.added >= 1
    Q = np.broadcast_to(I, (m.n_triangles, 2, 2))
    assert failing_edges(m.points, m.triangles, m.region_tags, Q) == \
        {"interior": 0, "interface": 0, "boundary": 0}
    above = m.points[m.triangles].mean(axis=1)[:, 1] > 0
    assert np.array_equal(m.region_tags, np.where(above, 0, 1))
    assert np.all(m.points[m.n_vertices - cert.added:, 1] == 0.0)     # on the interface


def test_a_region_without_a_conductivity_is_refused():
    domain, cond, _ = inclusion()
    with pytest.raises(qmesh.QmeshError, match=r"no conductivity for region 2 \(lens\)"):
        qmesh.mesh(domain, {0: cond[0], 1: cond[1]}, target_vertices=300)
    with pytest.raises(qmesh.QmeshError, match="must be a qmesh.Anisotropy or a qmesh.TensorField"):
        qmesh.mesh(domain, {**cond, 1: [[1, 0], [0, 1]]}, target_vertices=300)
    with pytest.raises(qmesh.QmeshError, match="region 7"):
        qmesh.mesh(domain, {**cond, 7: cond[0]}, target_vertices=300)


def test_a_raster_that_does_not_cover_its_region_is_refused():
    domain, cond, _ = inclusion()
    R = qmesh.TensorField.from_raster([0.6, 0.8], [0.25, 0.35], [[2.0]], [[1.0]], [[0.0]])
    with pytest.raises(qmesh.QmeshError, match=r"region 2 \(lens\) .* reaches outside the cells"):
        qmesh.mesh(domain, {**cond, 2: R}, target_vertices=300)
    with pytest.raises(qmesh.QmeshError, match="region 0 .* reaches outside the cells"):
        qmesh.iterate(domain, {**cond, 0: R}, target_vertices=300)


def test_media_without_fields_take_the_medium_path():
    domain, cond, _ = inclusion()
    del cond[0]
    assert not field_regions.holds_fields(domain, {0: qmesh.Anisotropy.constant(np.eye(2)), **cond})
    assert field_regions.holds_fields(domain, qmesh.TensorField.principal(2, 1, 0))
    assert not field_regions.holds_fields(qmesh.Disk(8), qmesh.TensorField.principal(2, 1, 0))


def test_the_benchmark_counts_each_interface_side_on_its_own():
    """bench_fields' media case: its own region test and its per-side count, on the hand-made
    interface above (one side fails, the sum passes)."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    import bench_fields as bench
    P = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.2], [0.5, -2.0]])
    T = np.array([[0, 1, 2], [1, 0, 3]])
    Q = np.stack([np.eye(2)] * 2)
    assert bench.positive_off_diagonals(P, T, Q)[:2] == (0, 0)
    assert bench.positive_off_diagonals(P, T, Q, np.array([0, 1]))[:2] == (1, 0)
    domain = bench.CASES["media"].domain()
    X = np.random.default_rng(1).uniform(0, 1, (2000, 2))
    from tests.media.cases import region_of
    assert np.array_equal(bench.in_star(X), region_of(domain, X) == 1)
