"""benchmarks/bench_fields.py's pieces on a tiny case: its own element means (exact clipping
against the reference loop, collapsed Gauss against a constant), FVCA5 test 5 meshed by qmesh
with no positive off-diagonal on the means computed by the benchmark, and the P1 error of the
manufactured solution finite and falling with N; the spiral's and the islands' fields as
qmesh and SymPy read them, the islands' callable counted, the seconds per stage and the tables
of ratios against the targets."""

import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, strategies as st
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


def test_stage_seconds_split_the_whole_run():
    records = [("triangulate", 0, 0.5), ("adjust", 1, 0.2), ("insert", 1, 0.1),
               ("triangulate", 1, 0.05), ("adjust", 2, 0.2), ("triangulate", 2, 0.0)]
    stamps = np.array([10.0, 10.75, 10.95, 11.05, 11.1, 11.3, 12.0])
    s = bench.stage_seconds(records, stamps)
    assert s == pytest.approx({"set-up": 0.25, "first triangulation": 0.5, "adjust": 0.4,
                               "insert": 0.1, "triangulate": 0.05, "certify": 0.7})
    assert sum(s.values()) == pytest.approx(stamps[-1] - stamps[0])


@pytest.fixture(scope="module")
def sympy_q():
    """Q(x, y) as SymPy reads each new case's texts (built once: lambdifying takes a second)."""
    return {name: bench.sympy_problem(bench.CASES[name])[0] for name in ("spiral", "islands")}


@given(st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_spiral_text_for_qmesh_is_the_sympy_field(sympy_q, x, y):
    """qmesh's angle text (an arctangent) and SymPy's cos 2θ / sin 2θ texts are one Q."""
    assume(np.hypot(x - 0.5, y - 0.5) > 0.14 and abs(x - 0.5) > 1e-9)
    Q = sympy_q["spiral"]
    ours = bench.CASES["spiral"].field()(np.array([[x, y]]))[0]
    assert np.allclose(ours, Q(x, y), rtol=1e-9, atol=1e-12)
    w, v = np.linalg.eigh(ours)
    r = np.array([x - 0.5, y - 0.5]) / np.hypot(x - 0.5, y - 0.5)
    assert w == pytest.approx([bench.SPIRAL_K2, 1.0])
    turned = 4 * np.pi * np.hypot(x - 0.5, y - 0.5)    # k1's direction from the radial one
    assert abs(v[:, 1] @ r) == pytest.approx(abs(np.cos(turned)), abs=1e-9)


@given(st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_islands_callable_is_its_sympy_field(sympy_q, x, y):
    assume(np.hypot(x - 0.25, y - 0.5) > 1e-6 and np.hypot(x - 0.75, y - 0.5) > 1e-6)
    Q = sympy_q["islands"]
    assert np.allclose(bench.islands(np.array([x]), np.array([y]))[0], Q(x, y), rtol=1e-9,
                       atol=1e-13)


def test_islands_at_their_o_and_x_points_and_the_count_of_calls():
    """At the O- and X-points b is round-off, never 0: Q is finite and positive definite."""
    f = bench.Counted(bench.islands)
    q = f(np.array([0.25, 0.75, 0.1]), np.array([0.5, 0.5, 0.2]))
    assert np.all(np.isfinite(q)) and np.all(np.linalg.eigvalsh(q) > 0)
    f(np.zeros((2, 3)), np.zeros((2, 3)))
    assert (f.calls, f.points) == (2, 9) and f.seconds >= 0
    f.reset()
    assert (f.calls, f.points, f.seconds) == (0, 0, 0.0)


def test_islands_callable_meshed_certified_and_counted():
    case = bench.CASES["islands"]
    r = bench.run_mesher(case, "qmesh", 300, repeats=1)
    P, T = r["points"], r["triangles"]
    Qbar = bench.independent_means(case, P, T)
    assert bench.positive_off_diagonals(P, T, Qbar)[:2] == (0, 0)
    c = r["callable"]
    assert c["calls"] > 0 and c["points"] >= c["calls"] and c["seconds"] > 0
    assert sum(r["stages"].values()) == pytest.approx(r["total_seconds"], rel=0.05)
    assert r["stages"]["certify"] == r["certify_seconds"] > 0


def _row(case, mesher, n, seconds, **more):
    return {"case": case, "mesher": mesher, "target": n, "seconds": seconds, "N": n, **more}


def test_ratio_rows_hold_the_targets():
    rows = [_row("a", "qmesh", 2000, 0.9, const_s=0.2, cpu_s=0.8, const_cpu=0.2, constfield_s=0.3),
            _row("a", "qmesh", 20000, 0.9, const_s=0.2, cpu_s=0.8, const_cpu=0.2),
            _row("a", "MMG2D", 2000, 0.1)]
    got = bench.ratio_rows(rows)
    assert [g[:2] for g in got] == [["a", "2000"], ["a", "20000"]]
    assert got[0][4:7] == ["4.5×", "≤ 5×: met", "4.0×"] and got[0][8] == "3.0×"
    assert got[1][4:6] == ["4.5×", "≤ 3×: not met"] and got[1][7] == "not run"


def test_big_rows_judge_qmesh_against_mmg2d_and_the_million_target():
    rows = [_row("raster512", "MMG2D", 200_000, 20.0, peak_mb=500.0),
            _row("raster512", "qmesh", 200_000, 30.0, peak_mb=700.0),
            _row("raster512", "qmesh", 1_000_000, 55.0, peak_mb=2100.0),
            _row("raster512", "qmesh", 20_000, 3.0, peak_mb=200.0)]
    got = bench.big_rows(rows)
    assert [g[:2] for g in got] == [["qmesh", "200000"], ["MMG2D", "200000"], ["qmesh", "1000000"]]
    assert got[0][5] == "≤ MMG2D's 20.0 s: not met" and got[1][5] == ""
    assert got[2][5] == "≤ 60 s and ≤ 2 GB: not met"
