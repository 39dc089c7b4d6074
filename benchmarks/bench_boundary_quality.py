"""Quality next to fine boundary points: the chapter's disk and a rotated hexagon.

On the chapter's case (Q = diag(0.1, 10), Disk(VB), target N = the chapter's adapted N) the seeds
at the tips x = ±1 are up to ten times closer together, in the metric, than the interior spacing.
For every VB this prints N, the minimum and mean metric quality (2.94), the share of q_ij ≥ 0
(≥ −1e-9·max|q|) on interior and on boundary edges, κ2 of the Dirichlet matrix and its ratio to
κ2 before the conforming rewrite (commit 9ef9386); then the same for the convex hexagon of
tests/core/test_mesher.py with Anisotropy.principal(1, 50, 30), N = 150.

    python benchmarks/bench_boundary_quality.py [--vb 128 512] [--seed 0] [--no-page]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

import qmesh
from qmesh import measure

import report_page

CHAPTER_N = {32: 101, 45: 131, 64: 212, 90: 280, 128: 428, 180: 656, 256: 817, 360: 1380,
             512: 2312}
KAPPA2_BEFORE = {32: 4.96, 45: 6.20, 64: 11.46, 90: 11.58, 128: 19.13, 180: 33.29, 256: 41.86,
                 360: 79.45, 512: 137.03}


def hexagon() -> qmesh.Polygon:
    t = np.deg2rad([0.0, 50.0, 110.0, 180.0, 235.0, 300.0])
    return qmesh.Polygon(np.column_stack([1.5 * np.cos(t), np.sin(t)]))


def row(m, A) -> dict:
    r = measure.report(m, A)
    _, q, interior = measure.edge_weights(m, A)
    ok = q / np.abs(q).max() >= -1e-9
    return {"N": m.n_vertices, "min q": r["min_quality"], "mean q": r["mean_quality"],
            "interior": ok[interior].mean(), "boundary": ok[~interior].mean(),
            "κ2": r["kappa2"]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vb", type=int, nargs="+", default=sorted(CHAPTER_N))
    ap.add_argument("--seed", type=int, default=0)
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    A = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    headers = ["case", "N (target)", "min q", "mean q", "q_ij≥0 interior", "q_ij≥0 boundary", "κ2",
               "κ2/before"]
    print("| " + " | ".join(headers) + " |")
    print("|" + "---|" * len(headers))
    ratios, rows = [], []
    for vb in args.vb:
        n = CHAPTER_N[vb]
        r = row(qmesh.mesh(qmesh.Disk(vb), A, target_vertices=n, seed=args.seed), A)
        ratios.append(r["κ2"] / KAPPA2_BEFORE[vb])
        rows.append([f"disk VB {vb}", f"{r['N']} ({n})", f"{r['min q']:.3f}", f"{r['mean q']:.3f}",
                     f"{r['interior']:.4f}", f"{r['boundary']:.4f}", f"{r['κ2']:.2f}",
                     f"{ratios[-1]:.3f}"])
        print("| " + " | ".join(rows[-1]) + " |")
    Ah = qmesh.Anisotropy.principal(1, 50, 30)
    r = row(qmesh.mesh(hexagon(), Ah, target_vertices=150, seed=args.seed), Ah)
    rows.append(["rotated hexagon", f"{r['N']} (150)", f"{r['min q']:.3f}", f"{r['mean q']:.3f}",
                 f"{r['interior']:.4f}", f"{r['boundary']:.4f}", f"{r['κ2']:.2f}", ""])
    print("| " + " | ".join(rows[-1]) + " |")
    summary = (f"κ2 / before the rewrite over the disk rows: geometric mean "
               f"{np.exp(np.mean(np.log(ratios))):.3f}, max {max(ratios):.3f}")
    print(f"\n{summary}")
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "Quality next to fine boundary points",
            "The chapter's case (Q = diag(0.1, 10) on Disk(VB), target N = the chapter's adapted "
            "N), where the seeds at the tips x = ±1 are up to ten times closer together, in the "
            "metric, than the interior spacing; then a convex hexagon under "
            "`Anisotropy.principal(1, 50, 30)` at N = 150. Columns: N reached (target), minimum "
            "and mean metric quality (2.94), the share of q_ij ≥ 0 (≥ −1e-9·max|q|) on "
            "interior and on boundary edges, κ2 of the Dirichlet matrix and its ratio to κ2 "
            "before the conforming rewrite (commit 9ef9386).",
            tables=[report_page.Table(headers, rows)], notes=[summary + "."])


if __name__ == "__main__":
    main()
