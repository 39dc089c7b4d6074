"""qmesh.mesh on a TensorField: every q_ij ≥ 0 with the element means recomputed here by other
methods (a collapsed-Gauss rule of another family for formulas, exact per-cell clipping for
rasters), N within 10% of the target or the warning saying why, iterate = mesh."""

import re
import warnings

import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

import qmesh
from qmesh.conductivity.anisotropy import adj2
from qmesh.geometry import topology
from tests.fields.reference import _collapsed_rule, area, cell_tensors, clip, principal

UNIT = qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])
DELTA = 1e-3
FVCA5_TEST5 = ("(%g*x**2 + y**2)/(x**2 + y**2)" % DELTA, "(%g - 1)*x*y/(x**2 + y**2)" % DELTA,
               "(x**2 + %g*y**2)/(x**2 + y**2)" % DELTA)
ROUND = 1e-9     # an off-diagonal counts as positive beyond this share of the terms it sums
# a refusal names a count to ask for in one of these forms
ASKED = r"ask for at least (\d+)|needs more than (\d+) vertices|about (\d+) vertices"


def reference_means(f, P, T, levels=2, n=8):
    """Element means by a collapsed Gauss–Legendre rule on 4**levels pieces of each triangle."""
    A, B, C = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    for _ in range(levels):
        ab, bc, ca = (A + B) / 2, (B + C) / 2, (C + A) / 2
        A, B, C = (np.stack(z, axis=1).reshape(-1, 2) for z in
                   ((A, ab, ca, ab), (ab, B, bc, bc), (ca, bc, C, ca)))
    uv, w = _collapsed_rule(n)
    X = A[:, None] + uv[None, :, 0, None] * (B - A)[:, None] + uv[None, :, 1, None] * (C - A)[:, None]
    Q = f(X[..., 0].ravel(), X[..., 1].ravel()).reshape(len(A), len(w), 2, 2)
    return np.einsum("r,krij->kij", w, Q).reshape(len(T), -1, 2, 2).mean(axis=1)


def raster_reference_means(x, y, Qc, P, T):
    """Area-weighted cell means by clipping each triangle against the cells of its box."""
    out = np.empty((len(T), 2, 2))
    for t, tri in enumerate(P[T]):
        lo, hi = tri.min(axis=0), tri.max(axis=0)
        i0, i1 = max(np.searchsorted(x, lo[0]) - 1, 0), min(np.searchsorted(x, hi[0]), len(x) - 1)
        j0, j1 = max(np.searchsorted(y, lo[1]) - 1, 0), min(np.searchsorted(y, hi[1]), len(y) - 1)
        o = tri.mean(axis=0)
        poly = [tuple(p - o) for p in tri]
        total = np.zeros((2, 2))
        for j in range(j0, j1):
            for i in range(i0, i1):
                piece = poly
                for axis, value, above in ((0, x[i] - o[0], True), (0, x[i + 1] - o[0], False),
                                           (1, y[j] - o[1], True), (1, y[j + 1] - o[1], False)):
                    piece = clip(piece, axis, value, above)
                    if not piece:
                        break
                if piece:
                    total += abs(area(piece)) * Qc[j, i]
        out[t] = total / abs(area(poly))
    return out


def positive_off_diagonals(P, T, Qbar) -> int:
    """Edges whose off-diagonal K_ij of the P1 stiffness matrix assembled with Qbar is > 0 by
    more than round-off: ROUND × the size of the terms it sums, |e_i||e_j|‖Q̄_T‖ / 4|T| per
    triangle (a share that is zero — a right angle in the triangle's metric — has the sign of
    the round-off, ±1e-16 of those terms, whatever means it is assembled from)."""
    X = P[T]
    E = X[:, [2, 0, 1]] - X[:, [1, 2, 0]]
    twice = (X[:, 1, 0] - X[:, 0, 0]) * (X[:, 2, 1] - X[:, 0, 1]) - \
        (X[:, 1, 1] - X[:, 0, 1]) * (X[:, 2, 0] - X[:, 0, 0])
    K = np.einsum("mki,mij,mkj->mk", E, adj2(Qbar), E[:, [1, 2, 0]]) / (2.0 * twice[:, None])
    K = K.ravel()                                   # K_ij^T of half-edge 3t + j
    twin = topology.twins(T)
    g = np.where(twin >= 0, twin, np.arange(len(twin)))
    k = K + np.where(twin >= 0, K[g], 0.0)
    size = (np.linalg.norm(E, axis=2) * np.linalg.norm(E[:, [1, 2, 0]], axis=2)
            * np.linalg.norm(Qbar, axis=(1, 2))[:, None] / (2.0 * np.abs(twice)[:, None])).ravel()
    scale = size + np.where(twin >= 0, size[g], 0.0)
    once = (twin < 0) | (np.arange(len(twin)) < twin)
    return int((once & (k > ROUND * scale)).sum())


def meshed(domain, field, target, **options):
    """The mesh, and how many edges its warning says still fail (0 without one). N off the
    target by more than 10% must be said too."""
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always", qmesh.QmeshWarning)
        m = qmesh.mesh(domain, field, target_vertices=target, **options)
    words = [str(w.message) for w in said]
    if abs(m.n_vertices - target) > 0.1 * target:
        assert any("vertices" in w for w in words), "N off target without a word"
    failing = [int(re.match(r"(\d+) edges still have q_ij < 0", w).group(1)) for w in words
               if re.match(r"\d+ edges still have q_ij < 0", w)]
    return m, sum(failing)


def fvca5(x, y):
    r2 = x * x + y * y
    return np.stack([np.stack([DELTA * x * x + y * y, (DELTA - 1) * x * y], -1),
                     np.stack([(DELTA - 1) * x * y, x * x + DELTA * y * y], -1)], -2) / r2[..., None, None]


def fvca5_reference(P, T):
    """Collapsed-Gauss means, with 4**5 pieces on the triangles next to the singular corner."""
    ref = reference_means(fvca5, P, T)
    near = np.flatnonzero(np.hypot(*P[T].min(axis=1).T) < 0.05)
    ref[near] = reference_means(fvca5, P, T[near], levels=5)
    return ref


@pytest.mark.parametrize("target", [400, 1500])
def test_fvca5_test5_is_certified_on_independent_means(target):
    m, failing = meshed(UNIT, qmesh.TensorField.from_expressions(*FVCA5_TEST5), target)
    assert failing == 0
    assert m.conductivity.shape == (m.n_triangles, 2, 2)
    ref = fvca5_reference(m.points, m.triangles)
    assert np.allclose(m.conductivity, ref, rtol=1e-6, atol=1e-7)
    assert positive_off_diagonals(m.points, m.triangles, ref) == 0
    assert positive_off_diagonals(m.points, m.triangles, m.conductivity) == 0


def test_iterate_ends_on_the_mesh_and_only_the_last_step_is_converged():
    F = qmesh.TensorField.principal("1 + 99*x", 1, "40*y")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        steps = list(qmesh.iterate(UNIT, F, target_vertices=300))
        m = qmesh.mesh(UNIT, F, target_vertices=300)
    assert steps[-1].converged and not any(s.converged for s in steps[:-1])
    assert {"triangulate", "adjust", "insert"} <= {s.stage for s in steps}
    assert np.array_equal(steps[-1].mesh.points, m.points)
    assert np.array_equal(steps[-1].mesh.triangles, m.triangles)
    assert np.array_equal(steps[-1].mesh.conductivity, m.conductivity)
    # the certified Step's figures are the mesh's own: quality in each triangle's own means,
    # as `report` (and the CLI's report of the file) gives them, no energy without an s
    r = qmesh.measure.report(m)
    assert steps[-1].stats.min_quality == pytest.approx(r["min_quality"], rel=1e-12)
    assert steps[-1].stats.mean_quality == pytest.approx(r["mean_quality"], rel=1e-12)
    assert np.isnan(steps[-1].stats.energy)


@pytest.mark.slow(20)
@settings(max_examples=8, deadline=None)
@given(ratio=st.floats(1.0, 1e4), turns=st.floats(0.0, 2.0), tilt=st.floats(0.0, 180.0),
       aspect=st.floats(1.0, 4.0), hole=st.booleans(), target=st.integers(150, 1500))
# found by longer random runs: a boundary share zero up to round-off (a right angle in the
# metric), counted positive by a test scaled to the share itself; a target one corrected run
# undershot, refused without a count to ask for; a target the boundary alone overshoots;
# runs that all undershoot a box far under one element wide, now refused with the count
@example(ratio=2980.71875, turns=0.2890625, tilt=0.291015625, aspect=1.0, hole=True, target=399)
@example(ratio=1334.0, turns=1.25, tilt=0.0, aspect=3.0, hole=True, target=165)
@example(ratio=2420.0, turns=1.25, tilt=0.0, aspect=3.0, hole=False, target=162)
@example(ratio=2000.0, turns=0.0, tilt=90.0, aspect=4.0, hole=False, target=150)
# and rotating fields whose repair gave up after 30 rounds without fewer failing edges
@example(ratio=1210.0, turns=0.21797110427298838, tilt=170.26753815967714,
         aspect=3.023712257849475, hole=True, target=452)
@example(ratio=1628.0, turns=1.776459282593665, tilt=163.05014757745047,
         aspect=3.711689180762488, hole=True, target=559)
def test_random_smooth_fields_are_certified_or_say_what_fails(ratio, turns, tilt, aspect, hole,
                                                               target):
    """A rotating anisotropy: k1 = ratio·(1 + x²), k2 = 1, the axis turning `turns` half-turns
    across the domain, on a box of any aspect, with or without a hole. The edges an independent
    assembly finds failing are never more than the run's warning says (0 without a warning):
    never a silent pass; and none fail for ratios up to 2000."""
    angle = f"{tilt} + {180 * turns}*x/{aspect}"
    F = qmesh.TensorField.principal(f"{ratio}*(1 + x**2)", 1.0, angle)
    outline = [(0, 0), (aspect, 0), (aspect, 1), (0, 1)]
    holes = [qmesh.Disk(12, radius=0.2, center=(0.5 * aspect, 0.5))] if hole else []
    try:
        m, failing = meshed(qmesh.Domain(outline, holes), F, target)
    except qmesh.QmeshError as e:        # a target the conforming boundary alone overshoots
        asked = re.search(ASKED, str(e))
        assert asked is not None and int(next(g for g in asked.groups() if g)) > target, str(e)
        return

    def f(x, y):
        return principal(ratio * (1 + x * x), 1.0, tilt + 180 * turns * x / aspect)
    ref = reference_means(f, m.points, m.triangles)
    assert positive_off_diagonals(m.points, m.triangles, ref) <= failing
    if ratio <= 2000:
        assert failing == 0


def lognormal_raster(seed, cells):
    """Cell edges x (sorted uniform) and y (even), k1, k2 lognormal, any angle: every cell its
    own anisotropy, up to ~1000 : 1."""
    rng = np.random.default_rng(seed)
    x = np.concatenate([[0.0], np.sort(rng.uniform(0, 1, cells - 1)), [1.0]])
    y = np.linspace(0.0, 1.0, cells + 1)
    k1, k2 = np.exp(rng.normal(0, 1.5, (cells, cells))), np.exp(rng.normal(0, 1.5, (cells, cells)))
    return x, y, k1, k2, rng.uniform(0, 180, (cells, cells))


@pytest.mark.slow(20)
@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), cells=st.integers(4, 24), target=st.integers(200, 900))
def test_random_rasters_are_certified_by_exact_clipping(seed, cells, target):
    x, y, k1, k2, ang = lognormal_raster(seed, cells)
    m, failing = meshed(UNIT, qmesh.TensorField.from_raster(x, y, k1, k2, ang), target)
    ref = raster_reference_means(x, y, cell_tensors(k1, k2, ang), m.points, m.triangles)
    assert np.allclose(m.conductivity, ref, rtol=1e-9, atol=1e-12)
    assert positive_off_diagonals(m.points, m.triangles, ref) <= failing
    assert failing == 0


def uneven_cells(rng):
    """Cell edges x, y over a rectangle anywhere (scale 1e-2…1e2, offset up to 3 sizes), nx, ny
    up to 40 cells of uneven widths; its corner, width and height, and an anisotropy up to 1e4
    (the random search's draws, in its order)."""
    nx, ny = int(rng.integers(2, 41)), int(rng.integers(2, 41))
    scale = 10 ** rng.uniform(-2, 2)
    off = rng.uniform(-3, 3, 2) * scale * rng.choice([0, 1])
    W, H = scale, scale * rng.uniform(0.3, 3)
    xe = np.cumsum(np.r_[0, rng.uniform(0.2, 1.0, nx) ** (2 if rng.random() < .5 else 1)])
    ye = np.cumsum(np.r_[0, rng.uniform(0.2, 1.0, ny) ** (2 if rng.random() < .5 else 1)])
    xe, ye = off[0] + W * xe / xe[-1], off[1] + H * ye / ye[-1]
    return xe, ye, off, W, H, 10 ** rng.uniform(0, 4)


def offset_raster(seed):
    """A raster over its rectangle anywhere (`uneven_cells`), anisotropy up to 1e4 at any angle,
    and a target 150…5000."""
    rng = np.random.default_rng(seed)
    xe, ye, _, _, _, ratio = uneven_cells(rng)
    ny, nx = len(ye) - 1, len(xe) - 1
    rng.choice(3)                                  # the kind of field (kept: the draws in order)
    k1 = np.exp(rng.normal(0, rng.uniform(0, 2), (ny, nx)))
    k2 = k1 / 10 ** rng.uniform(0, np.log10(ratio), (ny, nx))
    ang = rng.uniform(0, 180, (ny, nx))
    rng.choice(2)
    target = int(10 ** rng.uniform(np.log10(150), np.log10(5000)))
    return xe, ye, k1, k2, ang, target


@pytest.mark.slow(10)
@settings(max_examples=3, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
@example(seed=416)
def test_a_raster_over_its_own_rectangle_anywhere_is_certified(seed):
    """The outline is the raster's rectangle, so the mesh's points on its sides lie on the
    raster's edge or off it by a last bit. Seed 416 (26 x 2 cells at 0.5 from the origin):
    a flip proposed a triangle of three points of the top side, 3e-16 of its edge squared
    in area; clipped to the raster its mean was undefined and the run was refused."""
    xe, ye, k1, k2, ang, target = offset_raster(seed)
    outline = [(xe[0], ye[0]), (xe[-1], ye[0]), (xe[-1], ye[-1]), (xe[0], ye[-1])]
    m, failing = meshed(qmesh.Polygon(outline), qmesh.TensorField.from_raster(xe, ye, k1, k2, ang),
                        target)
    ref = raster_reference_means(xe, ye, cell_tensors(k1, k2, ang), m.points, m.triangles)
    assert positive_off_diagonals(m.points, m.triangles, ref) <= failing


def test_a_field_turning_a_right_angle_at_3600_to_1_is_certified():
    """Q's axis turns about 100° across the unit square at 3660 : 1 (a random search found it).
    The repair's failing edges fell from 68 to 2, then rose and fell between 2 and 11 as splits
    made new ones; after 30 rounds without fewer than 2 it gave up with a warning. Later rounds
    reach 0: the repair gives up only after 120 rounds without a new fewest."""
    r = 0.0002732458799840147
    angle = "-68.85474116663886*x + 17.721927902971203*y + 170.11245267723086"
    m, failing = meshed(UNIT, qmesh.TensorField.principal(1.0, r, angle), 348)
    assert failing == 0

    def f(x, y):
        return principal(1.0, r, -68.85474116663886 * x + 17.721927902971203 * y
                         + 170.11245267723086)
    ref = reference_means(f, m.points, m.triangles)
    assert positive_off_diagonals(m.points, m.triangles, ref) == 0


def test_a_corner_sharp_in_its_cells_metric_is_certified():
    """The corner (0, 1) lies in a cell of about 1360 : 1 where the square's right angle is 4° in
    the metric: only an isosceles corner triangle passes on both sides, within 0.24% in their
    lengths. Splits there left the corner's two edges failing in turn (6 edges warned); a
    slide of the end along its side makes it isosceles."""
    x, y, k1, k2, ang = lognormal_raster(2818041, 20)
    m, failing = meshed(UNIT, qmesh.TensorField.from_raster(x, y, k1, k2, ang), 307)
    assert failing == 0
    ref = raster_reference_means(x, y, cell_tensors(k1, k2, ang), m.points, m.triangles)
    assert positive_off_diagonals(m.points, m.triangles, ref) == 0


@pytest.mark.parametrize("field", [
    qmesh.TensorField.from_expressions("1e200*(1 + x**2)", 0, "1e200"),       # det Q overflows
    qmesh.TensorField.principal(1e300, 1e-300, 0),                           # was OverflowError
    qmesh.TensorField.from_raster([0, 0.5, 1], [0, 0.5, 1], np.full((2, 2), 1e300), 1e-300),  # ValueError
])
@pytest.mark.filterwarnings("error::RuntimeWarning")     # the refusal alone, no overflow warned
def test_a_field_beyond_the_floats_is_refused_naming_the_field_not_an_s(field):
    """A field has no s: the refusal names the field's metric and says what to change."""
    with pytest.raises(qmesh.QmeshError) as e:
        qmesh.mesh(qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]), field, target_vertices=200)
    assert f"of the field ({field.label})" in str(e.value) and "rescale Q" in str(e.value)
    assert "Hessian of s" not in str(e.value)


def test_the_memory_refusal_of_a_field_says_field(monkeypatch):
    from qmesh.mesher import budget
    monkeypatch.setattr(budget, "available_bytes", lambda: 8 * 2**30)
    monkeypatch.setattr(budget, "process_limits", lambda: [])
    field = qmesh.TensorField.from_expressions("1 + x**2", 0, 1)
    with pytest.raises(qmesh.QmeshError, match=r"^4e\+07 vertices with a field need about") as e:
        qmesh.mesh(qmesh.Disk(16), field, target_vertices=40_000_000)
    assert "varying s" not in str(e.value)


@pytest.mark.parametrize("options, message", [
    ({"size": float("inf")}, "size must be a finite number > 0, got inf"),
    ({"size": 0.0}, "size must be a finite number > 0, got 0.0"),
    ({"size": "a"}, "size must be a finite number > 0, got 'a'"),
    ({"target_vertices": 10**400}, "target_vertices = 1e+300 asks for"),
])
def test_a_fields_options_are_checked_before_its_smoothing_reads_them(options, message):
    """Not "half_width must be finite" (the smoothing's own argument, which no one gave), a
    ValueError or an OverflowError: the option, named as for a constant Q."""
    raster = qmesh.TensorField.from_raster([0, 1], [0, 1], [[2.0]], 1.0)
    with pytest.raises(qmesh.QmeshError, match=re.escape(message)):
        qmesh.mesh(qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]), raster, **options)
