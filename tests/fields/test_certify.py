"""The repair pass (qmesh/fields/certify.py and its flips, splits and moves): its flips only
lower the total deficit (so they end), its splits never put a new vertex off the edge they split,
its shape steps add no failing edge, a flip or a move it refused is refused again while nothing
it is judged on changes (so it is not judged again), and a raster whose triangles are smaller
than its cells — where flips judged on their own edge alone cycled without end — is
certified on means computed here by clipping."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.spatial import Delaunay

import qmesh
from qmesh.fields import flips, moves, shares, splits
from qmesh.fields.metric import field_metric
from qmesh.fields.repair_state import RepairState
from qmesh.geometry import topology
from qmesh.conductivity.anisotropy import shape_metric
from qmesh.geometry.triangles import metric_quality, signed_areas
from tests.fields.reference import cell_tensors
from tests.fields.test_field_mesh import (UNIT, meshed, positive_off_diagonals,
                                          raster_reference_means)


def random_raster(seed, cells, decades):
    """Cells all different: k1 lognormal, k2 = k1 / 10^U(0, decades), any angle."""
    rng = np.random.default_rng(seed)
    k1 = np.exp(rng.normal(0.0, 1.0, (cells, cells)))
    k2 = k1 / 10.0 ** rng.uniform(0.0, decades, (cells, cells))
    angle = rng.uniform(0.0, 180.0, (cells, cells))
    edges = np.linspace(0.0, 1.0, cells + 1)
    return edges, k1, k2, angle


def square_mesh(seed, n):
    """The Delaunay triangulation (counter-clockwise) of the unit square's corners and n random
    points inside."""
    rng = np.random.default_rng(seed)
    P = np.concatenate([[(0, 0), (1, 0), (1, 1), (0, 1)], rng.uniform(0.02, 0.98, (n, 2))])
    T = Delaunay(P).simplices
    A, B = P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]
    cw = A[:, 0] * B[:, 1] - A[:, 1] * B[:, 0] < 0
    T[cw] = T[cw][:, [0, 2, 1]]
    return P, T.astype(np.int64)


def total_deficit(P, T, field):
    """Σ over the edges of max(0, bound − q_ij), from the means of `field` computed afresh."""
    Qbar, err = field.means_with_error(P, T)
    s, b = shares.shares(P, T, np.asarray(Qbar), np.asarray(err))
    twin = topology.twins(T)
    g = np.where(twin >= 0, twin, np.arange(len(twin)))
    q = s + np.where(twin >= 0, s[g], 0.0)
    bound = b + np.where(twin >= 0, b[g], 0.0)
    once = (twin < 0) | (np.arange(len(twin)) < twin)
    return float(np.maximum(bound - q, 0.0)[once].sum()), s, b, twin


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(30, 300), cells=st.integers(2, 12))
def test_a_round_of_flips_lowers_the_total_deficit(seed, n, cells):
    P, T = square_mesh(seed, n)
    edges, k1, k2, angle = random_raster(seed, cells, 3.0)
    field = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    before, s, b, twin = total_deficit(P, T, field)
    h, _, _ = shares.failing(s, b, twin)
    done = flips.mending_flips(RepairState.of(P, T, field), h)
    if not len(done):
        return
    T2, _ = topology.flip(T, twin, done)
    after = total_deficit(P, T2, field)[0]
    assert after < before


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(30, 200))
def test_split_points_lie_inside_the_edges_they_split(seed, n):
    P, T = square_mesh(seed, n)
    rng = np.random.default_rng(seed)
    edges, k1, k2, angle = random_raster(seed, 6, 2.0)
    field = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    state = RepairState.of(P, T, field)
    twin = state.twin
    for inner in (True, False):
        h = np.flatnonzero((twin >= 0) == inner)
        h = h[shares.independent(h, rng.random(len(h)), (h // 3, np.where(twin[h] >= 0, twin[h], h) // 3))]
        X = splits.split_points(state, h)
        u, v = P[T[h // 3, h % 3]], P[T[h // 3, topology.NXT[h % 3]]]
        t = np.einsum("ki,ki->k", X - u, v - u) / np.einsum("ki,ki->k", v - u, v - u)
        assert np.all((t >= splits.SPLIT_AT - 1e-12) & (t <= 1 - splits.SPLIT_AT + 1e-12))
        off = np.abs((X - u)[:, 0] * (v - u)[:, 1] - (X - u)[:, 1] * (v - u)[:, 0])
        assert np.all(off <= 1e-12 * np.einsum("ki,ki->k", v - u, v - u))


@pytest.mark.slow(10)
@pytest.mark.parametrize("seed, cells, target, decades", [(1, 40, 2000, 2.0), (3, 30, 2000, 3.0)])
def test_rasters_finer_meshed_than_their_cells_are_certified(seed, cells, target, decades):
    """About two triangles per cell, each cell's own anisotropy up to 10^decades: the repair
    used to flip the same edges back and forth until it stalled, and warned."""
    edges, k1, k2, angle = random_raster(seed, cells, decades)
    m, failing = meshed(UNIT, qmesh.TensorField.from_raster(edges, edges, k1, k2, angle), target)
    assert failing == 0
    ref = raster_reference_means(edges, edges, cell_tensors(k1, k2, angle), m.points, m.triangles)
    assert np.allclose(m.conductivity, ref, rtol=1e-9, atol=1e-12)
    assert positive_off_diagonals(m.points, m.triangles, ref) == 0


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(30, 200), cells=st.integers(2, 10),
       shape=st.booleans())
def test_shape_steps_never_add_failing_edges_nor_deficit(seed, n, cells, shape):
    """A vertex moves only where its star gets better: no edge of the mesh starts failing, the
    total deficit does not grow, and no triangle turns over."""
    P, T = square_mesh(seed, n)
    edges, k1, k2, angle = random_raster(seed, cells, 2.0)
    field = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    metric = field_metric(field, 0.1, (np.zeros(2), np.ones(2)))
    before, s, b, twin = total_deficit(P, T, field)
    h0, _, _ = shares.failing(s, b, twin)
    fixed = np.zeros(len(P), bool)
    fixed[:4] = True
    movers = moves.movers(T, twin, moves.free(T, twin, fixed, np.arange(len(P))),
                       np.random.default_rng(seed))
    state = RepairState.of(P, T, field, fixed=fixed)
    moves.relax(state, metric, movers, shape=shape)
    P2 = state.P
    assert np.all(signed_areas(P2, T) > 0)
    after, s2, b2, _ = total_deficit(P2, T, field)
    h1, _, _ = shares.failing(s2, b2, twin)
    assert len(h1) <= len(h0)
    assert after <= before * (1 + 1e-9) + 1e-15
    moved = np.flatnonzero(np.any(P2 != P, axis=1))
    assert np.isin(moved, movers).all()


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), cells=st.integers(3, 10), target=st.integers(200, 800))
def test_boundary_vertices_slide_along_the_boundary_only(seed, cells, target):
    """The repair and the polish slide boundary vertices along their straight piece of the
    boundary: every boundary vertex stays on the outline or on the hole, the seeds stay put,
    and every edge still passes on independently computed means."""
    edges, k1, k2, angle = random_raster(seed, cells, 2.0)
    domain = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)],
                          [qmesh.Polygon([(0.3, 0.3), (0.7, 0.35), (0.6, 0.7)])])
    F = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    m, failing = meshed(domain, F, target)
    assert failing == 0
    on = np.unique(m.boundary_edges)
    X = m.points[on]
    outline = np.minimum(np.minimum(X[:, 0], 1 - X[:, 0]), np.minimum(X[:, 1], 1 - X[:, 1]))
    A = np.array([(0.3, 0.3), (0.7, 0.35), (0.6, 0.7)])
    B = np.roll(A, -1, axis=0)
    E = B - A
    t = np.clip(np.einsum("kpi,pi->kp", X[:, None] - A, E) / np.einsum("pi,pi->p", E, E), 0, 1)
    hole = np.hypot(*(X[:, None] - (A + t[..., None] * E)).transpose(2, 0, 1)).min(axis=1)
    assert np.all(np.minimum(np.abs(outline), hole) <= 1e-12)
    corners = np.array([(0, 0), (1, 0), (1, 1), (0, 1)] + A.tolist())
    assert all(np.any(np.all(m.points == c, axis=1)) for c in corners)
    ref = raster_reference_means(edges, edges, cell_tensors(k1, k2, angle), m.points, m.triangles)
    assert positive_off_diagonals(m.points, m.triangles, ref) == 0


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(30, 200), cells=st.integers(2, 10))
def test_sliding_vertices_keep_to_their_side(seed, n, cells):
    """_tangents gives the sides' directions to the boundary points between the corners and
    nothing to the corners; a shape step moves those points along their side only, and
    breaks no edge."""
    rng = np.random.default_rng(seed)
    P, T = square_mesh(seed, n)
    u = rng.uniform(0.1, 0.9, 8)
    side = np.concatenate([np.column_stack([u[:2], [0, 0]]), np.column_stack([[1, 1], u[2:4]]),
                           np.column_stack([u[4:6], [1, 1]]), np.column_stack([[0, 0], u[6:]])])
    P = np.concatenate([P, side])
    T = Delaunay(P).simplices
    A, B = P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]
    cw = A[:, 0] * B[:, 1] - A[:, 1] * B[:, 0] < 0
    T[cw] = T[cw][:, [0, 2, 1]]
    T = T.astype(np.int64)
    twin = topology.twins(T)
    fixed = np.zeros(len(P), bool)
    fixed[:4] = True
    tan = moves.tangents(P, T, twin, fixed)
    sliding = np.flatnonzero(np.any(tan != 0, axis=1))
    assert set(sliding) == set(range(len(P) - 8, len(P)))
    assert np.allclose(np.abs(tan[sliding]), np.abs(np.round(tan[sliding])))
    edges, k1, k2, angle = random_raster(seed, cells, 2.0)
    field = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    state = RepairState.of(P, T, field, fixed=fixed)
    h0 = state.h
    movers = moves.movers(T, twin, moves.free(T, twin, fixed, np.arange(len(P)), tan), rng)
    moves.relax(state, None, movers, shape=True, tangent=tan)
    P2 = state.P
    on_x = np.isin(P[sliding, 1], (0.0, 1.0))            # sides y = 0, 1 keep their y, else x
    assert np.array_equal(P2[sliding[on_x], 1], P[sliding[on_x], 1])
    assert np.array_equal(P2[sliding[~on_x], 0], P[sliding[~on_x], 0])
    assert np.all(signed_areas(P2, T) > 0)
    _, s2, b2, _ = total_deficit(P2, T, field)
    assert len(shares.failing(s2, b2, twin)[0]) <= len(h0)


def star_worst(P, T, field, v):
    """The worst metric quality of each vertex v's star, each triangle in its own means."""
    Qbar = np.asarray(field.means(P, T))
    q = np.nan_to_num(metric_quality(P, T, shape_metric(Qbar)), nan=0.0)
    return np.array([q[np.any(T == u, axis=1)].min() for u in v])


def square_mesh_with_sides(seed, n, m):
    """`square_mesh` with m points on each side too (random, in order along it), which may
    slide along their side."""
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0.05, 0.95, (4, m)), axis=1)
    sides = np.concatenate([np.column_stack([t[0], 0 * t[0]]), np.column_stack([1 + 0 * t[1], t[1]]),
                            np.column_stack([t[2], 1 + 0 * t[2]]), np.column_stack([0 * t[3], t[3]])])
    P = np.concatenate([[(0, 0), (1, 0), (1, 1), (0, 1)], sides, rng.uniform(0.05, 0.95, (n, 2))])
    T = Delaunay(P).simplices
    A, B = P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]
    cw = A[:, 0] * B[:, 1] - A[:, 1] * B[:, 0] < 0
    T[cw] = T[cw][:, [0, 2, 1]]
    return P, T.astype(np.int64)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(5, 60), m=st.integers(1, 6),
       cells=st.integers(1, 6))
def test_isosceles_slides_keep_to_their_side_and_mend(seed, n, m, cells):
    """A failing boundary edge next to a corner: its other end slides along its side to where
    the triangle is isosceles in its metric, only where that leaves fewer failing edges or a
    lower deficit and no more of either, and no triangle turns over."""
    P, T = square_mesh_with_sides(seed, n, m)
    edges, k1, k2, angle = random_raster(seed, cells, 3.0)
    field = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    before, s, b, twin = total_deficit(P, T, field)
    h0, _, _ = shares.failing(s, b, twin)
    fixed = np.zeros(len(P), bool)
    fixed[:4] = True
    tangent = moves.tangents(P, T, twin, fixed)
    state = RepairState.of(P, T, field, fixed=fixed)
    changed = moves.isosceles(state, h0, tangent, np.random.default_rng(seed))
    P2 = state.P
    assert np.all(signed_areas(P2, T) > 0)
    moved = np.flatnonzero(np.any(P2 != P, axis=1))
    assert np.all(np.any(tangent[moved] != 0, axis=1))           # sliding side vertices only
    on_x = np.isin(P[moved], [0.0, 1.0])                        # the coordinate their side fixes
    assert np.all(on_x.any(axis=1)) and np.array_equal(P2[moved][on_x], P[moved][on_x])
    assert np.all((P2[moved] >= 0) & (P2[moved] <= 1))
    beside = np.zeros(len(P), bool)                             # an edge away from a corner
    E = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    E = np.concatenate([E, E[:, ::-1]])
    beside[E[E[:, 0] < 4, 1]] = True
    assert beside[moved].all()
    assert set(np.flatnonzero(topology.touching(T, np.isin(np.arange(len(P)), moved)))) == set(changed)
    after, s2, b2, _ = total_deficit(P2, T, field)
    h1, _, _ = shares.failing(s2, b2, twin)
    assert len(h1) <= len(h0)
    assert after <= before * (1 + 1e-9) + 1e-15


def polish_inputs(P, T, field, rng):
    """What the polish is called with on a mesh whose four first points (the square's corners)
    are fixed: the deficit before, the repair's state (a function making it afresh), the twins,
    failing edges, tangents, movers."""
    before, s, b, twin = total_deficit(P, T, field)
    h0, _, _ = shares.failing(s, b, twin)
    fixed = np.zeros(len(P), bool)
    fixed[:4] = True
    tan = moves.tangents(P, T, twin, fixed)
    movers = moves.movers(T, twin, moves.free(T, twin, fixed, np.arange(len(P)), tan), rng)
    return before, lambda: RepairState.of(P, T, field, fixed=fixed), twin, h0, tan, movers


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(30, 200), cells=st.integers(2, 10))
def test_the_polish_raises_the_worst_quality_of_every_star_it_moves(seed, n, cells):
    """The polish moves a mover only where its star's worst quality (in each triangle's own
    means) rises, breaking no edge and turning over no triangle; a boundary vertex slides
    along its side; what it leaves is what it refused; and a mover is polished as it would be
    alone (`Judged` relies on it)."""
    rng = np.random.default_rng(seed)
    P, T = square_mesh(seed, n)
    u = rng.uniform(0.1, 0.9, 4)
    P = np.concatenate([P, np.column_stack([u[:2], [0, 0]]), np.column_stack([[1, 1], u[2:]])])
    T = Delaunay(P).simplices
    A, B = P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]
    cw = A[:, 0] * B[:, 1] - A[:, 1] * B[:, 0] < 0
    T[cw] = T[cw][:, [0, 2, 1]]
    T = T.astype(np.int64)
    edges, k1, k2, angle = random_raster(seed, cells, 2.0)
    field = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    before, state, twin, h0, tan, movers = polish_inputs(P, T, field, rng)
    refused = np.zeros(len(P), bool)
    polished = state()
    moves.polish(polished, movers, tangent=tan, refused=refused)
    P2 = polished.P
    assert np.all(signed_areas(P2, T) > 0)
    after, s2, b2, _ = total_deficit(P2, T, field)
    assert len(shares.failing(s2, b2, twin)[0]) <= len(h0)
    assert after <= before * (1 + 1e-9) + 1e-15
    moved = np.flatnonzero(np.any(P2 != P, axis=1))
    assert np.isin(moved, movers).all()
    assert np.array_equal(refused[movers], ~np.isin(movers, moved))
    assert np.all(star_worst(P2, T, field, moved) > star_worst(P, T, field, moved))
    sliding = np.flatnonzero(np.any(tan != 0, axis=1))
    assert np.array_equal(P2[sliding[P[sliding, 1] == 0], 1], np.zeros(2))
    assert np.array_equal(P2[sliding[P[sliding, 0] == 1], 0], np.ones(2))
    some = movers[rng.random(len(movers)) < 0.5]
    alone = state()
    moves.polish(alone, some, tangent=tan)
    assert np.array_equal(alone.P[some], P2[some])


FORMULA = ("1 + x**2 + sin(3*y)", "0.9*sin(4*x)*cos(3*y)", "1.2 + cos(2*x)")


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(30, 200), shape=st.booleans(),
       own=st.booleans())
def test_each_mover_is_judged_on_its_own(seed, n, shape, own):
    """The repair leaves out the movers it refused before (`_Judged`): that holds only if a
    mover's move and verdict do not depend on which other movers move with it. Half of the
    movers alone move exactly as they did among all of them, and are refused alike."""
    P, T = square_mesh(seed, n)
    rng = np.random.default_rng(seed)
    field = qmesh.TensorField.from_expressions(*FORMULA)
    metric = None if own else field_metric(field, 0.1, (np.zeros(2), np.ones(2)))
    twin = topology.twins(T)
    fixed = np.zeros(len(P), bool)
    fixed[:4] = True
    movers = moves.movers(T, twin, moves.free(T, twin, fixed, np.arange(len(P))), rng)
    all_refused, some_refused = np.zeros(len(P), bool), np.zeros(len(P), bool)
    every, part = RepairState.of(P, T, field, fixed=fixed), RepairState.of(P, T, field, fixed=fixed)
    moves.relax(every, metric, movers, shape=shape, refused=all_refused)
    some = movers[rng.random(len(movers)) < 0.5]
    moves.relax(part, metric, some, shape=shape, refused=some_refused)
    P_all, P_some = every.P, part.P
    assert np.array_equal(P_some[some], P_all[some])
    assert np.array_equal(some_refused[some], all_refused[some])
    assert np.array_equal(all_refused[movers], np.all(P_all[movers] == P[movers], axis=1))
    assert not np.any(some_refused[np.setdiff1d(np.arange(len(P)), some)])


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(30, 300), cells=st.integers(2, 12))
def test_flips_refused_once_are_refused_again(seed, n, cells):
    """The flips a round refused (not lowering their quadrilateral's deficit) change nothing
    when judged again on the same mesh, and leaving them out chooses the same flips."""
    P, T = square_mesh(seed, n)
    edges, k1, k2, angle = random_raster(seed, cells, 3.0)
    field = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    _, s, b, twin = total_deficit(P, T, field)
    h, _, _ = shares.failing(s, b, twin)
    state = RepairState.of(P, T, field)
    refused = np.zeros(len(twin), bool)
    done = flips.mending_flips(state, h, refused=refused)
    assert not refused[done].any()
    again = np.zeros(len(twin), bool)
    assert not len(flips.mending_flips(state, h[refused[h]], refused=again))
    assert again[h[refused[h]]].all()
    assert np.array_equal(flips.mending_flips(state, h[~refused[h]]), done)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(10, 100))
def test_a_change_forgets_what_was_judged_on_it(seed, n):
    """`_Judged.forget(t)`: the flips of the edges of t and of the triangles beside it (both
    half-edges) and the moves of their corners are judged again; nothing else is."""
    P, T = square_mesh(seed, n)
    twin = topology.twins(T)
    rng = np.random.default_rng(seed)
    seen = moves.Judged(len(P), len(T))
    seen.vertices[:] = True
    seen.edges[:] = True
    t = rng.choice(len(T), min(3, len(T)), replace=False)
    seen.forget(T, twin, t)
    near = set(t.tolist())
    for x in t:
        near |= {int(g) // 3 for g in twin[3 * x:3 * x + 3] if g >= 0}
    near = np.array(sorted(near))
    he = (3 * near[:, None] + np.arange(3)).ravel()
    he = np.union1d(he, twin[he][twin[he] >= 0])
    assert np.array_equal(np.flatnonzero(~seen.edges), he)
    assert np.array_equal(np.flatnonzero(~seen.vertices), np.unique(T[near]))


def test_the_worst_slack_the_warning_prints_stays_within_one_in_size():
    """An edge failing by its means' error bound alone (bound 1e9 × its shares) reports a slack
    of about −1, not −1e9: q_ij − bound over Σ|q_ij^T| + bound, as q_ij / Σ|q_ij^T| is bounded."""
    twin = np.array([1, 0, -1])                 # one interior edge (half-edges 0, 1), one boundary
    s = np.array([0.5, -1.0, 2.0])
    b = np.array([1e9, 0.0, 0.0])
    h, q, slack = shares.failing(s, b, twin, slack=True)
    assert list(h) == [0] and q[0] == -0.5
    assert np.all(np.abs(slack) <= 1) and slack.min() == pytest.approx(-1.0, rel=1e-8)
    assert slack.max() == 1.0                   # the boundary edge: 2 / 2


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(30, 150))
def test_the_polish_asks_adaptive_means_for_one_try_a_mover(seed, n):
    """The polish judges its tries on rough means and asks the field's adaptive means only for
    the try each mover would take (not for every try, which was most of a callable field's run);
    what it keeps still breaks no edge and raises its star's worst quality on the adaptive
    means."""
    from qmesh.fields.cache import ElementMeans

    class Counted(ElementMeans):
        asked = {"means_with_error": 0, "rough": 0}

        def means_with_error(self, P, T):
            self.asked["means_with_error"] += len(T)
            return super().means_with_error(P, T)

        def rough(self, P, T):
            self.asked["rough"] += len(T)
            return super().rough(P, T)

    rng = np.random.default_rng(seed)
    P, T = square_mesh(seed, n)
    field = qmesh.TensorField.from_expressions(*FORMULA)
    before, state, twin, h0, tan, movers = polish_inputs(P, T, field, rng)
    polished = state()
    counted = polished.field = Counted(field)     # the means the polish asks for, counted
    moves.polish(polished, movers, tangent=tan)
    P2 = polished.P
    stars = int(topology.touching(T, np.isin(np.arange(len(P)), movers)).sum())
    tries = len(moves.STEPS) + moves.PATTERN * len(moves.REACH)
    assert 0 < counted.asked["rough"] <= tries * stars   # tries refused on geometry: not asked
    assert counted.asked["means_with_error"] <= stars
    after, s2, b2, _ = total_deficit(P2, T, field)
    assert len(shares.failing(s2, b2, twin)[0]) <= len(h0)
    assert after <= before * (1 + 1e-9) + 1e-15
    moved = np.flatnonzero(np.any(P2 != P, axis=1))
    assert np.all(star_worst(P2, T, field, moved) > star_worst(P, T, field, moved))
