"""CPU seconds of bench_fields' field cases in this checkout against another, runs interleaved.

    python benchmarks/field_against.py --other /path/to/other/checkout [--cases fvca5 layers]
           [--n 2000 20000] [--runs 3] [--no-page]

For a machine shared with other work: each run is a fresh process (`qmesh.iterate` on the case's
field, a new field each run), the two checkouts one after the other for every case and N in every
round, and each column keeps the least of the runs. Per checkout, case and target N: CPU seconds
of the set-up and first triangulation (up to the first Step), the loop's adjust, insert and
triangulate stages, certify and repair (the last Step) and the whole run; the loop's rounds (its
adjust stages); N; a hash of the mesh's points and triangles (a rewrite meant to change nothing keeps
it); and, with the element means computed by bench_fields (not the mesh's), the positive
off-diagonals K_ij > 0 (interior / boundary) and the min and mean quality (2.94). The cases and
their fields are this checkout's bench_fields' for both checkouts.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))
import report_page  # noqa: E402 — beside this script

CASES = ["fvca5", "plasma", "layers", "spiral", "islands", "raster64", "raster512"]
PARTS = ("set-up and first triangulation", "adjust", "insert", "triangulate", "certify")


def child(case: str, n: int, out: str) -> None:
    """One run in this process: CPU seconds per part, rounds, the mesh (saved to `out`)."""
    import qmesh
    from bench_fields import CASES as FIELDS
    c = FIELDS[case]
    domain, fld = c.domain(), c.field()
    cpu = dict.fromkeys(PARTS, 0.0)
    records = []
    start = last = time.process_time()
    for step in qmesh.iterate(domain, fld, target_vertices=n):
        now = time.process_time()
        records.append((step.stage, step.iteration, now - last))
        last, mesh = now, step.mesh
    total = time.process_time() - start
    for k, (stage, iteration, gap) in enumerate(records):
        if k == len(records) - 1:
            cpu["certify"] += gap
        elif k == 0:
            cpu["set-up and first triangulation"] += gap
        else:
            cpu[stage] += gap
    P, T = np.asarray(mesh.points), np.asarray(mesh.triangles)
    digest = hashlib.sha256(np.ascontiguousarray(P).tobytes()
                            + np.ascontiguousarray(T, np.int64).tobytes()).hexdigest()[:16]
    meta = {"cpu": cpu, "total": total, "rounds": sum(r[0] == "adjust" for r in records),
            "N": len(P), "hash": digest}
    np.savez(out, P=P, T=T, fixed=np.asarray(mesh.fixed), meta=json.dumps(meta))


def run(checkout: Path, case: str, n: int) -> dict:
    """One run in a fresh process with `checkout`'s qmesh."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "mesh.npz")
        env = dict(os.environ, PYTHONPATH=str(checkout))
        subprocess.run([sys.executable, __file__, "--child", case, str(n), out], env=env,
                       check=True, capture_output=True)
        with np.load(out) as z:
            r = json.loads(str(z["meta"]))
            r.update(P=z["P"], T=z["T"], fixed=z["fixed"])
    return r


def measured(case: str, r: dict) -> dict:
    """K_ij > 0 and the quality with bench_fields' own element means."""
    import bench_fields as bf
    import qmesh
    c = bf.CASES[case]
    problem = bf.sympy_problem(c) if c.kind in ("formula", "callable") else None
    Qbar = bf.independent_means(c, r["P"], r["T"], problem)
    n_in, n_b, _ = bf.positive_off_diagonals(r["P"], r["T"], Qbar)
    q = qmesh.measure.quality(qmesh.Mesh(r["P"], r["T"], r["fixed"]), Qbar)
    return {"positive": f"{n_in} / {n_b}", "min_q": float(np.nanmin(q)),
            "mean_q": float(np.nanmean(q))}


def commit_of(checkout: Path) -> str:
    done = subprocess.run(["git", "-C", str(checkout), "rev-parse", "--short=10", "HEAD"],
                          capture_output=True, text=True)
    return done.stdout.strip() if done.returncode == 0 else "(no git)"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--other", type=Path, help="the other checkout (its root)")
    ap.add_argument("--cases", nargs="+", choices=CASES, default=CASES)
    ap.add_argument("--n", type=int, nargs="+", default=[2000, 20000])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    if args.child:
        child(args.child[0], int(args.child[1]), args.child[2])
        return
    if args.other is None:
        ap.error("--other is required")
    sides = {"this": HERE, "other": args.other.resolve()}
    best: dict = {}
    for k in range(args.runs):
        for case in args.cases:
            for n in args.n:
                for name, checkout in sides.items():
                    r = run(checkout, case, n)
                    kept = best.get((name, case, n))
                    if kept is not None and kept["hash"] != r["hash"]:
                        print(f"{name} {case} {n}: another mesh in run {k + 1}", flush=True)
                    if kept is None:
                        best[(name, case, n)] = kept = r
                    kept["total"] = min(kept["total"], r["total"])   # each column its least
                    kept["cpu"] = {p: min(kept["cpu"][p], r["cpu"][p]) for p in PARTS}
                    print(f"run {k + 1} {name:5s} {case:9s} {n:6d} CPU {r['total']:.2f} s, "
                          f"{r['rounds']} rounds, N {r['N']}, hash {r['hash']}", flush=True)
    headers = ["case", "target N", "checkout", *(f"{p} CPU s" for p in PARTS), "whole run CPU s",
               "rounds", "N", "mesh hash", "K_ij > 0 interior / boundary", "min quality",
               "mean quality"]
    rows = []
    for case in args.cases:
        for n in args.n:
            for name in sides:
                r = best[(name, case, n)]
                m = measured(case, r)
                rows.append([case, n, name, *(f"{r['cpu'][p]:.3f}" for p in PARTS),
                             f"{r['total']:.3f}", r["rounds"], r["N"], r["hash"], m["positive"],
                             f"{m['min_q']:.3f}", f"{m['mean_q']:.3f}"])
    table = report_page.markdown_table(headers, rows)
    print(table)
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "A field's stages in this checkout against another",
            __doc__.split("\n\n")[2].replace("\n", " "),
            tables=[report_page.Table(headers, rows, f"best of {args.runs} runs; this: "
                                      f"{commit_of(HERE)}, other: {commit_of(sides['other'])}")],
            output=table)


if __name__ == "__main__":
    main()
