"""Inputs whose cost once did not follow N, each timed in its own process with its
peak memory: the co-circular isotropic disk beside the same disk under Q = diag(0.1, 10), the
steep varying s on Disk(32), and the extreme scales.

    python benchmarks/bench_scale_cases.py [--quick] [--no-page]

Prints a Markdown table: case, outcome (N, or the QmeshError's first words), seconds inside
qmesh.mesh, peak RSS of the process (MB).
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import report_page

SQUARE = [[0, 0], [1, 0], [1, 1], [0, 1]]


def _cases():
    """name → (domain, anisotropy, target N), built in the child process."""
    import numpy as np
    import qmesh
    expr = qmesh.Anisotropy.from_expression
    return {
        "Disk(30000), Q = I, N = 36000":
            lambda: (qmesh.Disk(30000), qmesh.Anisotropy.constant(np.eye(2)), 36000),
        "Disk(30000), Q = diag(0.1, 10), N = 36000":
            lambda: (qmesh.Disk(30000), qmesh.Anisotropy.constant(np.diag([0.1, 10])), 36000),
        "Disk(32), s = (x²+y²+1)^20, N = 3000":
            lambda: (qmesh.Disk(32), expr("(x**2+y**2+1)**20"), 3000),
        "Disk(32), s = exp(10(x²+y²)), N = 3000":
            lambda: (qmesh.Disk(32), expr("exp(10*(x**2+y**2))"), 3000),
        "Disk(32), s = exp(20x)+exp(20y), N = 3000":
            lambda: (qmesh.Disk(32), expr("exp(20*x)+exp(20*y)"), 3000),
        "square of side 1e300, Q = I, N = 1000":
            lambda: (qmesh.Polygon(np.array(SQUARE) * 1e300), qmesh.Anisotropy.constant(np.eye(2)), 1000),
        "square of side 1e-300, Q = I, N = 1000":
            lambda: (qmesh.Polygon(np.array(SQUARE) * 1e-300), qmesh.Anisotropy.constant(np.eye(2)), 1000),
        "Disk(16, radius=1e-7), s = exp(x)+y², N = 300":
            lambda: (qmesh.Disk(16, radius=1e-7), expr("exp(x)+y**2"), 300),
    }


NAMES = ["Disk(30000), Q = I, N = 36000", "Disk(30000), Q = diag(0.1, 10), N = 36000",
         "Disk(32), s = (x²+y²+1)^20, N = 3000", "Disk(32), s = exp(10(x²+y²)), N = 3000",
         "Disk(32), s = exp(20x)+exp(20y), N = 3000", "square of side 1e300, Q = I, N = 1000",
         "square of side 1e-300, Q = I, N = 1000", "Disk(16, radius=1e-7), s = exp(x)+y², N = 300"]


def child(name: str) -> dict:
    import qmesh
    domain, A, n = _cases()[name]()
    t0 = time.perf_counter()
    try:
        m = qmesh.mesh(domain, A, target_vertices=n)
        outcome = f"N = {m.n_vertices}"
    except qmesh.QmeshError as e:
        outcome = "QmeshError: " + " ".join(str(e).split()[:9]) + " …"
    return {"outcome": outcome, "seconds": time.perf_counter() - t0,
            "rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--quick", action="store_true", help="leave out the two Disk(30000) cases")
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(child(args.child)))
        return
    print("| case | outcome | s | peak MB |")
    print("|---|---|---|---|")
    rows = []
    for name in NAMES:
        if args.quick and "30000" in name:
            continue
        out = subprocess.run([sys.executable, __file__, "--child", name], capture_output=True,
                             text=True, timeout=1800)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append([name, r["outcome"], f"{r['seconds']:.2f}", f"{r['rss']:.0f}"])
        print("| " + " | ".join(rows[-1]) + " |", flush=True)
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "Inputs whose cost once did not follow N",
            "Each case runs in its own process: the co-circular isotropic Disk(30000) beside the "
            "same disk under Q = diag(0.1, 10), steep varying s on Disk(32), and extreme scales. "
            "Columns: the case, its outcome (N, or the QmeshError's first words), seconds inside "
            "`qmesh.mesh`, and the process's peak resident memory (MB, ru_maxrss, imports "
            "included).", tables=[report_page.Table(["case", "outcome", "s", "peak MB"], rows)])


if __name__ == "__main__":
    main()
