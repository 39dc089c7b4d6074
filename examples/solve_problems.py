"""The two problems of the guide's "From conductivity to solution", and scikit-fem's solve of them.

−div(Q∇u) = f on the unit square (sides tagged bottom, right, top, left), u = its exact value on
the whole boundary:
- `fvca5`: FVCA5 test 5, Q turning about the corner (0, 0) at δ = 1e-3, u = sin πx sin πy,
  f = −div(Q∇u) derived by SymPy (the page's recipe);
- `strata`: a raster TensorField of 8 × 8 cells whose k1, k2 and angle vary along x only
  (anisotropy up to 1000 : 1), f = 0; u depends on x alone, with Q11 u' the same in every
  column, so it is piecewise linear: u(x) = 1 − ∫₀ˣ 1/Q11 / ∫₀¹ 1/Q11.
Each problem keeps u and f as SymPy expressions in `X`, `Y`: NumPy functions for scikit-fem and
MODFLOW 6, and, through `translate`, NGSolve CoefficientFunctions or UFL expressions, so that
every code evaluates the same u and f at its own quadrature points.
`skfem_solve` assembles with the mesh's element means (`to_skfem(mesh, with_means=True)`).
"""

from __future__ import annotations

import operator
from functools import reduce
from typing import Any, Callable, Iterator, Mapping, NamedTuple

import numpy as np
import sympy as sp

from fem_problem import positive_off_diagonals

import qmesh
import qmesh.io

SQUARE = qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)], tags=[1, 2, 3, 4],
                       names={1: "bottom", 2: "right", 3: "top", 4: "left"})
X, Y = sp.symbols("x y")


class Problem(NamedTuple):
    field: qmesh.TensorField
    u: Callable[[np.ndarray, np.ndarray], np.ndarray]      # u_expr and f_expr as NumPy functions
    f: Callable[[np.ndarray, np.ndarray], np.ndarray]
    u_expr: sp.Expr                                        # the exact solution, in X and Y
    f_expr: sp.Expr                                        # f = −div(Q∇u)


def _problem(field: qmesh.TensorField, u: sp.Expr, f: sp.Expr) -> Problem:
    def numpy(expr: sp.Expr) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
        g = sp.lambdify((X, Y), expr, "numpy")
        return lambda x, y: g(x, y) + 0.0 * (x + y)        # an array of the points' shape, f = 0 too
    return Problem(field, numpy(u), numpy(f), u, f)


def fvca5(delta: float = 1e-3) -> Problem:
    x, y = X, Y
    r2 = x**2 + y**2
    Q = sp.Matrix([[(delta * x**2 + y**2) / r2, (delta - 1) * x * y / r2],
                   [(delta - 1) * x * y / r2, (x**2 + delta * y**2) / r2]])
    u = sp.sin(sp.pi * x) * sp.sin(sp.pi * y)
    flux = Q * sp.Matrix([u.diff(x), u.diff(y)])
    f = -(flux[0].diff(x) + flux[1].diff(y))                       # f = −div(Q∇u)
    field = qmesh.TensorField.from_expressions(str(Q[0, 0]), str(Q[0, 1]), str(Q[1, 1]))
    return _problem(field, u, f)


def strata(seed: int = 3) -> Problem:
    rng = np.random.default_rng(seed)
    k1 = np.exp(rng.uniform(0, np.log(100), 8))
    k2 = k1 / np.exp(rng.uniform(0, np.log(1000), 8))
    angle = rng.uniform(0, 180, 8)
    edges = np.linspace(0, 1, 9)
    field = qmesh.TensorField.from_raster(edges, edges, np.tile(k1, (8, 1)), np.tile(k2, (8, 1)),
                                          np.tile(angle, (8, 1)))
    t = np.radians(angle)
    q11 = k1 * np.cos(t) ** 2 + k2 * np.sin(t) ** 2
    resistance = np.concatenate([[0], np.cumsum(np.diff(edges) / q11)])  # ∫₀ˣ 1/Q11 at the columns' edges
    pieces = [1 - (resistance[k] + (X - edges[k]) / q11[k]) / resistance[-1] for k in range(8)]
    u = sp.Piecewise(*((p, X < b) for p, b in zip(pieces[:-1], edges[1:-1])), (pieces[-1], True))
    return _problem(field, u, sp.Integer(0))


def meshed(target_vertices: int = 1500) -> Iterator[tuple[str, Problem, qmesh.Mesh]]:
    """(name, problem, mesh) of both problems: the meshes every code of the guide solves them on."""
    for name, make in (("fvca5", fvca5), ("strata", strata)):
        problem = make()
        yield name, problem, qmesh.mesh(SQUARE, problem.field, target_vertices=target_vertices)


def summary(code: str, name: str, n_vertices: int, error: float, positive: int) -> str:
    """The line each FEM example prints for a problem."""
    return f"{code}, {name}: N={n_vertices}, L2 error {error:.4g}, {positive} positive off-diagonals"


def translate(expr: sp.Expr, x: Any, y: Any, functions: Mapping[str, Callable[[Any], Any]],
              if_positive: Callable[[Any, Any, Any], Any]) -> Any:
    """`expr` (SymPy, in X and Y) rebuilt from a FEM code's own coordinates `x`, `y`, its
    `functions` by SymPy's name ({"sin": ngsolve.sin, ...}) and `if_positive(t, a, b)` (a where
    t > 0, else b), so that the code evaluates it at its own quadrature points. Numbers, sums,
    products, integer powers, those functions and a Piecewise of `<` / `>` conditions."""
    def walk(e: sp.Expr) -> Any:
        if e.is_number:
            return float(e)
        if e == X or e == Y:
            return x if e == X else y
        if e.is_Add or e.is_Mul:
            return reduce(operator.add if e.is_Add else operator.mul, map(walk, e.args))
        if e.is_Pow and e.exp.is_Integer:
            n = int(e.exp)
            return walk(e.base) ** n if n > 0 else 1.0 / walk(e.base) ** -n
        if isinstance(e, sp.Piecewise):
            (value, condition), rest = e.args[0], e.args[1:]
            if condition == sp.true:
                return walk(value)
            if not isinstance(condition, (sp.StrictLessThan, sp.StrictGreaterThan)):
                raise ValueError(f"a Piecewise condition other than < or >: {condition}")
            t = condition.gts - condition.lts                     # > 0 where the condition holds
            return if_positive(walk(t), walk(value), walk(sp.Piecewise(*rest)))
        if isinstance(e, sp.Function) and type(e).__name__ in functions:
            return functions[type(e).__name__](*map(walk, e.args))
        raise ValueError(f"no translation for {type(e).__name__}: {e}")
    return walk(expr)


class Solution(NamedTuple):
    u: np.ndarray           # u_h at the vertices
    load: np.ndarray        # b_i = ∫ f φ_i
    positive: int           # positive off-diagonals of K between free vertices


def skfem_solve(mesh: qmesh.Mesh, problem: Problem) -> Solution:
    """P1 with the mesh's element means, u = problem.u on the whole boundary."""
    import skfem
    from skfem.helpers import dot, grad, mul

    m, Q = qmesh.io.to_skfem(mesh, with_means=True)
    basis = skfem.Basis(m, skfem.ElementTriP1(), intorder=6)
    K = skfem.BilinearForm(lambda u, v, w: dot(mul(w.Q, grad(u)), grad(v))).assemble(basis, Q=Q)
    b = skfem.LinearForm(lambda v, w: problem.f(*w.x) * v).assemble(basis)
    D = basis.get_dofs().all()
    u_h = skfem.solve(*skfem.condense(K, b, x=problem.u(*m.p), D=D))
    return Solution(u_h, b, positive_off_diagonals(K, basis.complement_dofs(D)))


def l2_error(mesh: qmesh.Mesh, problem: Problem, u_h: np.ndarray) -> float:
    """‖u_h − u‖_L2 for u_h given at the vertices (P1), by scikit-fem's quadrature."""
    import skfem

    basis = skfem.Basis(qmesh.io.to_skfem(mesh), skfem.ElementTriP1(), intorder=6)
    error = skfem.Functional(lambda w: (w.u_h - problem.u(*w.x)) ** 2).assemble(basis, u_h=basis.interpolate(u_h))
    return float(np.sqrt(error))
