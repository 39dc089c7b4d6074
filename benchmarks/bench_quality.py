"""Quality against the chapter's Tables 2.2/2.3: Q = diag(0.1, 10) on the unit disk.

For every VB of Tables 2.2/2.3 it meshes with target_vertices = the chapter's adapted N and
prints N, min quality, fraction of q_ij ≥ 0, κ2, |e_s|_h1 and ‖e_s‖_L2 beside the chapter's
values, the ratios, and the geometric-mean κ2 ratio over the rows; the page
(docs/benchmarks/bench_quality.md) adds a figure of κ2, |e_s|_h1 and ‖e_s‖_L2 against N.

    python benchmarks/bench_quality.py [--vb 32 64 ...] [--seed 0] [--alpha 0.5] [--no-page]
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

import qmesh
from qmesh import measure

import report_page

# Tables 2.2 / 2.3, adapted columns: VB -> (N, L2, h1, kappa2)
CHAPTER = {32: (101, 1.13e-2, 3.43e-1, 6.0), 45: (131, 1.01e-2, 3.11e-1, 6.7),
           64: (212, 4.68e-3, 2.16e-1, 15), 90: (280, 4.04e-3, 1.94e-1, 18),
           128: (428, 2.43e-3, 1.52e-1, 26), 180: (656, 1.69e-3, 1.21e-1, 35),
           256: (817, 1.46e-3, 1.13e-1, 46), 360: (1380, 8.97e-4, 8.89e-2, 71),
           512: (2312, 4.83e-4, 6.56e-2, 132)}


SEED, ALPHA = 0, 0.5            # the defaults of --seed, --alpha


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vb", type=int, nargs="+", default=sorted(CHAPTER))
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--alpha", type=float, default=ALPHA)
    ap.add_argument("--max-iterations", type=int, default=None)
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    A = qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    opts = {"seed": args.seed, "alpha": args.alpha}
    if args.max_iterations is not None:
        opts["max_iterations"] = args.max_iterations
    headers = ["VB", "N (target)", "iters", "s", "min q", "q_ij≥0", "κ2", "κ2/ch", "h1", "h1/ch",
               "L2", "L2/ch"]
    print("| " + " | ".join(headers) + " |")
    print("|" + "---|" * len(headers))
    ratios, rows, plotted = [], [], []
    for vb in args.vb:
        n, l2c, h1c, kc = CHAPTER[vb]
        t0 = time.perf_counter()
        last = None
        for last in qmesh.iterate(qmesh.Disk(vb), A, target_vertices=n, **opts):
            pass
        dt = time.perf_counter() - t0
        r = measure.report(last.mesh, A)
        ratios.append(r["kappa2"] / kc)
        cells = [vb, f"{r['n_vertices']} ({n})", last.iteration, f"{dt:.2f}",
                 f"{r['min_quality']:.3f}", f"{r['q_nonnegative_fraction']:.4f}", f"{r['kappa2']:.2f}",
                 f"{r['kappa2'] / kc:.3f}", f"{r['h1_error']:.3g}", f"{r['h1_error'] / h1c:.3f}",
                 f"{r['l2_error']:.3g}", f"{r['l2_error'] / l2c:.3f}"]
        print("| " + " | ".join(map(str, cells)) + " |")
        rows.append(cells)
        plotted.append((r["n_vertices"], n, r["kappa2"], kc, r["h1_error"], h1c, r["l2_error"], l2c))
    summary = (f"κ2 ratio to the chapter: geometric mean {np.exp(np.mean(np.log(ratios))):.3f}, "
               f"max {max(ratios):.3f}")
    print(f"\n{summary}")
    if not args.no_page:
        figures = []
        fig = figure(plotted)
        if fig is not None:
            figures.append(report_page.Figure(fig, "κ2, |e_s|_h1 and ‖e_s‖_L2 against N: qmesh "
                                                   "and the chapter's adapted meshes"))
        report_page.write_page(
            __file__, sys.argv, "Quality on the chapter's case",
            "The unit-disk VB-gon with Q = diag(0.1, 10), meshed with `target_vertices` = the "
            "chapter's adapted N for every VB of Tables 2.2/2.3, beside the chapter's values: "
            "N reached, Algorithm 2.1's iterations, seconds for the whole run, minimum metric "
            "quality (2.94), share of interior q_ij ≥ 0, κ2 of the Dirichlet matrix, |e_s|_h1 "
            "(2.97) and ‖e_s‖_L2, each with its ratio to the chapter's (`/ch`).",
            tables=[report_page.Table(headers, rows)], notes=[summary + "."], figures=figures)


def figure(plotted) -> str | None:
    """κ2, |e_s|_h1 and ‖e_s‖_L2 against N, qmesh beside the chapter; None without matplotlib."""
    try:
        import matplotlib
    except ImportError:
        return None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    a = np.array(plotted, float)
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.8))
    for ax, (col, name) in zip(axes, [(2, "κ2"), (4, "|e_s|_h1"), (6, "‖e_s‖_L2")]):
        ax.loglog(a[:, 0], a[:, col], "o-", label="qmesh")
        ax.loglog(a[:, 1], a[:, col + 1], "s--", label="chapter (adapted)")
        ax.set_xlabel("N")
        ax.set_title(name)
        ax.grid(True, which="both", lw=0.3)
    axes[0].legend()
    fig.tight_layout()
    path = report_page.figure_path(__file__, "quality.png")
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


if __name__ == "__main__":
    main()
