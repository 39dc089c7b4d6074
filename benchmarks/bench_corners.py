"""Sharp corners in the metric: the smallest corner that meshes, and what its triangles can be.

A quadrilateral whose corner at the origin is θ wide in the metric of Q = principal(1, 30, 20°)
(sides 1 and 0.5 there, its other corners wide), meshed at a few targets: the outcome (N, the
shares of interior and boundary q_ij ≥ 0, or the refusal's first words), the worst metric
quality beside the bound any mesh of that corner has (benchmarks/corners.py), and the time.
Then the same quadrilateral as region 1 of a medium, in a rectangle of region 0 under
Q = principal(1, 5, 70°): its corner inside (both sides interfaces) or on the outline (its
first side on the rectangle's side), with the shares of q_ij ≥ 0 on interface edges too.

    python benchmarks/bench_corners.py [--no-page]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np

import report_page
from corners import corner_bound, regions_corner_bound

ANGLES = (2.0, 1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01)
TARGETS = (300, 1000, 3000)
MEDIA_ANGLES = (2.0, 0.5, 0.1, 0.02, 0.01)


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


def medium(theta: float, where: str):
    """The quadrilateral as region 1 in a rectangle of region 0 whose sides run along and
    across its first side (from the corner): "inside", a margin of 0.3 of its size all round;
    "outline", the rectangle's side through that first side. And {tag: Anisotropy}."""
    import qmesh
    P, A = polygon(theta)
    u = (P[1] - P[0]) / np.hypot(*(P[1] - P[0]))
    frame = np.array([u, [-u[1], u[0]]])                  # rows: along, across the first side
    Y = (P - P[0]) @ frame.T
    lo, hi = Y.min(axis=0), Y.max(axis=0)
    m = 0.3 * (hi - lo).max()
    bottom = 0.0 if where == "outline" else lo[1] - m
    box = np.array([[lo[0] - m, bottom], [hi[0] + m, bottom], [hi[0] + m, hi[1] + m],
                    [lo[0] - m, hi[1] + m]]) @ frame + P[0]
    return qmesh.Domain(box, regions=[P]), {0: qmesh.Anisotropy.principal(1.0, 5.0, 70.0), 1: A}


def run(theta: float, n: int, where: str | None = None) -> list[str]:
    import qmesh
    if where is None:
        P, cond = polygon(theta)
        domain = qmesh.Polygon(P)
    else:
        domain, cond = medium(theta, where)
    first = [f"{theta:g}", str(n)] if where is None else [where, f"{theta:g}", str(n)]
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", qmesh.QmeshWarning)
            m = qmesh.mesh(domain, cond, target_vertices=n)
    except qmesh.QmeshError as e:
        return first + ["refused: " + " ".join(str(e).split()[:8])] + [""] * (
            4 if where is None else 5) + [f"{time.perf_counter() - t0:.2f}"]
    seconds = time.perf_counter() - t0
    r = qmesh.measure.report(m, cond, laplacian=False)
    if where is None:
        Qbar = np.broadcast_to(cond.matrix, (m.n_triangles, 2, 2))
        bound = corner_bound(m.points, m.triangles, Qbar)
    else:
        bound = regions_corner_bound(m, cond)
    share = r["q_nonnegative_fraction"]
    shares = ["—" if share is None else f"{share:.4f}"]
    if where is not None:
        shares.append(f"{r['q_nonnegative_fraction_interface']:.4f}")
    return first + [str(m.n_vertices)] + shares + [
        f"{r['q_nonnegative_fraction_boundary']:.4f}", f"{r['min_quality']:.4f}",
        f"{bound:.4f}", f"{seconds:.2f}"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    report_page.add_option(ap)
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
    media_headers = ["where", *headers[:3], "interior q ≥ 0", "interface q ≥ 0", *headers[4:]]
    print("| " + " | ".join(media_headers) + " |")
    media_rows = []
    for where in ("inside", "outline"):
        for theta in MEDIA_ANGLES:
            for n in TARGETS:
                media_rows.append(run(theta, n, where))
                print("| " + " | ".join(media_rows[-1]) + " |", flush=True)
    meshed = [r for r in media_rows if not r[3].startswith("refused")]
    signs = sum(all(c in ("1.0000", "—") for c in r[4:7]) for r in meshed)
    near = sum(abs(int(r[3]) - int(r[2])) <= 0.1 * int(r[2]) for r in meshed)
    media = (f"Media: {len(meshed)} of {len(media_rows)} meshed, {signs} with every q_ij ≥ 0, "
             f"{near} within 10% of the target (the others warned).")
    print(media)
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "Sharp corners in the metric",
            "A quadrilateral whose corner at the origin is θ wide in the metric of "
            "Q = principal(1, 30, 20°) — sides 1 and 0.5 there, its other corners wide — at "
            "three targets. Columns: θ, the target N, the mesh's N (or the refusal's first "
            "words), the shares of interior and boundary q_ij ≥ 0 (— where no edge is "
            "interior), the worst metric quality (2.94), the best any mesh with a vertex at "
            "that corner can have (a triangle's angle there is at most θ: "
            "`benchmarks/corners.py`), and the seconds of `qmesh.mesh`. Then the same "
            "quadrilateral as region 1 of a medium in a rectangle of region 0 under "
            "Q = principal(1, 5, 70°), its corner inside (both sides interfaces) or on the "
            "outline (its first side on the rectangle's), with the share of q_ij ≥ 0 on "
            "interface edges (each side's, MEDIA.md §2) and the corners' bound of every region.",
            tables=[report_page.Table(headers, rows),
                    report_page.Table(media_headers, media_rows)],
            notes=[summary, media])


if __name__ == "__main__":
    main()
