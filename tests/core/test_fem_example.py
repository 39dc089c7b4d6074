"""examples/holed_domain_fem.py: scikit-fem solves on a holed qmesh mesh using its boundary tags."""

import runpy
from pathlib import Path

import numpy as np
import pytest

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "holed_domain_fem.py"


@pytest.fixture(scope="module")
def example():
    return runpy.run_path(str(EXAMPLE), run_name="holed_domain_fem")


def test_manufactured_data_are_consistent(example):
    """∇u and f = −div(Q∇u) of the example match central differences of its u."""
    u, grad, f, Q = example["exact"], example["exact_gradient"], example["source"], example["Q"]
    x, y, e = np.array([0.3, -0.8]), np.array([-0.2, 0.6]), 1e-4
    np.testing.assert_allclose((u(x + e, y) - u(x - e, y)) / (2 * e), grad(x, y)[0], rtol=1e-7)
    np.testing.assert_allclose((u(x, y + e) - u(x, y - e)) / (2 * e), grad(x, y)[1], rtol=1e-7)
    flux = lambda x, y: Q @ grad(x, y)  # noqa: E731
    div = (flux(x + e, y)[0] - flux(x - e, y)[0] + flux(x, y + e)[1] - flux(x, y - e)[1]) / (2 * e)
    np.testing.assert_allclose(f(x, y), -div, rtol=1e-6)


def test_solves_with_the_tags_and_the_adapted_mesh_needs_fewer_cg_iterations(example, capsys):
    results = example["main"](400)
    out = capsys.readouterr().out
    adapted, isotropic = results["Q-adapted"], results["isotropic (Q = I)"]
    for r in (adapted, isotropic):
        assert r["cg_converged"] and r["relative_residual"] < 1e-8
        assert r["relative_l2_error"] < 0.05                      # the manufactured solution is found
        assert r["n_hole_facets"] == r["n_hole_edges"] > 0         # tag 2 arrived as the "hole" boundary
        assert r["n_dirichlet"] == r["n_outline_vertices"] > 0     # tag 1 as the "outline"
    assert abs(isotropic["n_vertices"] - adapted["n_vertices"]) <= 0.1 * adapted["n_vertices"]
    assert adapted["cg_iterations"] < isotropic["cg_iterations"] / 2
    assert adapted["positive_off_diagonals"] < isotropic["positive_off_diagonals"]  # the M-matrix check
    assert f"{adapted['cg_iterations']:>14}" in out and "isotropic (Q = I)" in out
