"""The guide's two problems (examples/solve_problems.py) as each FEM code gets them: `translate`
rebuilds u and f from a code's own operations with the values of the NumPy functions scikit-fem
and MODFLOW 6 use, and the strata's piecewise-linear u solves its problem exactly."""

import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings, strategies as st

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))
import solve_problems  # noqa: E402

PROBLEMS = {name: getattr(solve_problems, name)() for name in ("fvca5", "strata")}
NUMPY = {"sin": np.sin, "cos": np.cos}


def where(t, a, b):
    return np.where(t > 0, a, b)


@settings(max_examples=30, deadline=None)
@given(name=st.sampled_from(sorted(PROBLEMS)), seed=st.integers(0, 2**32 - 1), n=st.integers(1, 50))
def test_translate_gives_the_values_of_the_numpy_functions(name, seed, n):
    """Rebuilt from NumPy's operations (as NGSolve's and UFL's), u and f take the values of the
    lambdified expressions at any point of the open square."""
    problem = PROBLEMS[name]
    x, y = np.random.default_rng(seed).uniform(1e-6, 1 - 1e-6, (2, n))
    for expr, f in ((problem.u_expr, problem.u), (problem.f_expr, problem.f)):
        np.testing.assert_allclose(solve_problems.translate(expr, x, y, NUMPY, where) + 0 * x, f(x, y),
                                   rtol=1e-12, atol=1e-12 * np.abs(f(x, y)).max(initial=1))


def test_translate_names_what_it_cannot_rebuild():
    X, Y = solve_problems.X, solve_problems.Y
    with pytest.raises(ValueError, match="exp"):
        solve_problems.translate(sp.exp(X), 0.5, 0.5, NUMPY, where)
    with pytest.raises(ValueError, match="Piecewise condition"):
        solve_problems.translate(sp.Piecewise((X, sp.Eq(X, Y)), (Y, True)), 0.5, 0.5, NUMPY, where)


def test_the_strata_solution_is_exact():
    """u(0) = 1, u(1) = 0, continuous at the columns' edges, and Q11 u' the same in every column
    (div(Q∇u) = ∂x(Q11 u') = 0 for u = u(x) and Q = Q(x))."""
    problem = PROBLEMS["strata"]
    edges = np.linspace(0, 1, 9)
    y = np.full(9, 0.37)
    np.testing.assert_allclose(problem.u(edges[[0, -1]], y[:2]), [1, 0], atol=1e-14)
    left, right = problem.u(edges[1:-1] - 1e-12, y[1:-1]), problem.u(edges[1:-1] + 1e-12, y[1:-1])
    np.testing.assert_allclose(left, right, atol=1e-9)
    middle = (edges[:-1] + edges[1:]) / 2
    slope = sp.lambdify(solve_problems.X, problem.u_expr.diff(solve_problems.X), "numpy")(middle)
    q11 = problem.field(np.column_stack([middle, y[:8]]))[:, 0, 0]
    flux = q11 * slope
    assert np.all(slope < 0) and np.ptp(flux) <= 1e-12 * np.abs(flux).max()
    assert not np.allclose(slope, slope[0], rtol=0.1)          # the columns differ: u has kinks
