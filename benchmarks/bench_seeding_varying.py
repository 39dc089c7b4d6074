"""The varying-s start: the mesher's random points against `seeding_varying.initial_points`.

`qmesh/seeding_varying.py` is a prototype the mesher does not call yet. This script swaps it in
for one run at a time by wrapping the mesher's private `_run` (to learn the normalised domain,
anisotropy, target and boundary point count) and `seeding.random_interior` (the varying-s
start), then meshes the chapter's 64-gon for each expression, target N and seed both ways and
prints the means over the seeds: κ2 (Dirichlet, continuous Q), min and mean metric quality,
|e_s|_h1, iterations and seconds. Once the mesher calls `initial_points` itself, this script
has done its job.

    python benchmarks/bench_seeding_varying.py [--n 500 2000] [--seeds 4] [--no-page]
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time

import numpy as np

import qmesh
from qmesh import measure
from qmesh.mesher import loop as mesher
from qmesh.mesher import seeding
from qmesh.mesher import seeding_varying

import report_page

EXPRESSIONS = ("exp(x) + y**2", "cosh(3*x) + 0.02*y**2",
               "log(exp(2*x) + exp(-2*x) + exp(2*y))", "x**4 + y**4 + x**2 + y**2")


@contextlib.contextmanager
def lattice_start():
    """Within the block, a varying s with a target N starts from seeding_varying.initial_points
    with LATTICE_FILL of the expected interior vertices (as the constant-Q lattice does)."""
    run, random_interior = mesher._run, seeding.random_interior
    context = {}

    def wrapped_run(norm, h, area_m, lengths, target_vertices, alpha, quality_threshold, min_area,
                    max_iterations, rng, boundary_refinement):
        factor = mesher.BOUNDARY_FACTOR if boundary_refinement else None
        extra, _ = seeding.boundary_points(norm.domain, norm.anisotropy, h, factor)
        context.update(anisotropy=norm.anisotropy, target=target_vertices,
                       n_b=len(norm.domain.seeds) + len(extra))
        return run(norm, h, area_m, lengths, target_vertices, alpha, quality_threshold, min_area,
                   max_iterations, rng, boundary_refinement)

    def start(domain, k, rng):
        A = context.pop("anisotropy", None)          # only the start of the run, not other callers
        if A is None or context["target"] is None:
            return random_interior(domain, k, rng)
        n = int(mesher.LATTICE_FILL * (context["target"] - context["n_b"]))
        return seeding_varying.initial_points(domain, A, n, rng)

    mesher._run, seeding.random_interior = wrapped_run, start
    try:
        yield
    finally:
        mesher._run, seeding.random_interior = run, random_interior


def measure_runs(A, n: int, seeds) -> np.ndarray:
    """Means over the seeds of κ2, min q, mean q, |e_s|_h1, iterations, seconds."""
    rows = []
    for seed in seeds:
        t0 = time.perf_counter()
        last = None
        for last in qmesh.iterate(qmesh.Disk(64), A, target_vertices=n, seed=seed):
            pass
        seconds = time.perf_counter() - t0
        r = measure.report(last.mesh, A)
        rows.append([r["kappa2"], r["min_quality"], r["mean_quality"], r["h1_error"], last.iteration, seconds])
    return np.mean(rows, axis=0)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[500, 2000])
    ap.add_argument("--seeds", type=int, default=4, help="seeds 0 … SEEDS−1")
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    seeds = range(args.seeds)
    head = (f"Disk(64), means over seeds 0–{args.seeds - 1}; each cell: mesher's random start → "
            "seeding_varying.initial_points")
    print(head)
    print()
    print("| s(x, y) | N | κ2 | min q | mean q | \\|e_s\\|_h1 | iterations | s |")
    print("|---|---|---|---|---|---|---|---|")
    ratios, rows = [], []
    for n in args.n:
        for expr in EXPRESSIONS:
            A = qmesh.Anisotropy.from_expression(expr)
            before = measure_runs(A, n, seeds)
            with lattice_start():
                after = measure_runs(A, n, seeds)
            ratios.append(after[0] / before[0])
            cells = [f"{b:.4g} → {a:.4g}" for b, a in zip(before, after)]
            print(f"| `{expr}` | {n} | " + " | ".join(cells) + " |")
            rows.append([f"`{expr}`", n, *cells])
    ratios = np.array(ratios)
    print()
    summary = f"κ2 after/before: geometric mean {np.exp(np.log(ratios).mean()):.3f}, max {ratios.max():.3f}"
    print(summary)
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "Varying s: the random start against a lattice start",
            "`qmesh/mesher/seeding_varying.py` is a prototype the mesher does not call yet. The "
            "script swaps it in for one run at a time (wrapping the mesher's private `_run` and "
            "`seeding.random_interior`), meshes the chapter's 64-gon for each expression, target "
            "N and seed both ways, and shows the means over the seeds: κ2 (Dirichlet, continuous "
            "Q), min and mean metric quality, |e_s|_h1, iterations and seconds.",
            tables=[report_page.Table(["s(x, y)", "N", "κ2", "min q", "mean q", "|e_s|_h1",
                                       "iterations", "s"], rows, head)],
            notes=[summary + "."])


if __name__ == "__main__":
    main()
