"""Element means whose error bound a jump or a narrow bump cannot fool (FIELDS.md §2–3).

A text formula's means carry a bound proven by interval enclosures (`conductivity.intervals`):
checked here against means by exact clipping along a known jump line and against a bump's
integral in closed form; a callable's means say how finely they sampled it."""

import math

import numpy as np
import pytest
import sympy as sp
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.conductivity import intervals
from qmesh.conductivity import means as _m
from qmesh.conductivity.expression import _to_sympy, check
from qmesh.errors import QmeshError

# ----------------------------------------------------------------------- the interval evaluator

_leaves = st.one_of(st.just("x"), st.just("y"),
                    st.floats(-2, 2, allow_nan=False).map(lambda v: f"{v:.6g}"))
_UNARY = ["exp(sin({}))", "log(2 + cos({}))", "sqrt(1 + ({})**2)", "tan(0.5*sin({}))", "sinh({})",
          "cosh(sin({}))", "tanh({})", "atan({})", "abs({})", "log1p(1 + sin({}))", "({})**3",
          "({})**2", "sqrt(abs({}))", "({})**(-2)"]
_BINARY = ["({}) + ({})", "({}) - ({})", "({})*({})", "({})/(1.5 + cos({}))", "({})/({})"]


def _grow(children):
    return st.one_of(st.builds(lambda f, a: f.format(a), st.sampled_from(_UNARY), children),
                     st.builds(lambda f, a, b: f.format(a, b), st.sampled_from(_BINARY), children,
                               children))


expressions = st.recursive(_leaves, _grow, max_leaves=5)


def _checked(text):
    try:
        return check(text, "f(x, y)")
    except QmeshError:                   # nested too deep or folded out of range: not a case
        assume(False)


def _derivatives(form):
    """The value, gradient, Hessian and third derivatives of a checked form, by SymPy:
    independent of `intervals`."""
    f, x, y = _to_sympy(form)
    parts = taylor_parts(f, x, y)
    # abs'' is a Dirac mass at the kink, sign' too: 0 at every point a random draw can hit
    parts = [p.replace(sp.DiracDelta, lambda *a: sp.Integer(0))
             .replace(lambda e: isinstance(e, sp.Derivative), lambda e: sp.Integer(0)) for p in parts]
    exp = {"qmesh_exp": np.exp}          # the parser's whole eᵘ (`expression._whole_exp`)
    return [sp.lambdify((x, y), p, [exp, "numpy"]) for p in parts]


@settings(max_examples=50, deadline=None)
@given(text=expressions, seed=st.integers(0, 2**32 - 1))
def test_the_enclosure_holds_the_value_and_derivatives_at_every_point_of_the_box(text, seed):
    form = _checked(text)
    rng = np.random.default_rng(seed)
    k = 8
    centre = rng.uniform(-1, 1, (k, 2))
    half = 10.0 ** rng.uniform(-6, -0.3, (k, 2))
    X, Y = (centre[:, 0] - half[:, 0], centre[:, 0] + half[:, 0]), (centre[:, 1] - half[:, 1],
                                                                     centre[:, 1] + half[:, 1])
    assert_enclosed(intervals.evaluate(form, X, Y), _derivatives(form), centre, half, rng, text)


def taylor_parts(f, x, y):
    """f's derivatives in the order of `intervals.DERIVATIVES`, each from the one before."""
    d = {(0, 0): f}
    for i, j in intervals.DERIVATIVES[1:]:
        d[(i, j)] = sp.diff(d[(i, j - 1)], y) if j else sp.diff(d[(i - 1, j)], x)
    return [d[k] for k in intervals.DERIVATIVES]


def assert_enclosed(node, funcs, centre, half, rng, label, draws=6):
    """Each of `funcs` (value, gradient, Hessian, third derivatives) at random points of the
    boxes centre ± half lies in its enclosure in `node`, but for the reference's own round-off
    (SymPy's order of operations: a relative 1e-9)."""
    k = len(centre)
    assert len(node) == len(funcs) == len(intervals.DERIVATIVES)
    for _ in range(draws):
        u = rng.uniform(-1, 1, (k, 2))
        px, py = centre[:, 0] + u[:, 0] * half[:, 0], centre[:, 1] + u[:, 1] * half[:, 1]
        for (lo, hi), f in zip(node, funcs):
            with np.errstate(all="ignore"):
                v = np.broadcast_to(np.asarray(f(px, py), dtype=float), (k,))
            ok = np.isfinite(v)
            slack = 1e-9 * (1 + np.abs(v))
            assert np.all(lo[ok] <= v[ok] + slack[ok]), (label, lo[ok], v[ok])
            assert np.all(v[ok] - slack[ok] <= hi[ok]), (label, v[ok], hi[ok])


def test_a_division_by_an_interval_holding_zero_is_unbounded_and_a_sign_is_not():
    X, Y = (np.array([-0.1]), np.array([0.1])), (np.array([0.0]), np.array([1.0]))
    (lo, hi), *_ = intervals.evaluate(check("1/x", "f"), X, Y)
    assert lo[0] == -math.inf and hi[0] == math.inf
    (lo, hi), gx, *_ = intervals.evaluate(check("45 - 45*abs(x)/x", "f"), X, Y)
    assert lo[0] >= -1e-12 and hi[0] <= 90 + 1e-12          # the value of a jump: bounded
    assert gx[0][0] == -math.inf and gx[1][0] == math.inf      # its slope: not


# ----------------------------------------------------------------------- a jump along a line

def _jump_field():
    return qmesh.TensorField.principal(100, 1, "45 - 45*abs(x + 0.3*y - 0.537)/(x + 0.3*y - 0.537)")


def _share_below(P, T, a, b, c):
    """The share of each triangle (k, 3) over P where a x + b y < c: exact clipping by the line,
    the cut-off corner a triangle similar to the part beyond it (NumPy, no geometry library)."""
    u = P[T] @ np.array([a, b]) - c                                      # (k, 3)
    neg = u < 0
    n = neg.sum(axis=1)

    def corner(mask):       # the share of the corner alone on its side (exactly one vertex)
        i = np.argmax(mask, axis=1)
        ui = u[np.arange(len(u)), i]
        uj, uk = u[np.arange(len(u)), (i + 1) % 3], u[np.arange(len(u)), (i + 2) % 3]
        with np.errstate(all="ignore"):
            return ui * ui / ((ui - uj) * (ui - uk))

    return np.select([n == 0, n == 3, n == 1, n == 2], [0.0, 1.0, corner(neg), 1.0 - corner(~neg)])


def _exact_jump_means(P, T):
    """Q̄_T of the jump field: diag(1, 100) below the line (the angle 90°), diag(100, 1) above."""
    w = _share_below(P, T, 1.0, 0.3, 0.537)[:, None, None]
    return w * np.diag([1.0, 100.0]) + (1 - w) * np.diag([100.0, 1.0])


def _relative_q(P, T, Q):
    """q_ij / Σ_T |q_ij^T| of every interior edge, assembled here from the P1 gradients."""
    X = P[T]
    area = 0.5 * ((X[:, 1, 0] - X[:, 0, 0]) * (X[:, 2, 1] - X[:, 0, 1])
                  - (X[:, 1, 1] - X[:, 0, 1]) * (X[:, 2, 0] - X[:, 0, 0]))
    E = X[:, [2, 0, 1]] - X[:, [1, 2, 0]]                       # edge opposite corner i
    G = np.stack([E[..., 1], -E[..., 0]], axis=-1) / (2 * area[:, None, None])   # ∇φ_i (up to sign)
    q, scale = {}, {}
    for i, j in ((0, 1), (1, 2), (2, 0)):
        share = -area * np.einsum("ki,kij,kj->k", G[:, i], Q, G[:, j])
        for t in range(len(T)):
            key = tuple(sorted((int(T[t, i]), int(T[t, j]))))
            q[key] = q.get(key, 0.0) + share[t]
            scale[key] = scale.get(key, 0.0) + abs(share[t])
    count = {}
    for t in range(len(T)):
        for i, j in ((0, 1), (1, 2), (2, 0)):
            key = tuple(sorted((int(T[t, i]), int(T[t, j]))))
            count[key] = count.get(key, 0) + 1
    return np.array([q[k] / scale[k] for k in q if count[k] == 2])


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), size=st.floats(1e-3, 0.3))
def test_a_triangle_across_the_jump_has_its_exact_mean_within_the_bound(seed, size):
    rng = np.random.default_rng(seed)
    on = np.array([0.537, 0.0]) + rng.uniform(0, 1) * np.array([-0.3, 1.0])   # on the line
    P = on + size * rng.uniform(-1, 1, (3, 2))
    u, v = P[1] - P[0], P[2] - P[0]
    assume(abs(u[0] * v[1] - u[1] * v[0]) > 1e-3 * size ** 2)
    T = np.array([[0, 1, 2]])
    Q, err = _jump_field().means_with_error(P, T)
    exact = _exact_jump_means(P, T)
    assert np.linalg.norm(Q[0] - exact[0]) <= err[0] * (1 + 1e-9) + 1e-12 * 100


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), size=st.floats(1e-3, 0.3))
def test_the_cheap_means_of_a_triangle_across_the_jump_are_within_its_enclosure_errors(seed, size):
    """The repair's means (the rule's estimate, no proof: `bound_rtol=None`) proven afterwards by
    the enclosures of the triangle's 4 children alone (`enclosure_errors`), as the lazy proof
    does: the exact mean is within that bound."""
    rng = np.random.default_rng(seed)
    on = np.array([0.537, 0.0]) + rng.uniform(0, 1) * np.array([-0.3, 1.0])
    P = on + size * rng.uniform(-1, 1, (3, 2))
    u, v = P[1] - P[0], P[2] - P[0]
    assume(abs(u[0] * v[1] - u[1] * v[0]) > 1e-3 * size ** 2)
    T = np.array([[0, 1, 2]])
    F = _jump_field()
    Q, estimate = F.means_with_error(P, T, rtol=1e-6, bound_rtol=None)
    proven = F.enclosure_errors(P, T)
    gap = np.linalg.norm(Q[0] - _exact_jump_means(P, T)[0])
    assert gap <= proven[0] * (1 + 1e-9) + 1e-12 * 100


@pytest.mark.slow
@pytest.mark.parametrize("n", [500, 1500, 2000])
def test_the_jump_meshed_passes_on_every_interior_edge_with_the_exact_means(n):
    """Means blind to the jump certified an edge whose exact q_ij / Σ|q_ij^T| is −0.10 at 500
    vertices, −0.886 at 1 500 and −0.65 at 2 000."""
    m = qmesh.mesh(qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]), _jump_field(),
                   target_vertices=n)
    P, T = np.asarray(m.points), np.asarray(m.triangles)
    r = _relative_q(P, T, _exact_jump_means(P, T))
    assert len(r) > 2 * n
    assert r.min() >= -1e-9, r.min()


@pytest.mark.parametrize("k1, k2, angle", [(10, 1, "30*x"), (3, 1, "20*sin(2*x + y)"),
                                           (100, 1, "30*x")])
def test_a_smooth_text_is_proven_lazily_and_meshed_as_its_samples_are(k1, k2, angle, monkeypatch):
    """The proof changes nothing where the rule's means already pass: a smooth text gives the
    vertices and triangles of the same Q given as a callable (never proven), with at most 1% of
    its triangles' bounds refined beyond their children's enclosures."""
    from qmesh.fields import cache
    refined = []
    refine = cache.ElementMeans.refine
    monkeypatch.setattr(cache.ElementMeans, "refine",
                        lambda self, P, T, r: refined.append(len(T)) or refine(self, P, T, r))
    F = qmesh.TensorField.principal(k1, k2, angle)
    twin = qmesh.TensorField(lambda x, y: F(np.column_stack([np.ravel(x), np.ravel(y)]))
                             .reshape(np.shape(x) + (2, 2)))
    square = qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])
    m = qmesh.mesh(square, F, target_vertices=300)
    assert sum(refined) <= 0.01 * len(m.triangles)
    refined.clear()
    g = qmesh.mesh(square, twin, target_vertices=300)
    assert not refined                                    # a callable is never proven
    assert np.array_equal(m.points, g.points) and np.array_equal(m.triangles, g.triangles)
    assert np.allclose(m.conductivity, g.conductivity, rtol=0, atol=1e-10 * k1)


# ----------------------------------------------------------------------- a bump between samples

BUMP = (0.16, 0.335)        # 0.125 from every sample of the rule and of its 4 children
WIDTH = 1e-4                # exp(-r²/WIDTH): a bump about 0.01 wide, of integral π·WIDTH
TRIANGLE = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])


def _bump_text():
    return f"1 + 100*exp(-((x - {BUMP[0]})**2 + (y - {BUMP[1]})**2)/{WIDTH})"


def _bump_mean():
    """In closed form: the bump lies ≥ 16 widths inside the triangle (its tail beyond is < e^-256)."""
    return 1 + 100 * math.pi * WIDTH / 0.5


def test_a_narrow_bump_inside_a_triangle_is_within_the_stated_bound():
    F = qmesh.TensorField.from_expressions(_bump_text(), 0, 1)
    Q, err = F.means_with_error(TRIANGLE, [[0, 1, 2]])
    truth = _bump_mean()
    assert truth - 1 > 0.06                                  # a bump that matters
    assert abs(Q[0, 0, 0] - truth) <= err[0] < truth - 1      # proven, and narrower than the bump
    assert abs(Q[0, 0, 0] - truth) < 1e-8 * truth            # found: the samples resolve it


def _bump_callable(x, y):
    x, y = np.asarray(x, float), np.asarray(y, float)
    q = 1 + 100 * np.exp(-((x - BUMP[0]) ** 2 + (y - BUMP[1]) ** 2) / WIDTH)
    out = np.zeros(x.shape + (2, 2))
    out[..., 0, 0], out[..., 1, 1] = q, 1.0
    return out


def test_a_callable_misses_the_bump_at_its_default_sampling_and_says_how_coarse_it_is():
    F = qmesh.TensorField(_bump_callable)
    Q, err = F.means_with_error(TRIANGLE, [[0, 1, 2]])
    assert abs(Q[0, 0, 0] - _bump_mean()) > 10 * err[0]     # what sampling cannot promise
    assert F.sampled_at(TRIANGLE, [[0, 1, 2]]) == pytest.approx(math.sqrt(2) / 2)


def test_a_callable_sampled_finely_enough_sees_the_bump():
    F = qmesh.TensorField(_bump_callable, resolution=0.02)
    Q, err = F.means_with_error(TRIANGLE, [[0, 1, 2]])
    assert abs(Q[0, 0, 0] - _bump_mean()) < 1e-6 * _bump_mean()
    assert F.sampled_at(TRIANGLE, [[0, 1, 2]]) == 0.02


@pytest.mark.parametrize("bad", [0, -1.0, float("nan"), float("inf"), "0.1", True])
def test_a_resolution_is_a_finite_length(bad):
    with pytest.raises(QmeshError, match="resolution"):
        qmesh.TensorField(_bump_callable, resolution=bad)


# ----------------------------------------------------------------------- what a mesh says

def _two_tensors(x, y):
    """Two 1000 : 1 tensors across the line x = 0.5 (np.where: no text, nothing to bound)."""
    x = np.asarray(x, float)
    out = np.zeros(x.shape + (2, 2))
    left = x < 0.5
    out[..., 0, 0] = np.where(left, 1000.0, 1.0)
    out[..., 1, 1] = np.where(left, 1.0, 1000.0)
    return out


def test_a_callable_mesh_and_its_report_say_at_what_resolution_the_means_were_sampled():
    F = qmesh.TensorField(_two_tensors)
    m = qmesh.mesh(qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]), F, target_vertices=300)
    h = F.sampled_at(m.points, m.triangles)
    assert h is not None and h > 0
    assert m.means_sampled_at == h
    assert qmesh.measure.report(m, laplacian=False)["means_sampled_at"] == h
    assert qmesh.measure.report(m, F, laplacian=False)["means_sampled_at"] == h


def test_a_text_field_mesh_says_nothing_was_sampled():
    F = qmesh.TensorField.principal(10, 1, "30*x")
    m = qmesh.mesh(qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]), F, target_vertices=300)
    assert F.means_bounded and m.means_sampled_at is None
    assert "means_sampled_at" not in qmesh.measure.report(m, laplacian=False)


def test_the_enclosure_bound_of_a_linear_field_is_round_off():
    bound = _m.enclosure_bound([check("1 + x + 2*y", "q"), ("num", 0.0), ("num", 1.0)])
    A, B, C = (np.array([p]) for p in TRIANGLE)
    assert bound(A, B, C)[0] < 1e-12
