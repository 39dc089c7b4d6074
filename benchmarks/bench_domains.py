"""Non-convex and holed domains: qmesh, stretched Triangle and MMG2D at equal N.

For each named domain (`qmesh.domains`) and each of two constant Q (the chapter's diag(0.1, 10)
and a rotated one, both of anisotropy 100), meshes with qmesh at the target N, then at qmesh's N:
- Triangle's conforming Delaunay mesh in metric coordinates y = Lᵀx (LLᵀ = ∇²s), `pq30D` with
  the maximum area bisected until N is within 3%, mapped back (`metric_peers.stretched_triangle`);
- MMG2D (mmgpy) with the metric ∇²s / h², h calibrated to within 3% (`metric_peers.mmg2d`).
Columns: N, κ2 of the Dirichlet matrix, the share of interior and of boundary q_ij ≥ 0, min
and mean metric quality (2.94), seconds (qmesh: the whole run; peers: their final run). Then the
geometric mean and the max of κ2(qmesh)/κ2(Triangle).

    python benchmarks/bench_domains.py [--n 1000] [--seed 0] [--domains "L-shape" annulus ...]
                                       [--no-page]
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

import qmesh
from qmesh import measure
from qmesh.compare import metric_peers, peers

import report_page

DOMAINS = ("L-shape", "notched square", "square with hole", "annulus", "plate with holes")
N, SEED = 1000, 0               # the target N and the seed (--n, --seed)
ANISOTROPIES = {
    "diag(0.1, 10)": qmesh.Anisotropy.constant(qmesh.CHAPTER_Q),
    "k 100, 1 at 30°": qmesh.Anisotropy.principal(100.0, 1.0, 30.0),
}


def measure_row(domain: str, q: str, mesher: str, mesh, seconds: float, A) -> dict:
    r = measure.report(mesh, A)
    return {"domain": domain, "Q": q, "mesher": mesher, "N": mesh.n_vertices, "kappa2": r["kappa2"],
            "q_int": r["q_nonnegative_fraction"], "q_bnd": measure.q_nonnegative_fraction_boundary(mesh, A),
            "min_q": r["min_quality"], "mean_q": r["mean_quality"], "seconds": seconds}


def run(domains=DOMAINS, n: int = 1000, seed: int = 0, mmg: bool = True) -> tuple[list[dict], list[str]]:
    """Rows for every domain × Q (qmesh, Triangle, MMG2D), and the cases qmesh refused."""
    rows, failures = [], []
    for name in domains:
        domain = qmesh.domains.NAMED[name]()
        for qname, A in ANISOTROPIES.items():
            t0 = time.perf_counter()
            try:
                m = qmesh.mesh(domain, A, target_vertices=n, seed=seed)
            except qmesh.QmeshError as e:
                failures.append(f"{name}, {qname}: qmesh: {e}")
                continue
            rows.append(measure_row(name, qname, "qmesh", m, time.perf_counter() - t0, A))
            p = metric_peers.stretched_triangle(domain, A, m.n_vertices)
            rows.append(measure_row(name, qname, "Triangle (stretched)", p.mesh, p.seconds, A))
            if mmg:
                p = metric_peers.mmg2d(domain, A, m.n_vertices)
                rows.append(measure_row(name, qname, "MMG2D", p.mesh, p.seconds, A))
    return rows, failures


HEADERS = ["domain", "Q", "mesher", "N", "κ2", "q_ij≥0 interior", "q_ij≥0 boundary", "min q", "mean q",
           "s"]


def cells(r: dict) -> list[str]:
    return [r["domain"], r["Q"], r["mesher"], str(r["N"]), f"{r['kappa2']:.4g}", f"{r['q_int']:.4f}",
            f"{r['q_bnd']:.4f}", f"{r['min_q']:.3f}", f"{r['mean_q']:.3f}", f"{r['seconds']:.2f}"]


def markdown(rows: list[dict]) -> str:
    out = ["| " + " | ".join(HEADERS) + " |", "|" + "---|" * len(HEADERS)]
    out += ["| " + " | ".join(cells(r)) + " |" for r in rows]
    return "\n".join(out)


def summary(rows: list[dict]) -> str:
    by_case = {}
    for r in rows:
        by_case.setdefault((r["domain"], r["Q"]), {})[r["mesher"]] = r
    ratios = [c["qmesh"]["kappa2"] / c["Triangle (stretched)"]["kappa2"] for c in by_case.values()
              if "qmesh" in c and "Triangle (stretched)" in c]
    if not ratios:
        return "no case to compare"
    ratios = np.array(ratios)
    q = [r for r in rows if r["mesher"] == "qmesh"]
    return (f"κ2(qmesh)/κ2(Triangle, stretched): geometric mean {np.exp(np.log(ratios).mean()):.3f}, "
            f"max {ratios.max():.3f} over {len(ratios)} cases; qmesh: interior q_ij≥0 min "
            f"{min(r['q_int'] for r in q):.4f}, boundary q_ij≥0 min {min(r['q_bnd'] for r in q):.4f}, "
            f"min quality min {min(r['min_q'] for r in q):.3f}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=N, help="target vertex count")
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--domains", nargs="+", default=list(DOMAINS), choices=list(qmesh.domains.NAMED))
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    has_mmg = peers.available()["mmg2d"] is None
    rows, failures = run(args.domains, args.n, args.seed, mmg=has_mmg)
    head = f"target N {args.n}, seed {args.seed}" + ("" if has_mmg else " (MMG2D not installed)")
    print(head)
    print()
    print(markdown(rows))
    print()
    print(summary(rows))
    for f in failures:
        print(f"refused: {f}")
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "Non-convex and holed domains against Triangle and MMG2D",
            "For each named domain (`qmesh.domains`) and two constant Q of anisotropy 100 (the "
            "chapter's diag(0.1, 10) and a rotated one), qmesh meshes at the target N; then, at "
            "qmesh's N, Triangle's conforming Delaunay mesh in metric coordinates y = Lᵀx "
            "(LLᵀ = ∇²s, `pq30D`, the maximum area bisected until N is within 3%, mapped back) and "
            "MMG2D (mmgpy) with the metric ∇²s / h², h calibrated to within 3%. Columns: N, κ2 of "
            "the Dirichlet matrix, the share of interior and of boundary q_ij ≥ 0, min and mean "
            "metric quality (2.94), seconds (qmesh: the whole run; peers: their final run).",
            tables=[report_page.Table(HEADERS, [cells(r) for r in rows], head)],
            notes=[summary(rows) + "."] + [f"Refused: {f}" for f in failures])


if __name__ == "__main__":
    main()
