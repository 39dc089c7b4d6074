"""The two problems of the guide's "From conductivity to solution", and scikit-fem's solve of them.

−div(Q∇u) = f on the unit square (sides tagged bottom, right, top, left), u = its exact value on
the whole boundary:
- `fvca5`: FVCA5 test 5, Q turning about the corner (0, 0) at δ = 1e-3, u = sin πx sin πy,
  f = −div(Q∇u) derived by SymPy (the page's recipe);
- `strata`: a raster TensorField of 8 × 8 cells whose k1, k2 and angle vary along x only
  (anisotropy up to 1000 : 1), f = 0; u depends on x alone, with Q11 u' the same in every
  column, so it is piecewise linear: u(x) = 1 − ∫₀ˣ 1/Q11 / ∫₀¹ 1/Q11.
`skfem_solve` assembles with the mesh's element means (`to_skfem(mesh, with_means=True)`).
"""

from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np
import sympy as sp

import qmesh
import qmesh.io

SQUARE = qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)], tags=[1, 2, 3, 4],
                       names={1: "bottom", 2: "right", 3: "top", 4: "left"})


class Problem(NamedTuple):
    field: qmesh.TensorField
    u: Callable[[np.ndarray, np.ndarray], np.ndarray]
    f: Callable[[np.ndarray, np.ndarray], np.ndarray]


def fvca5(delta: float = 1e-3) -> Problem:
    x, y = sp.symbols("x y")
    r2 = x**2 + y**2
    Q = sp.Matrix([[(delta * x**2 + y**2) / r2, (delta - 1) * x * y / r2],
                   [(delta - 1) * x * y / r2, (x**2 + delta * y**2) / r2]])
    u = sp.sin(sp.pi * x) * sp.sin(sp.pi * y)
    flux = Q * sp.Matrix([u.diff(x), u.diff(y)])
    f = -(flux[0].diff(x) + flux[1].diff(y))                       # f = −div(Q∇u)
    field = qmesh.TensorField.from_expressions(str(Q[0, 0]), str(Q[0, 1]), str(Q[1, 1]))
    return Problem(field, sp.lambdify((x, y), u, "numpy"), sp.lambdify((x, y), f, "numpy"))


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

    def u(x, y):
        return 1 - np.interp(x, edges, resistance) / resistance[-1] + 0 * y

    return Problem(field, u, lambda x, y: 0 * x)


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
    free = basis.complement_dofs(D)
    A = K[free][:, free].tocoo()
    return Solution(u_h, b, int(np.count_nonzero((A.row != A.col) & (A.data > 1e-12 * abs(K).max()))))


def l2_error(mesh: qmesh.Mesh, problem: Problem, u_h: np.ndarray) -> float:
    """‖u_h − u‖_L2 for u_h given at the vertices (P1), by scikit-fem's quadrature."""
    import skfem

    basis = skfem.Basis(qmesh.io.to_skfem(mesh), skfem.ElementTriP1(), intorder=6)
    error = skfem.Functional(lambda w: (w.u_h - problem.u(*w.x)) ** 2).assemble(basis, u_h=basis.interpolate(u_h))
    return float(np.sqrt(error))
