"""The three inputs the MODFLOW 6 tests write: a constant Q at 1 : 1000, a raster TensorField
(contrasts over 1e6 between cells, 1 : 1000 within one) and the five tilted layers of
`media_cases.layered` — each on a domain whose outline carries tags 1 to 4 (bottom, right,
top, left), with the conductivity `to_modflow6` is given (None: the mesh's element means)
and the domain's area."""

from typing import Any, NamedTuple

import numpy as np

import qmesh
from qmesh.domain import media_cases

SIDES = {1: "bottom", 2: "right", 3: "top", 4: "left"}
N = 600


class Case(NamedTuple):
    mesh: qmesh.Mesh
    conductivity: Any
    area: float


def constant() -> Case:
    A = qmesh.Anisotropy.principal(1, 1e-3, 30)
    d = qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)], tags=[1, 2, 3, 4], names=SIDES)
    return Case(qmesh.mesh(d, A, target_vertices=N), A, 1.0)


def raster() -> Case:
    rng = np.random.default_rng(1)
    k1 = np.exp(rng.normal(0, 1.5, (16, 16)))
    k2 = k1 * np.exp(rng.uniform(-np.log(1000), 0, (16, 16)))
    F = qmesh.TensorField.from_raster(np.linspace(0, 1, 17), np.linspace(0, 1, 17), k1, k2,
                                      rng.uniform(0, 180, (16, 16)))
    hole = [(0.4, 0.4), (0.6, 0.4), (0.6, 0.6), (0.4, 0.6)]
    d = qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], holes=[hole], tags=[[1, 2, 3, 4], [5] * 4],
                     names={**SIDES, 5: "hole"})
    return Case(qmesh.mesh(d, F, target_vertices=N), None, 1.0 - 0.04)


def layered() -> Case:
    layers, Q, _ = media_cases.layered()
    d = qmesh.Domain([(0, 0), (2, 0), (2, 1), (0, 1)], tags=[[1, 2, 3, 4]], names=SIDES,
                     regions=[r.rings[0] for r in layers.regions])
    return Case(qmesh.mesh(d, Q, target_vertices=N), Q, 2.0)


CASES = {"constant": constant, "raster": raster, "layered": layered}
