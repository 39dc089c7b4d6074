"""Where the field benchmark's meshes keep triangles below metric quality 0.3, and why.

Each case of `bench_fields.py` the fields guide lists (fvca5, plasma, layers, spiral, islands,
raster64) is meshed at each N, and every triangle whose quality (2.94) in its own metric
H_T = adj Q̄_T / √det Q̄_T (the mesh's own means, as the polish judges it) is below 0.3 is
put in the first class it falls in, each "near" meaning within 3 of the triangle's own longest
edges:

- corner: near a corner of the domain (the outline's or a hole's) whose wedge, measured in the
  triangle's metric, is narrower than 60°: a triangle there has quality at most
  2√3 sin α / (2 + 4 sin²(α/2)) (the fields guide), and its neighbours grade away from it;
- singular: near a point where Q has no limit (the case's singular points: FVCA5's (0, 0),
  the islands' O- and X-points) or the rim of a hole cut around one (plasma's, spiral's);
- raster: beside a cell line of a raster whose cells all differ;
- touch: near a point where a field line touches a side of the domain (Q's major axis turns
  through the side's direction there: tᵀQn changes sign along the side with tᵀQt > nᵀQn, t
  the side's direction and n its normal, found on the mesh's boundary vertices);
- elsewhere: none of these.

The table gives each class's count and worst quality, and the CPU seconds of the run
(`qmesh.mesh`, in this process). A second table lists the `--show` worst triangles left
elsewhere: where they are, their corners (a seed, on a side, inside) and how far they lie from
a sharp corner, a singular point and a touch, in their longest edges.

    python benchmarks/quality_fields.py [--cases islands ...] [--n 2000 20000] [--show 3]
                                        [--no-page]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import qmesh
from qmesh import measure
from qmesh.conductivity.anisotropy import shape_metric

sys.path.insert(0, str(Path(__file__).resolve().parent))
import report_page  # noqa: E402 — beside this script, imported before measuring
from bench_fields import CASES  # noqa: E402

FLOOR = 0.3
NEAR = 3.0                       # "near": within this many of the triangle's longest edges
GUIDE_CASES = ("fvca5", "plasma", "layers", "spiral", "islands", "raster64")
CLASSES = ("corner", "singular", "raster", "touch", "elsewhere")
HOLE = ((0.5, 0.5), 0.15)        # the hole the plasma and spiral cases cut around (½, ½)


def boundary_walk(mesh):
    """Each boundary vertex's next and previous boundary vertex (Ω on the left), −1 elsewhere."""
    E = mesh.boundary_edges
    nxt, prv = np.full(mesh.n_vertices, -1), np.full(mesh.n_vertices, -1)
    nxt[E[:, 0]], prv[E[:, 1]] = E[:, 1], E[:, 0]
    return nxt, prv


def domain_corners(mesh):
    """The boundary vertices where the boundary turns, and their wedges' two unit directions."""
    P = mesh.points
    nxt, prv = boundary_walk(mesh)
    v = np.flatnonzero(nxt >= 0)
    u, w = P[nxt[v]] - P[v], P[prv[v]] - P[v]
    turn = np.abs(u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]) > 1e-9 * np.hypot(*u.T) * np.hypot(*w.T)
    v, u, w = v[turn], u[turn], w[turn]
    return v, u / np.hypot(*u.T)[:, None], w / np.hypot(*w.T)[:, None]


def wedge_angles(H, u, w):
    """The angle between directions u and w (k, 2) in metrics H (m, 2, 2): (m, k)."""
    uu = np.einsum("ki,mij,kj->mk", u, H, u)
    ww = np.einsum("ki,mij,kj->mk", w, H, w)
    uw = np.einsum("ki,mij,kj->mk", u, H, w)
    cross = np.sqrt(np.maximum(uu * ww - uw ** 2, 0.0))         # |u × w| measured in H
    angle = np.arctan2(cross, uw)
    convex = (u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]) > 0          # Ω to the left of u, w → u
    return np.where(convex[None], angle, 2 * np.pi - angle)


def touch_points(mesh, field):
    """The points where a field line touches a side: the boundary vertices between two boundary
    edges of one side at whose midpoints tᵀQn has opposite signs while the field runs along the
    side (tᵀQt > nᵀQn)."""
    P = mesh.points
    nxt, _ = boundary_walk(mesh)
    a = np.flatnonzero(nxt >= 0)
    t = P[nxt[a]] - P[a]
    t = t / np.hypot(*t.T)[:, None]
    n = np.column_stack([-t[:, 1], t[:, 0]])
    Q = np.asarray(field(P[a] + 0.5 * (P[nxt[a]] - P[a])), float)
    g = np.einsum("ki,kij,kj->k", t, Q, n)
    along = np.einsum("ki,kij,kj->k", t, Q, t) > np.einsum("ki,kij,kj->k", n, Q, n)
    edge = np.full(mesh.n_vertices, -1)
    edge[a] = np.arange(len(a))
    e2 = edge[nxt[a]]                                  # the edge after each, from its end
    same = np.abs(t[:, 0] * t[e2, 1] - t[:, 1] * t[e2, 0]) < 1e-9
    at = same & (np.sign(g) != np.sign(g[e2])) & along & along[e2]
    return P[nxt[a[at]]]


def _distance(c, points):
    """The distance of each point c (m, 2) to the nearest of `points` (k, 2) (inf: none)."""
    if not len(points):
        return np.full(len(c), np.inf)
    return np.hypot(*(c[:, None] - np.asarray(points, float)[None]).transpose(2, 0, 1)).min(axis=1)


def classify(case, mesh, field, q):
    """The class (an index into CLASSES) of every triangle with q < FLOOR, those triangles, and
    their distances (in their longest edges) to the nearest corner, singular point and touch."""
    P, T, Qbar = mesh.points, mesh.triangles, mesh.conductivity
    low = np.flatnonzero(q < FLOOR)
    X = P[T[low]]
    c = X.mean(axis=1)
    size = np.hypot(*(X - X[:, [1, 2, 0]]).transpose(2, 0, 1)).max(axis=1)
    H = shape_metric(Qbar[low])                  # the metric the quality is measured in
    v, u, w = domain_corners(mesh)
    sharp = wedge_angles(H, u, w) < np.pi / 3
    to_corner = np.where(sharp, np.hypot(*(c[:, None] - P[v][None]).transpose(2, 0, 1)), np.inf)
    d_corner = to_corner.min(axis=1, initial=np.inf) / size
    d_singular = _distance(c, case.singular)
    if case.hole:
        d_singular = np.minimum(d_singular, np.abs(_distance(c, [HOLE[0]]) - HOLE[1]))
    d_singular = d_singular / size
    if case.kind == "raster":
        k = case.cells
        lo, hi = np.floor(X.min(axis=1) * k), np.floor(X.max(axis=1) * k)
        gap = np.minimum(np.abs(c * k - np.round(c * k)).min(axis=1) / k, 1.0)
        raster = (lo != hi).any(axis=1) | (gap < NEAR * size)
        d_touch = np.full(len(low), np.inf)
    else:
        raster = np.zeros(len(low), bool)
        d_touch = _distance(c, touch_points(mesh, field)) / size
    cls = np.select([d_corner < NEAR, d_singular < NEAR, raster, d_touch < NEAR],
                    [0, 1, 2, 3], default=4)
    return low, cls, np.column_stack([d_corner, d_singular, d_touch])


def run(name, n, show):
    """One case at one target: its table row and its `show` worst triangles left elsewhere."""
    case = CASES[name]
    field = case.field()
    t0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        mesh = qmesh.mesh(case.domain(), field, target_vertices=n)
    cpu = time.process_time() - t0
    q = measure.quality(mesh, mesh.conductivity)
    low, cls, dist = classify(case, mesh, field, q)
    row = [name, n, mesh.n_vertices, f"{cpu:.1f}", len(low), f"{np.nanmin(q):.3f}"]
    for k in range(len(CLASSES)):
        at = cls == k
        row.append(f"{int(at.sum())} ({q[low[at]].min():.3f})" if at.any() else "0")
    P, T = mesh.points, mesh.triangles
    on = np.zeros(mesh.n_vertices, bool)
    on[mesh.boundary_edges.ravel()] = True
    shown = []
    for i in np.flatnonzero(cls == 4)[np.argsort(q[low[cls == 4]])][:show]:
        t = low[i]
        c = P[T[t]].mean(axis=0)
        kinds = ", ".join("seed" if mesh.fixed[x] else "side" if on[x] else "inner" for x in T[t])
        shown.append([name, n, f"{q[t]:.3f}", f"({c[0]:.4f}, {c[1]:.4f})", kinds,
                      *(f"{d:.1f}" for d in dist[i])])
    return row, shown


HEADERS = ["case", "target N", "N", "CPU s", "below 0.3", "min",
           *(f"{c} (worst)" for c in CLASSES)]
SHOWN = ["case", "target N", "quality", "centroid", "its corners", "from a sharp corner",
         "from a singular point", "from a touch"]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=list(GUIDE_CASES), choices=sorted(CASES))
    ap.add_argument("--n", nargs="+", type=int, default=[2000, 20000])
    ap.add_argument("--show", type=int, default=3, help="the K worst triangles left elsewhere")
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    rows, shown = [], []
    for n in args.n:
        for name in args.cases:
            row, worst = run(name, n, args.show)
            rows.append(row)
            shown += worst
            print(" | ".join(map(str, row)), flush=True)
    print(report_page.markdown_table(HEADERS, rows))
    print(report_page.markdown_table(SHOWN, shown))
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv if argv is None else ["benchmarks/quality_fields.py", *argv],
            "Where the field meshes keep triangles below quality 0.3",
            __doc__.split("\n\n", 1)[1].rsplit("\n\n", 1)[0],
            tables=[report_page.Table(HEADERS, rows, "Triangles below 0.3 by class: count "
                                      "(worst quality)"),
                    report_page.Table(SHOWN, shown, "The worst triangles elsewhere (distances "
                                      "in their longest edges)")])


if __name__ == "__main__":
    main()
