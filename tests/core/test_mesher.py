"""Algorithm 2.1 end to end: invariants of every produced mesh, the Step history, and convergence.

Each case is meshed once per seed (cached for the module); the invariants are checked on the
final mesh of every case. The interpolation errors must fall at the P1 rates on refinement:
‖e_s‖_L2 ~ N⁻¹ and |e_s|_h1 ~ N^-½ (MATH.md "Interpolation error").
"""

import inspect
from functools import lru_cache

import numpy as np
import pytest

import qmesh
from cases import exp_plus_y2, locally_regular
from qmesh import QmeshError, measure
from qmesh.geometry import topology
from qmesh.geometry.triangles import signed_areas
from qmesh.measure import edge_weights, interpolation_errors




def rotating(eps: float = 0.05) -> qmesh.Anisotropy:
    """s = |x|⁴/4 + eps|x|²/2: ∇²s = (|x|² + eps) I + 2 x xᵀ, whose stiff axis is radial.

    The principal direction turns with the polar angle; the ratio grows to 2.9 at |x| = 1.
    """
    def s(P):
        r2 = np.einsum("ni,ni->n", P, P)
        return r2 ** 2 / 4 + eps * r2 / 2

    def grad(P):
        r2 = np.einsum("ni,ni->n", P, P)
        return (r2 + eps)[:, None] * P

    def hessian(P):
        r2 = np.einsum("ni,ni->n", P, P)
        return (r2 + eps)[:, None, None] * np.eye(2) + 2 * P[:, :, None] * P[:, None, :]

    return qmesh.Anisotropy.from_s(s, grad, hessian, label="|x|^4/4 + eps |x|^2/2")


def hexagon() -> qmesh.Polygon:
    """A convex, irregular hexagon."""
    t = np.deg2rad([0.0, 50.0, 110.0, 180.0, 235.0, 300.0])
    return qmesh.Polygon(np.column_stack([1.5 * np.cos(t), np.sin(t)]))


def chapter() -> qmesh.Anisotropy:
    return qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)


# name: (domain, anisotropy, options)
CASES = {
    "chapter-vb32": (lambda: qmesh.Disk(32), chapter, {"target_vertices": 101}),
    "chapter-vb64": (lambda: qmesh.Disk(64), chapter, {"target_vertices": 212}),
    "rotated-hexagon": (hexagon, lambda: qmesh.Anisotropy.principal(1, 50, 30),
                        {"target_vertices": 150}),
    "size-mode": (lambda: qmesh.Disk(32), chapter, {"size": 0.15}),
    "exp-plus-y2": (lambda: qmesh.Disk(32), exp_plus_y2, {"target_vertices": 150}),
    "rotating": (lambda: qmesh.Disk(32), rotating, {"target_vertices": 150}),
}
CONSTANT = {"chapter-vb32", "chapter-vb64", "rotated-hexagon", "size-mode"}
MAX_ITERATIONS = inspect.signature(qmesh.iterate).parameters["max_iterations"].default
TARGETED = [name for name, case in CASES.items() if "target_vertices" in case[2]]


@lru_cache(maxsize=None)
def history(name: str, seed: int = 0) -> tuple:
    """Every Step of one run (domain, anisotropy and steps), computed once per (case, seed)."""
    make_domain, make_anisotropy, options = CASES[name]
    domain, A = make_domain(), make_anisotropy()
    return domain, A, tuple(qmesh.iterate(domain, A, seed=seed, **options))


def final(name: str, seed: int = 0):
    domain, A, steps = history(name, seed)
    return domain, A, steps[-1].mesh


def edges_with_counts(T):
    e = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0, return_counts=True)


# --------------------------------------------------------------------------- invariants

@pytest.mark.parametrize("name", CASES)
def test_no_inverted_or_degenerate_triangle(name):
    domain, _, m = final(name)
    area = signed_areas(m.points, m.triangles)
    assert len(area) > 0
    assert area.min() > 1e-12 * domain.area


@pytest.mark.parametrize("name", CASES)
def test_seed_points_present_exactly_and_fixed(name):
    domain, _, m = final(name)
    index = {tuple(p): i for i, p in enumerate(m.points.tolist())}
    seeds = [tuple(p) for p in domain.seeds.tolist()]
    missing = [p for p in seeds if p not in index]
    assert not missing, f"seed points not at their exact coordinates: {missing}"
    where = np.array([index[p] for p in seeds])
    assert np.all(m.fixed[where])
    assert m.fixed.sum() == len(seeds)
    used = np.zeros(m.n_vertices, bool)
    used[m.triangles.ravel()] = True
    assert used.all(), "every point must be a vertex of some triangle"


@pytest.mark.parametrize("name", CASES)
def test_points_inside_and_boundary_on_the_polygon(name):
    domain, _, m = final(name)
    assert np.all(domain.contains(m.points))
    assert np.all(domain.edge_of(m.points[m.boundary]) >= 0)
    assert np.all(domain.edge_of(m.points[~m.boundary], tol=1e-6) == -1)


@pytest.mark.parametrize("name", CASES)
def test_edges_manifold_and_domain_covered(name):
    domain, _, m = final(name)
    _, counts = edges_with_counts(m.triangles)
    assert counts.max() <= 2
    twin = topology.twins(m.triangles)          # raises on inconsistent orientation
    assert (twin < 0).sum() == (counts == 1).sum()
    total = signed_areas(m.points, m.triangles).sum()
    assert total == pytest.approx(domain.area, rel=1e-9)
    # Euler: a triangulated disk has V − E + F = 1
    assert m.n_vertices - len(counts) + m.n_triangles == 1


@pytest.mark.parametrize("name", CASES)
def test_final_mesh_is_q_delaunay(name):
    """Constant Q: every interior q_ij ≥ 0. Varying s: every interior edge locally regular."""
    _, A, m = final(name)
    if name in CONSTANT:
        _, q, interior = edge_weights(m, A)
        assert (q[interior] / np.abs(q).max()).min() >= -1e-9
    else:
        margin = locally_regular(m.points, m.triangles, A)
        assert margin.min() >= -1e-9


@pytest.mark.parametrize("name", CASES)
def test_same_seed_same_mesh_different_seed_different_mesh(name):
    make_domain, make_anisotropy, options = CASES[name]
    _, _, m0 = final(name, 0)
    again = qmesh.mesh(make_domain(), make_anisotropy(), seed=0, **options)
    np.testing.assert_array_equal(again.points, m0.points)
    np.testing.assert_array_equal(again.triangles, m0.triangles)
    np.testing.assert_array_equal(again.fixed, m0.fixed)
    _, _, m1 = final(name, 1)
    assert m1.points.shape != m0.points.shape or not np.array_equal(m1.points, m0.points)


@pytest.mark.parametrize("name", TARGETED)
def test_target_vertices_within_ten_percent(name):
    target = CASES[name][2]["target_vertices"]
    for seed in (0, 1):
        _, _, m = final(name, seed)
        assert abs(m.n_vertices - target) <= 0.1 * target


def test_size_mode_sets_the_metric_edge_length():
    """`size` is the target metric edge length: the median metric edge length is near it."""
    domain, A, m = final("size-mode")
    h = CASES["size-mode"][2]["size"]
    E, _ = edges_with_counts(m.triangles)
    d = m.points[E[:, 0]] - m.points[E[:, 1]]
    lengths = np.sqrt(np.einsum("ni,ij,nj->n", d, A.H, d))
    assert 0.75 * h <= np.median(lengths) <= 1.25 * h
    coarser = qmesh.mesh(domain, A, size=2 * h)
    assert coarser.n_vertices < m.n_vertices


@pytest.mark.parametrize("name", ["chapter-vb32", "exp-plus-y2"])
def test_mesh_returns_the_last_step_of_iterate(name):
    make_domain, make_anisotropy, options = CASES[name]
    _, _, steps = history(name)
    m = qmesh.mesh(make_domain(), make_anisotropy(), seed=0, **options)
    np.testing.assert_array_equal(m.points, steps[-1].mesh.points)
    np.testing.assert_array_equal(m.triangles, steps[-1].mesh.triangles)


# --------------------------------------------------------------------------- the Step history

@pytest.mark.parametrize("name", CASES)
def test_step_sequence(name):
    _, _, steps = history(name)
    stages = [s.stage for s in steps]
    assert stages[0] == "triangulate" and steps[0].iteration == 0
    rest = stages[1:]
    assert len(rest) > 0 and len(rest) % 3 == 0
    assert rest == ["adjust", "insert", "triangulate"] * (len(rest) // 3)
    iterations = [s.iteration for s in steps[1:]]
    assert iterations == [k for k in range(1, len(rest) // 3 + 1) for _ in range(3)]
    # only the last step may say it converged, and it does unless the cap was hit
    assert not any(s.converged for s in steps[:-1])
    assert steps[-1].converged or steps[-1].iteration == MAX_ITERATIONS
    for s in steps:
        assert s.stats.n_vertices == s.mesh.n_vertices
        assert s.stats.n_triangles == s.mesh.n_triangles


@pytest.mark.parametrize("name", CASES)
def test_insert_steps_add_new_vertices(name):
    _, _, steps = history(name)
    total = 0
    for prev, step in zip(steps, steps[1:]):
        if step.stage != "insert":
            continue
        n0, n1 = prev.mesh.n_vertices, step.mesh.n_vertices
        # new vertices are appended; a relocated vertex (degree 3, moved to a large
        # triangle) keeps its index and is reported as added too
        new = step.added[step.added >= n0]
        relocated = step.added[step.added < n0]
        np.testing.assert_array_equal(new, np.arange(n0, n1))
        assert step.stats.added == len(step.added)
        stay = np.setdiff1d(np.arange(n0), relocated)
        np.testing.assert_array_equal(step.mesh.points[stay], prev.mesh.points[stay])
        assert not (step.mesh.points[relocated] == prev.mesh.points[relocated]).all(axis=1).any()
        assert not prev.mesh.boundary[relocated].any()
        assert not step.mesh.fixed[n0:].any()
        total += n1 - n0
    # the triangulate stages add the splits of encroached boundary subsegments (conform.py)
    split = sum(len(s.added) for s in steps[1:] if s.stage == "triangulate")
    assert total + split == steps[-1].mesh.n_vertices - steps[0].mesh.n_vertices


@pytest.mark.parametrize("name", CASES)
def test_adjust_steps_report_their_moves(name):
    _, _, steps = history(name)
    for prev, step in zip(steps, steps[1:]):
        if step.stage != "adjust":
            continue
        moved = step.mesh.points - prev.mesh.points
        assert step.moved.shape == moved.shape
        np.testing.assert_allclose(step.moved, moved, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(moved[step.mesh.fixed], 0.0)
        np.testing.assert_array_equal(step.mesh.fixed, prev.mesh.fixed)


@pytest.mark.parametrize("name", CASES)
def test_history_shares_arrays(name):
    """An adjust step keeps the triangles of the step before; a triangulate step keeps its points.

    The one exception: an adjust step that put vertices onto the boundary removed the
    triangles between them and the boundary, so its triangles are a strict subset of the
    previous ones and must be a new array.
    """
    _, _, steps = history(name)
    shared = 0
    for prev, step in zip(steps, steps[1:]):
        if step.stage == "adjust":
            if step.mesh.triangles is prev.mesh.triangles:
                shared += 1
            else:
                old, new = prev.mesh.triangles, step.mesh.triangles
                assert len(new) < len(old)
                rows = {tuple(r) for r in old.tolist()}
                assert all(tuple(r) in rows for r in new.tolist())
        elif step.stage == "triangulate" and not len(step.added) and step.moved is None:
            assert step.mesh.points is prev.mesh.points     # no split, no vertex pushed out
        assert not step.mesh.points.flags.writeable
        assert not step.mesh.triangles.flags.writeable
    assert shared > 0


def test_holding_the_history_is_cheap():
    """Shared arrays: the history costs well under one full copy per step."""
    _, _, steps = history("chapter-vb64")
    seen, nbytes = set(), 0
    for s in steps:
        for a in (s.mesh.points, s.mesh.triangles, s.mesh.fixed):
            if id(a) not in seen:
                seen.add(id(a))
                nbytes += a.nbytes
    last = steps[-1].mesh
    full = last.points.nbytes + last.triangles.nbytes + last.fixed.nbytes
    assert nbytes < 0.75 * len(steps) * full


# --------------------------------------------------------------------------- convergence rates

def test_interpolation_error_rates_on_refinement():
    """The chapter's case at N = 200, 800, 3200: L2 slope −1, h1 slope −½ in N (±0.2)."""
    A = chapter()
    N, l2, h1 = [], [], []
    for n in (200, 800, 3200):
        m = qmesh.mesh(qmesh.Disk(32), A, target_vertices=n, seed=0)
        e = interpolation_errors(m, A)
        N.append(m.n_vertices)
        l2.append(e[0])
        h1.append(e[1])
    slope_l2 = np.polyfit(np.log(N), np.log(l2), 1)[0]
    slope_h1 = np.polyfit(np.log(N), np.log(h1), 1)[0]
    assert slope_l2 == pytest.approx(-1.0, abs=0.2)
    assert slope_h1 == pytest.approx(-0.5, abs=0.2)


@pytest.mark.parametrize("vb, n", [(32, 40), (64, 70), (64, 80)])
def test_targets_just_above_the_seed_count(vb, n):
    """When the boundary alone nearly fills the target, the mesh lands within 10% and is valid."""
    A = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    m = qmesh.mesh(qmesh.Disk(vb), A, target_vertices=n)
    assert n <= m.n_vertices <= 1.1 * n
    assert (signed_areas(m.points, m.triangles) > 0).all()
    assert m.fixed.sum() == vb
    assert measure.q_nonnegative_fraction(m, A) == 1.0


def test_too_few_vertices_for_a_conforming_boundary_is_an_error():
    """Disk(32) in the chapter's metric is ten times longer than wide: with one interior vertex,
    boundary triangles reach across it with obtuse metric angles; keeping q_ij ≥ 0 needs splits."""
    with pytest.raises(QmeshError, match=r"target_vertices = 33 is too few.*ask for at least \d+"):
        qmesh.mesh(qmesh.Disk(32), qmesh.Anisotropy.constant(qmesh.CHAPTER_Q), target_vertices=33)


@pytest.mark.parametrize("vb, n", [(32, 101), (64, 212)])
def test_without_boundary_refinement_only_the_seeds_are_on_the_boundary(vb, n):
    """Besides the seeds, only the few splits that keep boundary q_ij ≥ 0 (interior vertices that
    encroach are pushed out of the diametral ellipse first)."""
    A = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    m = qmesh.mesh(qmesh.Disk(vb), A, target_vertices=n, boundary_refinement=False)
    assert n <= m.n_vertices <= 1.1 * n
    assert m.boundary.sum() < 2 * vb
    assert np.all(m.boundary[m.fixed])
    _, q, interior = edge_weights(m, A)
    assert (q / np.abs(q).max()).min() >= -1e-9          # boundary edges included
    assert (signed_areas(m.points, m.triangles) > 0).all()
