"""Heterogeneous test media: FVCA5 tests 4, 6, 7 (Herbin & Hubert 2008) and two of our own.

Each case is (domain with regions, {tag: Anisotropy}, Dirichlet data g(x, y)) on its outline,
with no source, so the discrete maximum principle says every vertex lies in the range of g.
The data is a step for every case, g = 1 on the left side (x = its minimum) and 0 on the rest
of the boundary: linear data would be reproduced exactly in a region of constant Q by any mesh
and show nothing; a step makes a stiffness matrix that is not an M-matrix overshoot.

- `fvca4`: the vertical fault, our reading of FVCA5 test 4: the unit square in horizontal
  layers of K1 = diag(1e-2, 1e-3) and K2 = diag(1e2, 1e1), alternating every 0.25 in y and
  offset by 0.125 across the fault x = 0.5
- `fvca6`: the oblique drain (test 6): δ = 0.2, the band 0.475 < y − δ(x − 0.5) < 0.525 with
  K = R diag(100, 10) Rᵀ, elsewhere R diag(1, 0.1) Rᵀ, R the rotation by atan δ
- `fvca7`: the oblique barrier (test 7): the same band with K = 0.01·I, elsewhere I
  (the tests' own boundary data are not used here).
- `layered`: a 2 × 1 box in five tilted layers, rotated anisotropies up to 1e3, contrast 1e4.
- `inclusion`: the unit square with a star-shaped conductive inclusion (anisotropy 1e3 at 45°)
  and a barrier lens (1e-3·I) in a background of anisotropy 10.
"""

from __future__ import annotations

import numpy as np

from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.domain.domain import Domain

UNIT = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]


def step(x, y):
    """1 on the left side x = 0, 0 elsewhere (every case's outline starts at x = 0)."""
    return (np.asarray(x) <= 1e-12).astype(float)


def fvca4():
    K1, K2 = Anisotropy.constant([[1e-2, 0], [0, 1e-3]]), Anisotropy.constant([[1e2, 0], [0, 1e1]])
    regions, cond = [], {}
    # left: K2 in [0.25, 0.5] and [0.75, 1]; right, offset by 0.125: [0.125, 0.375], [0.625, 0.875]
    for x0, x1, bands in ((0.0, 0.5, ((0.25, 0.5), (0.75, 1.0))),
                          (0.5, 1.0, ((0.125, 0.375), (0.625, 0.875)))):
        for y0, y1 in bands:
            regions.append([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
            cond[len(regions)] = K2
    cond[0] = K1
    return Domain(UNIT, regions=regions, region_names=["K2 left low", "K2 left high",
                                                       "K2 right low", "K2 right high"]), cond, \
        step


def _band(delta=0.2):
    lo = lambda x: delta * (x - 0.5) + 0.475      # noqa: E731
    return [(0.0, lo(0.0)), (1.0, lo(1.0)), (1.0, lo(1.0) + 0.05), (0.0, lo(0.0) + 0.05)]


def fvca6(delta=0.2):
    angle = np.degrees(np.arctan(delta))
    cond = {0: Anisotropy.principal(1.0, 0.1, angle), 1: Anisotropy.principal(100.0, 10.0, angle)}
    return Domain(UNIT, regions=[_band(delta)], region_names=["drain"]), cond, \
        step


def fvca7(delta=0.2):
    cond = {0: Anisotropy.constant(np.eye(2)), 1: Anisotropy.constant(0.01 * np.eye(2))}
    return Domain(UNIT, regions=[_band(delta)], region_names=["barrier"]), cond, \
        step


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
         "FVCA5 test 7 (oblique barrier)": fvca7, "layered (5 tilted layers)": layered,
         "inclusion (star + lens)": inclusion}
