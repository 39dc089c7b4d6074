"""Speed and memory of qmesh.mesh against MMG2D (mmgpy) and Triangle on the chapter's case.

    python benchmarks/bench_mesher.py                 # ~1e5 vertices
    python benchmarks/bench_mesher.py --big           # ~1e5 and ~1e6 vertices
    python benchmarks/bench_mesher.py --sizes 2e5 --vb 1024
    python benchmarks/bench_mesher.py --domains --no-mmg  # holed domains against the disk
    python benchmarks/bench_mesher.py --no-page       # print only (no docs/benchmarks/ page)

Every case runs in its own subprocess, so peak memory (ru_maxrss) does not mix between cases;
the baseline (interpreter + imports) is printed beside the peak. qmesh is timed over the whole
`qmesh.iterate` run to convergence, with the per-stage breakdown summed from `step.stats.seconds`;
MMG2D gets the constant metric ∇²s/h² with h calibrated to the same N (qmesh.compare.peers),
and its time is that of the final, calibrated run (calibration runs are counted and timed
separately); Shewchuk's Triangle meshes the same disk isotropically (pq30a, its maximum area
calibrated to the same N by one probe run), the C limit. The case:
Q = diag(0.1, 10) on Disk(VB); the mesher adds boundary points between the VB seeds, so one VB
(default 512) serves every size. The whole `qmesh mesh … -o x.vtu` command (meshing, the
summary's measures, writing the file) is timed too, from its own process. Prints figures only:
no assertion.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from collections import defaultdict

import report_page

CHAPTER_Q = [[0.1, 0.0], [0.0, 10.0]]
VB, SIZES, BIG = 512, (1e5,), (1e5, 1e6)      # the defaults of --vb, --sizes, and with --big


def _rss_mb() -> float:
    """Peak resident set size of this process so far (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


HOLED = ("square with hole", "plate with holes", "annulus", "L-shape")
"""Named domains (qmesh.domains.NAMED) timed by --domains, with more input points so their
boundary is as fine, relative to the interior, as the disk's at the same N."""


def _domain(spec: str):
    """Disk(VB) for a number, else a named domain with finer holes/outline (see HOLED)."""
    import qmesh
    from qmesh import domains
    if spec.isdigit():
        return qmesh.Disk(int(spec))
    fine = {"square with hole": lambda: domains.square_with_hole(hole_points=256),
            "plate with holes": lambda: domains.plate_with_holes(hole_points=128),
            "annulus": lambda: domains.annulus(outer_points=512, inner_points=256)}
    return fine.get(spec, domains.NAMED[spec])()


def child_qmesh(n: int, vb: str) -> dict:
    import qmesh
    domain, aniso = _domain(vb), qmesh.Anisotropy.constant(CHAPTER_Q)
    base = _rss_mb()
    stages, iterations, last = defaultdict(float), 0, None
    t0 = time.perf_counter()
    for step in qmesh.iterate(domain, aniso, target_vertices=n, seed=0):
        stages[step.stage] += step.stats.seconds
        iterations = max(iterations, step.iteration)
        last = step
    seconds = time.perf_counter() - t0
    m = last.mesh
    return {"mesher": "qmesh", "seconds": seconds, "n_vertices": m.n_vertices,
            "n_triangles": m.n_triangles, "iterations": iterations, "converged": last.converged,
            "stages": dict(stages), "baseline_mb": base, "peak_mb": _rss_mb()}


def child_mmg(n: int, vb: int) -> dict:
    import qmesh
    from qmesh.compare import peers
    reason = peers.available()["mmg2d"]
    if reason:
        return {"mesher": "mmg2d", "skipped": reason}
    domain, aniso = qmesh.Disk(vb), qmesh.Anisotropy.constant(CHAPTER_Q)
    base = _rss_mb()
    t0 = time.perf_counter()
    pm = peers.peer_mesh("mmg2d", domain, aniso, n, rtol=0.05, max_runs=3)
    total = time.perf_counter() - t0
    return {"mesher": "mmg2d", "seconds": pm.seconds, "n_vertices": pm.mesh.n_vertices,
            "n_triangles": pm.mesh.n_triangles, "runs": pm.runs, "calibration_seconds": total,
            "baseline_mb": base, "peak_mb": _rss_mb()}


def child_triangle(n: int, vb: int) -> dict:
    """Shewchuk's Triangle (isotropic quality mesh, pq30a), the C limit: one run to measure the
    density, the timed run with the maximum area scaled so N lands near n."""
    try:
        import triangle
    except ImportError as e:
        return {"mesher": "triangle", "skipped": f"the triangle package is missing ({e})"}
    import numpy as np
    import qmesh
    domain = qmesh.Disk(vb)
    pslg = {"vertices": np.array(domain.seeds), "segments": np.array(domain.segments, np.int32)}
    base = _rss_mb()
    a = domain.area / n
    probe = triangle.triangulate(pslg, f"pq30a{a:.15f}Q")
    a *= len(probe["vertices"]) / n
    t0 = time.perf_counter()
    out = triangle.triangulate(pslg, f"pq30a{a:.15f}Q")
    seconds = time.perf_counter() - t0
    return {"mesher": "triangle", "seconds": seconds, "n_vertices": len(out["vertices"]),
            "n_triangles": len(out["triangles"]), "baseline_mb": base, "peak_mb": _rss_mb()}


def child_command(n: int, vb: int) -> dict:
    """The whole `qmesh mesh --Q 0.1 0 10 --disk VB --target-vertices N -o x.vtu` command, run
    from this (fresh) process: wall seconds from start to exit, its peak RSS (this process's
    only child), and the meshing time it prints (time=…s)."""
    import os
    import re
    import shutil
    import tempfile
    exe = shutil.which("qmesh") or "qmesh"
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [exe, "mesh", "--Q", "0.1", "0", "10", "--disk", str(vb), "--target-vertices", str(n),
               "-o", os.path.join(tmp, "x.vtu")]
        t0 = time.perf_counter()
        out = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    if out.returncode != 0:
        return {"mesher": "command", "failed": out.stderr.strip().splitlines()[-1:]}
    meshing = float(re.search(r"time=([0-9.]+)s", out.stdout).group(1))
    return {"mesher": "command", "seconds": wall, "meshing_seconds": meshing,
            "peak_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0}


def run_case(kind: str, n: int, vb, timeout: float) -> dict:
    """One case in a fresh interpreter; its JSON result (or why it failed)."""
    cmd = [sys.executable, __file__, "--child", kind, str(n), str(vb)]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"mesher": kind, "failed": f"timed out after {timeout:.0f} s"}
    if out.returncode != 0:
        return {"mesher": kind, "failed": out.stderr.strip().splitlines()[-1:] or out.returncode}
    return json.loads(out.stdout.strip().splitlines()[-1])


def report(n: int, vb: int, q: dict, m: dict, t: dict) -> None:
    print(f"\n== target N = {n:,}  (Disk(VB = {vb}), Q = diag(0.1, 10); Triangle isotropic) ==")
    for r in (q, m, t):
        name = r["mesher"]
        if "skipped" in r or "failed" in r:
            print(f"{name:>6}: {'skipped' if 'skipped' in r else 'FAILED'}: "
                  f"{r.get('skipped', r.get('failed'))}")
            continue
        extra = (f", {r['iterations']} iterations, converged={r['converged']}" if name == "qmesh"
                 else f", final of {r['runs']} calibration runs ({r['calibration_seconds']:.1f} s in all)"
                 if name == "mmg2d" else ", pq30a, area calibrated by one probe run")
        print(f"{name:>6}: {r['seconds']:8.2f} s   N = {r['n_vertices']:,}   "
              f"{r['n_vertices'] / r['seconds']:,.0f} vertices/s   peak {r['peak_mb']:,.0f} MB "
              f"(baseline {r['baseline_mb']:,.0f} MB){extra}")
    if "stages" in q:
        total = sum(q["stages"].values())
        print("  qmesh stages: " + ", ".join(
            f"{k} {v:.2f} s ({100 * v / total:.0f}%)" for k, v in sorted(q["stages"].items())))
    if "seconds" in q and "seconds" in m:
        print(f"  time ratio qmesh / MMG2D = {q['seconds'] / m['seconds']:.2f}")
    if "seconds" in q and "seconds" in t:
        print(f"  time ratio qmesh / Triangle = {q['seconds'] / t['seconds']:.1f}, "
              f"peak memory qmesh / MMG2D = "
              f"{q['peak_mb'] / m['peak_mb'] if 'peak_mb' in m else float('nan'):.2f}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--sizes", type=float, nargs="+", default=None,
                   help="target vertex counts (default 1e5; with --big also 1e6)")
    p.add_argument("--big", action="store_true", help="add the ~1e6-vertex case")
    p.add_argument("--vb", type=int, default=VB, help="boundary seed points of the disk")
    p.add_argument("--no-mmg", action="store_true", help="time qmesh only")
    p.add_argument("--domains", action="store_true",
                   help="also time qmesh on holed and non-convex domains at the same N")
    p.add_argument("--timeout", type=float, default=3600.0, help="seconds per case")
    p.add_argument("--child", nargs=3, metavar=("KIND", "N", "VB"), help=argparse.SUPPRESS)
    report_page.add_option(p)
    args = p.parse_args(argv)
    if args.child:
        kind, n, vb = args.child[0], int(args.child[1]), args.child[2]
        child = {"qmesh": lambda: child_qmesh(n, vb), "mmg2d": lambda: child_mmg(n, int(vb)),
                 "triangle": lambda: child_triangle(n, int(vb)),
                 "command": lambda: child_command(n, int(vb))}[kind]
        print(json.dumps(child()))
        return 0
    sizes = args.sizes or list(BIG if args.big else SIZES)
    if args.big and args.sizes:
        sizes = sorted(set(sizes) | {1e6})
    with report_page.capture() as printed:
        rows = run(sizes, args)
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "Speed and memory against MMG2D and Triangle",
            f"The chapter's case, Q = diag(0.1, 10) on Disk({args.vb}) (the mesher adds boundary "
            "points between the seeds), at each target N. Every case runs in its own process, so "
            "peak memory (ru_maxrss) does not mix between cases; the baseline is the interpreter "
            "and its imports. qmesh is timed over the whole `qmesh.iterate` run to convergence "
            "(per-stage seconds from `step.stats.seconds` in the output below); MMG2D (mmgpy) "
            "gets the constant metric ∇²s/h² with h calibrated to the same N, timed on its final "
            "calibrated run; Shewchuk's Triangle meshes the same disk isotropically (`pq30a`, the "
            "maximum area calibrated by one probe run). The whole `qmesh mesh … -o x.vtu` command "
            "(meshing, the summary's measures, writing the file) is timed from its own process.",
            tables=[report_page.Table(["target N", "mesher", "s", "N", "vertices/s", "peak MB",
                                       "baseline MB", "detail"], rows)],
            output=printed())
    return 0


def _row(n: int, r: dict) -> list:
    """One row of the page's table for one case's result."""
    name = r["mesher"]
    if "seconds" not in r:
        return [f"{n:,}", name, "", "", "", "", "",
                ("skipped: " + str(r["skipped"])) if "skipped" in r else f"FAILED: {r.get('failed')}"]
    nv = r.get("n_vertices")
    detail = (f"{r['iterations']} iterations, converged={r['converged']}" if name == "qmesh"
              else f"final of {r['runs']} calibration runs ({r['calibration_seconds']:.1f} s in all)"
              if name == "mmg2d" else "pq30a, area calibrated by one probe run" if name == "triangle"
              else f"whole command, meshing {r['meshing_seconds']:.2f} s" if name == "command" else "")
    return [f"{n:,}", name, f"{r['seconds']:.2f}", "" if nv is None else f"{nv:,}",
            "" if nv is None else f"{nv / r['seconds']:,.0f}", f"{r['peak_mb']:,.0f}",
            f"{r['baseline_mb']:,.0f}" if "baseline_mb" in r else "", detail]


def run(sizes, args) -> list[list]:
    """Every case of every size, printed as it comes; the page's table rows."""
    rows = []
    print(f"python {sys.version.split()[0]}; each case in its own process; VB = {args.vb}")
    for n in (int(s) for s in sizes):
        q = run_case("qmesh", n, args.vb, args.timeout)
        m = ({"mesher": "mmg2d", "skipped": "--no-mmg"} if args.no_mmg
             else run_case("mmg2d", n, args.vb, args.timeout))
        t = run_case("triangle", n, args.vb, args.timeout)
        report(n, args.vb, q, m, t)
        c = run_case("command", n, args.vb, args.timeout)
        rows += [_row(n, r) for r in (q, m, t, c)]
        if "seconds" in c:
            print(f"  the whole `qmesh mesh … -o x.vtu` command: {c['seconds']:.2f} s (meshing "
                  f"{c['meshing_seconds']:.2f} s), peak {c['peak_mb']:,.0f} MB"
                  + (f"; {c['seconds'] / t['seconds']:.1f}x Triangle's time" if "seconds" in t else ""))
        else:
            print(f"  the whole command: FAILED: {c.get('failed')}")
        if args.domains:
            for name in HOLED:
                r = run_case("qmesh", n, name, args.timeout)
                if "seconds" not in r:
                    print(f"  {name}: FAILED: {r.get('failed')}")
                    continue
                ratio = r["seconds"] / q["seconds"] if "seconds" in q else float("nan")
                print(f"  qmesh on {name}: {r['seconds']:.2f} s, N = {r['n_vertices']:,}, "
                      f"{ratio:.2f}x the disk's time, peak {r['peak_mb']:,.0f} MB")
                rows.append(_row(n, r))
                rows[-1][1] = f"qmesh on {name}"
    return rows


if __name__ == "__main__":
    raise SystemExit(main())
