"""Where qmesh.mesh spends its time: a cProfile table of the top functions (own time).

    python benchmarks/profile_mesher.py [--n 1e5] [--top 10] [--iso] [--no-page]

The chapter's case (Disk(512), Q = diag(0.1, 10); --iso: Q = I on Disk(30000), a co-circular
boundary), imports excluded (qmesh is imported before profiling starts).
Prints a Markdown table: function, own seconds, share of the meshing time, calls.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import time

import numpy as np

import qmesh

import report_page


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=float, default=1e5)
    ap.add_argument("--top", type=int, default=10)
    ap.add_argument("--iso", action="store_true")
    report_page.add_option(ap)
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
    head = f"N = {m.n_vertices}, {total:.2f} s under cProfile"
    print(head)
    print("| function | own s | share | calls |")
    print("|---|---|---|---|")
    table = []
    for tt, nc, name in rows[:args.top]:
        table.append([f"`{name}`", f"{tt:.2f}", f"{100 * tt / total:.0f}%", str(nc)])
        print("| " + " | ".join(table[-1]) + " |")
    if not args.no_page:
        case = ("Q = I on Disk(30000), a co-circular boundary" if args.iso
                else "the chapter's case, Q = diag(0.1, 10) on Disk(512)")
        report_page.write_page(
            __file__, sys.argv, "Where the mesher spends its time",
            f"A cProfile of one `qmesh.mesh` run, {case}, target N = {n}, imports excluded "
            "(qmesh is imported before profiling starts): the functions with the most own time, "
            "their share of the meshing time under the profiler, and their calls.",
            tables=[report_page.Table(["function", "own s", "share", "calls"], table, head)])


if __name__ == "__main__":
    main()
