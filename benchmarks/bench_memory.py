"""Peak memory per vertex of `qmesh.mesh`, for constant and varying s: the figures behind
`qmesh.mesher.budget.BYTES_PER_VERTEX`.

Each case runs in a fresh Python process: after the imports and a tiny warm-up mesh, its resident
memory is the baseline; after `qmesh.mesh` its peak resident memory (getrusage ru_maxrss); the
difference over the vertices made is the figure printed.

    python benchmarks/bench_memory.py [--sizes 10000 100000 400000] [--vb 256] [--no-page]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

import report_page

CHILD = r"""
import json, resource, sys, time
import qmesh
n, varying, vb = int(sys.argv[1]), sys.argv[2] == "1", int(sys.argv[3])
A = (qmesh.Anisotropy.from_expression("exp(x) + y**2") if varying
     else qmesh.Anisotropy.constant(qmesh.CHAPTER_Q))
qmesh.mesh(qmesh.Disk(16), A, target_vertices=100, seed=0)          # warm-up: lazy imports
def rss():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
base = rss()
t = time.perf_counter()
m = qmesh.mesh(qmesh.Disk(vb), A, target_vertices=n, seed=0)
seconds = time.perf_counter() - t
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"n": m.n_vertices, "base": base, "peak": peak, "seconds": seconds}))
"""


def measure(n: int, varying: bool, vb: int) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, str(n), "1" if varying else "0", str(vb)],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", nargs="+", type=int, default=[10_000, 100_000, 400_000])
    p.add_argument("--vb", type=int, default=256)
    p.add_argument("--kinds", nargs="+", default=["constant", "varying"],
                   choices=["constant", "varying"])
    report_page.add_option(p)
    a = p.parse_args()
    rows = []
    print(f"{'s':<10}{'target':>9}{'N':>9}{'base MB':>9}{'peak MB':>9}{'B/vertex':>10}"
          f"{'mesh s':>8}")
    for kind in a.kinds:
        for n in a.sizes:
            t = time.perf_counter()
            r = measure(n, kind == "varying", a.vb)
            per = (r["peak"] - r["base"]) / r["n"]
            print(f"{kind:<10}{n:>9}{r['n']:>9}{r['base'] / 1e6:>9.0f}{r['peak'] / 1e6:>9.0f}"
                  f"{per:>10.0f}{r['seconds']:>8.1f}   ({time.perf_counter() - t:.0f} s in all)",
                  flush=True)
            rows.append([kind, n, r["n"], f"{r['base'] / 1e6:.0f}", f"{r['peak'] / 1e6:.0f}",
                         f"{per:.0f}", f"{r['seconds']:.1f}"])
    if not a.no_page:
        report_page.write_page(
            __file__, sys.argv, "Peak memory per vertex",
            f"Peak memory of `qmesh.mesh` on Disk({a.vb}) for a constant Q (the chapter's "
            "diag(0.1, 10)) and a varying s (`exp(x) + y**2`): the figures behind "
            "`qmesh.mesher.budget.BYTES_PER_VERTEX`. Each case runs in a fresh Python process; "
            "after the imports and a tiny warm-up mesh its resident memory is the baseline, after "
            "`qmesh.mesh` its peak resident memory (getrusage ru_maxrss); bytes per vertex = "
            "(peak − baseline) / N. MB are 10^6 bytes; the last column is the seconds inside "
            "`qmesh.mesh`.",
            tables=[report_page.Table(["s", "target", "N", "base MB", "peak MB", "B/vertex",
                                       "mesh s"], rows)])


if __name__ == "__main__":
    main()
