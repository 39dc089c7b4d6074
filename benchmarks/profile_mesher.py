"""Where qmesh.mesh spends its time: a cProfile table of the top functions (own time).

    python benchmarks/profile_mesher.py [--n 1e5] [--top 10] [--iso]

The chapter's case (Disk(512), Q = diag(0.1, 10); --iso: Q = I on Disk(30000), the co-circular
boundary of issue 20), imports excluded (qmesh is imported before profiling starts).
Prints a Markdown table: function, own seconds, share of the meshing time, calls.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time

import numpy as np

import qmesh


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=float, default=1e5)
    ap.add_argument("--top", type=int, default=10)
    ap.add_argument("--iso", action="store_true")
    args = ap.parse_args(argv)
    n = int(args.n)
    if args.iso:
        domain, A = qmesh.Disk(30000), qmesh.Anisotropy.constant(np.eye(2))
    else:
        domain, A = qmesh.Disk(512), qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    m = qmesh.mesh(domain, A, target_vertices=n)
    prof.disable()
    total = time.perf_counter() - t0
    stats = pstats.Stats(prof).stats
    rows = sorted(((tt, nc, f"{fn.rsplit('/', 2)[-2]}/{fn.rsplit('/', 1)[-1]}:{name}"
                    if "/" in fn else name)
                   for (fn, line, name), (cc, nc, tt, ct, callers) in stats.items()), reverse=True)
    print(f"N = {m.n_vertices}, {total:.2f} s under cProfile")
    print("| function | own s | share | calls |")
    print("|---|---|---|---|")
    for tt, nc, name in rows[:args.top]:
        print(f"| `{name}` | {tt:.2f} | {100 * tt / total:.0f}% | {nc} |")


if __name__ == "__main__":
    main()
