"""Heterogeneous test media: FVCA5 tests 4, 6, 7, FVCA6 test 5 (2-D slice) and two of our own.

Each case is (domain with regions, {tag: Anisotropy}, Dirichlet data g(x, y)) on its outline.
The FVCA5 cases and ours have no source, so the discrete maximum principle says every vertex
lies in the range of g. FVCA6 test 5 has a source and an exact solution (`fvca6_test5_exact`,
`fvca6_test5_source`) for an error against it; its g is that solution on ∂Ω, which is 0.

FVCA5: R. Herbin, F. Hubert, "Benchmark on discretization schemes for anisotropic diffusion
problems on general grids", Finite Volumes for Complex Applications V, 2008, pp. 659–692
(HAL hal-00429843). FVCA6: R. Eymard, G. Henry, R. Herbin, F. Hubert, R. Klöfkorn, G. Manzini,
"3D benchmark on discretization schemes for anisotropic diffusion problems on general grids",
Finite Volumes for Complex Applications VI, 2011, pp. 895–930 (HAL hal-00580549). The data of
both, as a participant's code defines them, were read in the DUNE-FEM-DG Poisson example
(github.com/adedner/dune-fem-dg, dune/fem-dg/examples/poisson/problems/benchmarkproblems.hh,
classes BenchMark_4 and BenchMark3d_5).

- `fvca4`: the vertical fault (FVCA5 test 4): the unit square in horizontal strips 0.1 high,
  K2 = diag(1e2, 1e1) and K1 = diag(1e-2, 1e-3) alternating, offset by 0.05 across the fault
  x = 0.5: on the right (x > 0.5) K2 in [0, 0.1], [0.2, 0.3], …, [0.8, 0.9]; on the left
  (x ≤ 0.5) K2 in [0.05, 0.15], [0.25, 0.35], …, [0.85, 0.95], K1 elsewhere. Data g = 1 − x on
  the whole boundary, no source (the benchmark's data; 1 − x is not the solution: the flux
  −K_xx across the fault differs from strip to strip). The five K2 regions are the Z-shaped
  unions of a right strip and the left strip it overlaps on the fault. The left half's bottom
  0.05 is K1, as the periodic pattern has it (a copy of the benchmark's code elsewhere rounds
  10(y − 0.05) towards zero there and would give it to K2).
- `fvca6`: the oblique drain (FVCA5 test 6): δ = 0.2, the band 0.475 < y − δ(x − 0.5) < 0.525
  with K = R diag(100, 10) Rᵀ, elsewhere R diag(1, 0.1) Rᵀ, R the rotation by atan δ
- `fvca7`: the oblique barrier (FVCA5 test 7): the same band with K = 0.01·I, elsewhere I.
  For tests 6 and 7 the data is a step (g = 1 on the left side x = 0, 0 on the rest of the
  boundary), not the tests' own linear data: their exact solutions are piecewise linear, which
  any conforming mesh reproduces, so a step shows more (a stiffness matrix that is not an
  M-matrix overshoots it).
- `fvca6_test5`: FVCA6 test 5 (discontinuous anisotropy) on its plane x = const: the unit square
  in four quadrants meeting at the cross point (½, ½), tags 0–3 for (x ≤ ½, y ≤ ½),
  (x > ½, y ≤ ½), (x > ½, y > ½), (x ≤ ½, y > ½) with K = diag(10, 0.01), diag(0.1, 100),
  diag(0.01, 10), diag(100, 0.1) (1000:1, the ellipses orthogonal across x = ½) and the exact
  solution u = α sin 2πx sin 2πy, α = 0.1, 10, 100, 0.01: −div(K∇u) = f with
  f = 4π² α (K_xx + K_yy) sin 2πx sin 2πy in each quadrant, u = 0 on ∂Ω. u vanishes on the lines
  x = ½ and y = ½, and K∇u·n is continuous across them (K_xx α = 1 on both sides of x = ½,
  K_yy α = 1e-3 and 1e3 across y = ½).
- `layered`: a 2 × 1 box in five tilted layers, rotated anisotropies up to 1e3, contrast 1e4;
  step data.
- `inclusion`: the unit square with a star-shaped conductive inclusion (anisotropy 1e3 at 45°)
  and a barrier lens (1e-3·I) in a background of anisotropy 10; step data.
"""

from __future__ import annotations

import numpy as np

from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.domain.domain import Domain
from qmesh.geometry.portable import arctan

UNIT = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]


def step(x, y):
    """1 on the left side x = 0, 0 elsewhere (every case's outline starts at x = 0)."""
    return (np.asarray(x) <= 1e-12).astype(float)


def linear(x, y):
    """1 − x: FVCA5 test 4's boundary data."""
    return 1.0 - np.asarray(x, dtype=float)


FVCA4_K1 = ((1e-2, 0.0), (0.0, 1e-3))
FVCA4_K2 = ((1e2, 0.0), (0.0, 1e1))


def fvca4():
    K1, K2 = Anisotropy.constant(FVCA4_K1), Anisotropy.constant(FVCA4_K2)
    regions, names = [], []
    for k in range(5):
        # right strip [0.2k, 0.2k + 0.1], left strip [0.2k + 0.05, 0.2k + 0.15]; in twentieths
        r0, r1, l0, l1 = 4 * k / 20, (4 * k + 2) / 20, (4 * k + 1) / 20, (4 * k + 3) / 20
        regions.append([(0.5, r0), (1.0, r0), (1.0, r1), (0.5, r1), (0.5, l1), (0.0, l1),
                        (0.0, l0), (0.5, l0)])
        names.append(f"K2 strip {k + 1}")
    cond = {0: K1, **{k + 1: K2 for k in range(5)}}
    return Domain(UNIT, regions=regions, region_names=names), cond, linear


def _band(delta=0.2):
    lo = lambda x: delta * (x - 0.5) + 0.475      # noqa: E731
    return [(0.0, lo(0.0)), (1.0, lo(1.0)), (1.0, lo(1.0) + 0.05), (0.0, lo(0.0) + 0.05)]


def fvca6(delta=0.2):
    angle = np.degrees(arctan(delta))
    cond = {0: Anisotropy.principal(1.0, 0.1, angle), 1: Anisotropy.principal(100.0, 10.0, angle)}
    return Domain(UNIT, regions=[_band(delta)], region_names=["drain"]), cond, \
        step


def fvca7(delta=0.2):
    cond = {0: Anisotropy.constant(np.eye(2)), 1: Anisotropy.constant(0.01 * np.eye(2))}
    return Domain(UNIT, regions=[_band(delta)], region_names=["barrier"]), cond, \
        step


# FVCA6 test 5 on a plane x = const: (α, K_xx, K_yy) per quadrant tag
FVCA6_TEST5 = ((0.1, 10.0, 0.01), (10.0, 0.1, 100.0), (100.0, 0.01, 10.0), (0.01, 100.0, 0.1))


def quadrant(x, y):
    """FVCA6 test 5's quadrant tag of points: 0 (x ≤ ½, y ≤ ½), 1 (x > ½, y ≤ ½), 2 (x > ½,
    y > ½), 3 (x ≤ ½, y > ½)."""
    right, top = np.asarray(x) > 0.5, np.asarray(y) > 0.5
    return np.where(top, np.where(right, 2, 3), np.where(right, 1, 0))


def _test5(tag, x, y):
    tag = quadrant(x, y) if tag is None else np.broadcast_to(np.asarray(tag), np.shape(x))
    alpha, kx, ky = (np.asarray(FVCA6_TEST5)[tag][..., i] for i in range(3))
    return alpha, kx, ky


def fvca6_test5_exact(x, y, tag=None):
    """u = α sin 2πx sin 2πy, α of the quadrant (`tag`: the region, e.g. of the triangle a
    quadrature point lies in; by default the quadrant of the point)."""
    alpha, _, _ = _test5(tag, x, y)
    return alpha * np.sin(2 * np.pi * np.asarray(x)) * np.sin(2 * np.pi * np.asarray(y))


def fvca6_test5_gradient(x, y, tag=None):
    """∇u (…, 2)."""
    alpha, _, _ = _test5(tag, x, y)
    x, y = 2 * np.pi * np.asarray(x), 2 * np.pi * np.asarray(y)
    return 2 * np.pi * alpha[..., None] * np.stack([np.cos(x) * np.sin(y), np.sin(x) * np.cos(y)],
                                                   axis=-1)


def fvca6_test5_source(x, y, tag=None):
    """f = −div(K∇u) = 4π² α (K_xx + K_yy) sin 2πx sin 2πy in the quadrant."""
    alpha, kx, ky = _test5(tag, x, y)
    return 4 * np.pi**2 * alpha * (kx + ky) * np.sin(2 * np.pi * np.asarray(x)) * \
        np.sin(2 * np.pi * np.asarray(y))


def fvca6_test5():
    quadrants = [[(0.5, 0.0), (1.0, 0.0), (1.0, 0.5), (0.5, 0.5)],
                 [(0.5, 0.5), (1.0, 0.5), (1.0, 1.0), (0.5, 1.0)],
                 [(0.0, 0.5), (0.5, 0.5), (0.5, 1.0), (0.0, 1.0)]]
    cond = {t: Anisotropy.constant(np.diag([kx, ky])) for t, (_, kx, ky) in enumerate(FVCA6_TEST5)}
    return Domain(UNIT, regions=quadrants,
                  region_names=["x > ½, y ≤ ½", "x > ½, y > ½", "x ≤ ½, y > ½"]), cond, \
        fvca6_test5_exact


def layered():
    ys = [(0.0, 0.0), (0.15, 0.3), (0.35, 0.45), (0.6, 0.55), (0.8, 0.85), (1.0, 1.0)]
    Ks = [Anisotropy.principal(1.0, 1e-3, 10), Anisotropy.principal(10.0, 1.0, -20),
          Anisotropy.principal(1e-3, 1e-3, 0), Anisotropy.principal(5.0, 0.05, 30),
          Anisotropy.principal(0.1, 0.1, 0)]
    regions = [[(0.0, ys[k][0]), (2.0, ys[k][1]), (2.0, ys[k + 1][1]), (0.0, ys[k + 1][0])]
               for k in range(1, 5)]
    outline = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (0.0, 1.0)]
    cond = {k: K for k, K in enumerate(Ks)}
    return Domain(outline, regions=regions), cond, step


def inclusion():
    t = 2 * np.pi * np.arange(10) / 10
    r = np.where(np.arange(10) % 2 == 0, 0.22, 0.12)
    star = np.column_stack([0.35 + r * np.cos(t), 0.6 + r * np.sin(t)])
    t = 2 * np.pi * np.arange(16) / 16
    lens = np.column_stack([0.72 + 0.15 * np.cos(t), 0.3 + 0.08 * np.sin(t)])
    cond = {0: Anisotropy.principal(10.0, 1.0, 0), 1: Anisotropy.principal(1e3, 1.0, 45),
            2: Anisotropy.constant(1e-3 * np.eye(2))}
    return Domain(UNIT, regions=[star, lens], region_names=["star", "lens"]), cond, \
        step


CASES = {"FVCA5 test 4 (vertical fault)": fvca4, "FVCA5 test 6 (oblique drain)": fvca6,
         "FVCA5 test 7 (oblique barrier)": fvca7,
         "FVCA6 test 5 (quadrants, 2-D)": fvca6_test5, "layered (5 tilted layers)": layered,
         "inclusion (star + lens)": inclusion}
