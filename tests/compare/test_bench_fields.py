"""benchmarks/bench_fields.py's pieces on a tiny case: its own element means (exact clipping
against the reference loop, collapsed Gauss against a constant), FVCA5 test 5 meshed by qmesh
with no positive off-diagonal on the means computed by the benchmark, and the P1 error of the
manufactured solution finite and falling with N."""

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import Delaunay

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
import bench_fields as bench  # noqa: E402

from tests.fields.reference import cell_tensors, raster_mean_by_clipping  # noqa: E402

pytest.importorskip("sympy", reason="the manufactured solution's f comes from SymPy")


def test_raster_means_equal_the_reference_clipping():
    rng = np.random.default_rng(3)
    xe, ye = np.sort(np.r_[0.0, rng.uniform(0, 1, 6), 1.0]), np.linspace(0, 1, 6)
    k1 = np.exp(rng.normal(0, 1, (5, 7)))
    k2, angle = k1 / 10 ** rng.uniform(0, 2, (5, 7)), rng.uniform(0, 180, (5, 7))
    Qc = bench.cell_tensors(k1, k2, angle)
    assert np.allclose(Qc, cell_tensors(k1, k2, angle), rtol=1e-14, atol=1e-14)
    P = np.vstack([rng.uniform(0, 1, (40, 2)), [[0, 0], [1, 0], [1, 1], [0, 1]], [[xe[2], ye[3]]]])
    T = Delaunay(P).simplices
    means, covered = bench.raster_means(xe, ye, Qc, P, T, chunk=37)
    ref = np.array([raster_mean_by_clipping(xe, ye, Qc, P[t])[0] for t in T])
    assert np.allclose(means, ref, rtol=1e-12, atol=1e-13)
    assert covered < 1e-12


def test_formula_means_are_exact_for_a_linear_field():
    P = np.array([[0.0, 0.0], [1.0, 0.0], [0.3, 0.8], [0.02, 0.01]])
    T = np.array([[0, 1, 2], [0, 3, 1]])

    def Q(X, Y):
        return np.stack([np.stack([2 + X, 0.1 * Y], -1), np.stack([0.1 * Y, 1 + Y], -1)], -2)
    c = P[T].mean(axis=1)
    assert np.allclose(bench.formula_means(Q, P, T, singular=[(0.0, 0.0)]), Q(c[:, 0], c[:, 1]),
                       rtol=1e-13)


def test_fvca5_qmesh_has_no_positive_off_diagonal_and_its_error_falls():
    case = bench.CASES["fvca5"]
    problem = bench.sympy_problem(case)
    errors = []
    for n in (200, 800):
        r = bench.run_mesher(case, "qmesh", n, repeats=1)
        P, T = r["points"], r["triangles"]
        Qbar = bench.independent_means(case, P, T, problem)
        assert np.allclose(Qbar, r["conductivity"], rtol=1e-5, atol=1e-6)
        assert bench.positive_off_diagonals(P, T, Qbar)[:2] == (0, 0)
        assert bench.maximum_principle(P, T, Qbar)[0] == 0
        errors.append(bench.l2_error(P, T, Qbar, problem[1], problem[2]))
    assert np.all(np.isfinite(errors)) and errors[1] < errors[0], errors


def test_plasma_at_2000_reaches_the_bound_its_corners_set():
    """The field-aligned plasma case at N = 2000: its worst triangle is one of the square's
    corners' (each 1.4° wide in the field's metric), not one on a side where the field runs
    nearly along it (0.034 when the polish only took shape steps)."""
    case = bench.CASES["plasma"]
    r = bench.run_mesher(case, "qmesh", 2000, repeats=1)
    P, T, Qbar = r["points"], r["triangles"], r["conductivity"]
    quality = bench.measure.quality(bench.qmesh.Mesh(P, T, r["fixed"]), Qbar)
    bound = bench.corner_bound(P, T, Qbar)
    assert bound < 0.05
    assert np.nanmin(quality) >= bound * (1 - 1e-6), (np.nanmin(quality), bound)
