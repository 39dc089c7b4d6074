"""Sharp corners in the metric: the smallest corner that meshes, and what its triangles can be.

A quadrilateral whose corner at the origin is θ wide in the metric of Q = principal(1, 30, 20°)
(sides 1 and 0.5 there, its other corners wide), meshed at a few targets: the outcome (N, the
shares of interior and boundary q_ij ≥ 0, or the refusal's first words), the worst metric
quality beside the bound any mesh of that corner has (benchmarks/corners.py), and the time.

    python benchmarks/bench_corners.py [--no-page]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np

import report_page
from corners import corner_bound

ANGLES = (2.0, 1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01)
TARGETS = (300, 1000, 3000)


def polygon(theta: float):
    """The quadrilateral in user coordinates and its Q: built in metric coordinates, turned by
    1 radian, mapped back by H^{-1/2} (angles between its sides in the metric are theta's)."""
    import qmesh
    A = qmesh.Anisotropy.principal(1.0, 30.0, 20.0)
    t = np.radians(theta)
    X = np.array([[0, 0], [1, 0], [1, 1], [0.5 * np.cos(t), 0.5 * np.sin(t)]])
    w, V = np.linalg.eigh(np.asarray(A.H, float))
    c, s = np.cos(1.0), np.sin(1.0)
    return X @ np.array([[c, s], [-s, c]]) @ (V @ np.diag(w ** -0.5) @ V.T), A


def run(theta: float, n: int) -> list[str]:
    import qmesh
    P, A = polygon(theta)
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", qmesh.QmeshWarning)
            m = qmesh.mesh(qmesh.Polygon(P), A, target_vertices=n)
    except qmesh.QmeshError as e:
        return [f"{theta:g}", str(n), "refused: " + " ".join(str(e).split()[:8]), "", "", "", "",
                f"{time.perf_counter() - t0:.2f}"]
    seconds = time.perf_counter() - t0
    r = qmesh.measure.report(m, A)
    bound = corner_bound(m.points, m.triangles, np.broadcast_to(A.matrix, (m.n_triangles, 2, 2)))
    share = r["q_nonnegative_fraction"]
    return [f"{theta:g}", str(n), str(m.n_vertices), "—" if share is None else f"{share:.4f}",
            f"{r['q_nonnegative_fraction_boundary']:.4f}", f"{r['min_quality']:.4f}",
            f"{bound:.4f}", f"{seconds:.2f}"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-page", action="store_true", help="print the table only")
    args = ap.parse_args(argv)
    headers = ["corner (°)", "target", "N", "interior q ≥ 0", "boundary q ≥ 0", "min quality",
               "corner bound", "seconds"]
    print("| " + " | ".join(headers) + " |")
    rows = []
    for theta in ANGLES:
        for n in TARGETS:
            rows.append(run(theta, n))
            print("| " + " | ".join(rows[-1]) + " |", flush=True)
    refused = [r[2].startswith("refused") for r in rows]
    every = [t for t in ANGLES if not any(f for r, f in zip(rows, refused) if float(r[0]) == t)]
    summary = (f"{len(rows) - sum(refused)} of {len(rows)} meshed; the smallest corner meshed at "
               f"every target: {min(every):g}°." if every else "no corner meshed at every target.")
    print(summary)
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "Sharp corners in the metric",
            "A quadrilateral whose corner at the origin is θ wide in the metric of "
            "Q = principal(1, 30, 20°) — sides 1 and 0.5 there, its other corners wide — at "
            "three targets. Columns: θ, the target N, the mesh's N (or the refusal's first "
            "words), the shares of interior and boundary q_ij ≥ 0 (— where no edge is "
            "interior), the worst metric quality (2.94), the best any mesh with a vertex at "
            "that corner can have (a triangle's angle there is at most θ: "
            "`benchmarks/corners.py`), and the seconds of `qmesh.mesh`.",
            tables=[report_page.Table(headers, rows)], notes=[summary])


if __name__ == "__main__":
    main()
