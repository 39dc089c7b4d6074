"""examples/heterogeneous_fem.py: FVCA5 test 4 with scikit-fem keeps 0 <= u <= 1 on qmesh's mesh."""

import runpy
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse.linalg as spla

import qmesh
from qmesh import measure
from qmesh.domain import media_cases as cases

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "heterogeneous_fem.py"


@pytest.fixture(scope="module")
def example():
    pytest.importorskip("skfem")
    return runpy.run_path(str(EXAMPLE), run_name="heterogeneous_fem")


def test_scikit_fem_assembles_each_triangles_k_as_measure_does(example):
    domain, cond, g = cases.fvca4()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(domain, cond, target_vertices=400)
    u = example["solve"](m, cond, g)
    K = measure.stiffness(m, cond).tocsr()
    B, I = np.flatnonzero(m.boundary), np.flatnonzero(~m.boundary)
    v = np.zeros(m.n_vertices)
    v[B] = g(*m.points[B].T)
    v[I] = spla.spsolve(K[I][:, I].tocsc(), -(K[I][:, B] @ v[B]))
    assert np.allclose(u, v, atol=1e-9)


def test_the_qmesh_solution_keeps_the_maximum_principle(example, capsys):
    results = example["main"](600)
    out = capsys.readouterr().out
    N, bad, worst, qi, qf, qb = results["qmesh"]
    assert bad == 0 and worst == 0.0 and qi == qf == qb == 1.0
    assert abs(N - 600) <= 60 and "Triangle" in out
