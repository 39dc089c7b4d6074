"""Heterogeneous media: qmesh vs MMG2D vs Triangle at equal N.

Cases (`qmesh.domain.media_cases`, which cites the benchmarks' definitions): FVCA5 tests 4
(vertical fault: strips 0.1 high offset by 0.05 across x = 0.5, u = 1 − x on ∂Ω), 6 (oblique
drain), 7 (oblique barrier), FVCA6 test 5 on a plane (four quadrants at 1000:1, ellipses
orthogonal across x = ½, meeting at the cross point; exact u = α sin 2πx sin 2πy), a layered box
and an inclusion. For each target N:
- qmesh: `qmesh.mesh(domain, {tag: Anisotropy}, target_vertices=N)`;
- MMG2D (mmgpy) from the constrained triangulation of every region edge, triangle references =
  regions (so MMG keeps the interfaces), the per-vertex metric ∇²s_r / k_r of the vertex's
  region, the mean of its regions' for a vertex on an interface, scaled to N
  (`qmesh.compare.media_peers.mmg2d`);
- Triangle, isotropic, regions as segments (`pq30a`, area calibrated to N).
Columns: N; share of q_ij ≥ 0 on interior / interface / boundary edges (each triangle's own Q);
for the cases without a source, the discrete maximum principle on −div(Q∇u) = 0, u = g on ∂Ω
(g the case's data): vertices outside [min g, max g] (beyond 1e-10 of the range) and the worst
excess relative to the range; for FVCA6 test 5, the L2 error of the P1 solution against the
exact u (stiffness with each triangle's region K, load ∫ f φ_i and error by the degree-4
Dunavant rule with f and u of the triangle's region, u = exact = 0 on ∂Ω); κ2 of the Dirichlet
matrix; min metric quality (2.94) in each triangle's own metric, and the most the case's corners
allow it to be (benchmarks/corners.py: a triangle's angle at a corner of its region is no wider
than that corner in its metric); seconds (qmesh: the whole run;
peers: their final calibrated run). Then the geometric mean of κ2(qmesh) / κ2(MMG2D). The page
(docs/benchmarks/bench_media.md) also shows the inclusion case's and FVCA6 test 5's three
meshes at N = 2000 (with MMG2D). A case qmesh refuses is a row with its message; the peers then
mesh the target N.

    python benchmarks/bench_media.py [--n 2000 8000] [--cases fvca4 ...] [--no-mmg] [--no-page]
    python benchmarks/bench_media.py --figure screenshots/media_inclusion.png   (that PNG only)
    python benchmarks/bench_media.py --timing 100000     (layered box with and without regions;
                                                          page bench_media-timing.md)
    python benchmarks/bench_media.py --cells 25 50 100    (Domain.from_cells on n × n cells at
                                                          N = 8 n², CPU seconds; page bench_media-cells.md)
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np
import scipy.sparse.linalg as spla

import qmesh
from qmesh import measure
from qmesh.domain import media_cases
from qmesh.compare import media_peers as peers
from qmesh.geometry import quadrature

import report_page
from corners import regions_corner_bound

SHORT = {"fvca4": media_cases.fvca4, "fvca6": media_cases.fvca6, "fvca7": media_cases.fvca7,
         "fvca6_test5": media_cases.fvca6_test5,
         "layered": media_cases.layered, "inclusion": media_cases.inclusion}
NAMES = {v: k for k, v in media_cases.CASES.items()}
NS = (2000, 8000)
"""The target N of every case (--n)."""
EXACT = {media_cases.fvca6_test5: (media_cases.fvca6_test5_exact, media_cases.fvca6_test5_source)}
"""Cases with a source and an exact solution: (u(x, y, tag), f(x, y, tag))."""


def maximum_principle(mesh, cond, g) -> tuple[int, float]:
    """(vertices outside the range of g, worst excess / range) of the P1 solution of
    −div(Q∇u) = 0 with u = g on the boundary, Q per triangle."""
    K = measure.stiffness(mesh, cond).tocsr()
    bnd = mesh.boundary
    I, B = np.flatnonzero(~bnd), np.flatnonzero(bnd)
    gb = g(*mesh.points[B].T)
    u = spla.spsolve(K[I][:, I].tocsc(), -(K[I][:, B] @ gb))
    span = gb.max() - gb.min()
    excess = np.maximum(u - gb.max(), gb.min() - u) / span
    return int(np.sum(excess > 1e-10)), float(max(excess.max(), 0.0))


def p1_l2_error(mesh, cond, exact, source) -> float:
    """‖u_h − u‖_L2 of the P1 solution of −div(K∇u) = f, u_h = u at the boundary vertices: the
    stiffness with each triangle's region K (`measure.stiffness`), the load ∫ f φ_i and the error
    by the degree-4 Dunavant rule, f and u of each triangle's region (exact(x, y, tag),
    source(x, y, tag))."""
    P, T = mesh.points, mesh.triangles
    bary, w = quadrature.DUNAVANT4_POINTS, quadrature.DUNAVANT4_WEIGHTS     # (q, 3), Σ w = 1
    X = np.einsum("qa,mad->mqd", bary, P[T])                                  # (M, q, 2)
    tag = np.broadcast_to(mesh.region_tags[:, None], X.shape[:2])
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    area = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                        - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    load = area[:, None] * np.einsum("q,mq,qi->mi", w, source(X[..., 0], X[..., 1], tag), bary)
    rhs = np.bincount(T.ravel(), load.ravel(), minlength=len(P))
    K = measure.stiffness(mesh, cond).tocsr()
    bnd = mesh.boundary
    I, B = np.flatnonzero(~bnd), np.flatnonzero(bnd)
    # a boundary vertex's value from any triangle holding it (u is continuous: 0 on ∂Ω here)
    owner = np.empty(len(P), np.int64)
    owner[T.ravel()] = np.repeat(mesh.region_tags, 3)
    U = np.zeros(len(P))
    U[B] = exact(P[B, 0], P[B, 1], owner[B])
    U[I] = spla.spsolve(K[I][:, I].tocsc(), rhs[I] - K[I][:, B] @ U[B])
    uh = np.einsum("mi,qi->mq", U[T], bary)
    err = (uh - exact(X[..., 0], X[..., 1], tag)) ** 2
    return float(np.sqrt(np.sum(area * (err @ w))))


def row(case, mesher, mesh, seconds, cond, g, solution=None) -> dict:
    r = measure.report(mesh, cond, laplacian=False)
    out = {"case": case, "mesher": mesher, "N": mesh.n_vertices,
           "q_int": r["q_nonnegative_fraction"], "q_if": r.get("q_nonnegative_fraction_interface"),
           "q_bnd": r["q_nonnegative_fraction_boundary"],
           "kappa2": r["kappa2"], "min_q": r["min_quality"], "bound": regions_corner_bound(mesh, cond),
           "seconds": seconds}
    if solution is None:
        out["mp"], out["mp_worst"] = maximum_principle(mesh, cond, g)
    else:
        out["l2"] = p1_l2_error(mesh, cond, *solution)
    return out


def run(case_fns, ns, mmg=True) -> list[dict]:
    rows = []
    for fn in case_fns:
        name = NAMES[fn]
        domain, cond, g = fn()
        solution = EXACT.get(fn)
        for n in ns:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", qmesh.QmeshWarning)
                t0 = time.perf_counter()
                try:
                    m = qmesh.mesh(domain, cond, target_vertices=n)
                except qmesh.QmeshError as e:
                    m = None
                    rows.append({"case": name, "mesher": "qmesh", "target": n, "refused": str(e),
                                 "seconds": time.perf_counter() - t0})
                else:
                    rows.append(row(name, "qmesh", m, time.perf_counter() - t0, cond, g, solution))
                    rows[-1]["target"] = n
            n_peer = n if m is None else m.n_vertices
            if mmg:
                pm = peers.mmg2d(domain, cond, n_peer)
                rows.append(row(name, "MMG2D", pm.mesh, pm.seconds, cond, g, solution))
                rows[-1]["target"] = n
            pt = peers.triangle(domain, n_peer)
            rows.append(row(name, "Triangle", pt.mesh, pt.seconds, cond, g, solution))
            rows[-1]["target"] = n
            print(*(_line(r) for r in rows[-(3 if mmg else 2):]), sep="\n", flush=True)
    return rows


def _pct(x):
    return "n/a" if x is None else f"{100 * x:.1f}"


def _cells(r) -> list[str]:
    if "refused" in r:
        return [r["case"], r["mesher"], f"refused at target {r['target']}: {r['refused']}",
                "", "", "", "", "", f"{r['seconds']:.2f}"]
    return [r["case"], r["mesher"], str(r["N"]),
            f"{_pct(r['q_int'])} / {_pct(r['q_if'])} / {_pct(r['q_bnd'])}",
            f"{r['mp']} ({r['mp_worst']:.1e})" if "mp" in r else "n/a",
            f"{r['l2']:.3e}" if "l2" in r else "n/a",
            f"{r['kappa2']:.3g}", f"{r['min_q']:.3f} / {r['bound']:.3f}", f"{r['seconds']:.2f}"]


def _line(r) -> str:
    return "| " + " | ".join(_cells(r)) + " |"


HEADERS = ["case", "mesher", "N", "q_ij ≥ 0 % interior / interface / boundary",
           "max-principle violations (worst)", "L2 error (FVCA6 test 5)", "κ2", "min quality / corners' bound", "s"]
HEADER = "| " + " | ".join(HEADERS) + " |\n" + "|" + "---|" * len(HEADERS)


def figure(path, case="inclusion", n=2000) -> None:
    """qmesh, MMG2D and Triangle meshes of one case side by side: triangles coloured by region,
    edges with q_ij < 0 (each triangle's own Q) in red."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    domain, cond, _ = SHORT[case]()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(domain, cond, target_vertices=n)
    meshes = [("qmesh", m), ("MMG2D", peers.mmg2d(domain, cond, m.n_vertices).mesh),
              ("Triangle", peers.triangle(domain, m.n_vertices).mesh)]
    from matplotlib.colors import ListedColormap
    colours = ListedColormap(["#eeeeee", "#a6cee3", "#b2df8a", "#fdbf6f", "#cab2d6", "#ffff99"])
    fig, axes = plt.subplots(1, 3, figsize=(15, 5.6))
    for ax, (name, mesh) in zip(axes, meshes):
        E, q, _ = measure.edge_weights(mesh, cond)
        bad = q < -1e-9 * np.abs(q).max()
        ax.tripcolor(mesh.points[:, 0], mesh.points[:, 1], mesh.triangles,
                     facecolors=mesh.region_tags.astype(float), cmap=colours, vmin=0, vmax=5)
        ax.triplot(mesh.points[:, 0], mesh.points[:, 1], mesh.triangles, lw=0.2, color="0.35")
        ax.add_collection(LineCollection(mesh.points[E[bad]], colors="red", linewidths=1.2))
        ax.set_title(f"{name}: N = {mesh.n_vertices}, {int(bad.sum())} edges with q_ij < 0")
        ax.set_aspect("equal")
        ax.set_axis_off()
    fig.suptitle(f"{NAMES[SHORT[case]]}: regions coloured, q_ij < 0 in red (each triangle's own Q)")
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    fig.savefig(path, dpi=90)


def timing(n: int) -> str:
    """Seconds for the layered box with its regions, and for the same box with one Q."""
    domain, cond, _ = media_cases.layered()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        t0 = time.perf_counter()
        m = qmesh.mesh(domain, cond, target_vertices=n)
        t1 = time.perf_counter() - t0
        t0 = time.perf_counter()
        m2 = qmesh.mesh(qmesh.Polygon(domain.rings[0]), cond[1], target_vertices=n)
        t2 = time.perf_counter() - t0
    line = (f"layered, 5 regions: N = {m.n_vertices}, {t1:.1f} s; same box, one Q: "
            f"N = {m2.n_vertices}, {t2:.1f} s; ratio {t1 / t2:.2f}")
    print(line)
    return line


def cell_maps(n: int) -> dict:
    """Two n × n cell maps of the unit square, (k1, k2, angle) each: "3 media", a random map of
    three conductivities (1, 10:1 at 30°, 100:1 at 60°) where a value touching itself only at a
    corner is joined by an edge (from_cells refuses such a pinch), and "all differ", every cell
    its own axis-aligned k1 in [1, 100] and k1/k2 in [1, 10]."""
    rng = np.random.default_rng(1)
    v = rng.integers(0, 3, (n, n))
    while True:
        a, b, c, d = v[:-1, :-1], v[:-1, 1:], v[1:, :-1], v[1:, 1:]
        pinch = ((a == d) & (b != a) & (c != a)) | ((b == c) & (a != b) & (d != b))
        if not pinch.any():
            break
        j, i = np.nonzero(pinch)
        v[j, i + 1] = v[j + 1, i + 1]
    k1 = 10 ** (2 * rng.random((n, n)))
    return {"3 media": (np.array([1.0, 10.0, 100.0])[v], np.ones((n, n)), np.array([0.0, 30.0, 60.0])[v]),
            "all differ": (k1, k1 / 10 ** rng.random((n, n)), np.zeros((n, n)))}


VERTICES_PER_CELL = 8
"""The target N of an n × n cell map: 8 n²."""


def cell_edges(n: int) -> np.ndarray:
    """The n + 1 cell edges along each side of the unit square."""
    return np.linspace(0.0, 1.0, n + 1)


def cells_timing(sizes: list[int]) -> list[list]:
    """CPU seconds of `Domain.from_cells` and of `qmesh.mesh` at N = 8 n² on `cell_maps(n)`."""
    rows = []
    for n in sizes:
        x = cell_edges(n)
        for kind, (k1, k2, angle) in cell_maps(n).items():
            t0 = time.process_time()
            domain, cond = qmesh.Domain.from_cells(x, x, k1, k2, angle)
            t1 = time.process_time()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", qmesh.QmeshWarning)
                m = qmesh.mesh(domain, cond, target_vertices=VERTICES_PER_CELL * n * n)
            t2 = time.process_time()
            share = min(measure.q_nonnegative_fractions(m, cond).values())
            rows.append([f"{n} × {n}", kind, len(cond), VERTICES_PER_CELL * n * n, m.n_vertices, f"{share:.4f}",
                         f"{t1 - t0:.2f}", f"{t2 - t1:.1f}"])
            print(*rows[-1], sep=" | ", flush=True)
    return rows


CELL_HEADERS = ["cells", "map", "regions", "target", "N", "min share q_ij ≥ 0", "from_cells s",
                "mesh s"]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--figure", metavar="PNG", help="only draw the figure of the inclusion case")
    ap.add_argument("--timing", type=int, metavar="N", help="only time the layered box at N")
    ap.add_argument("--cells", type=int, nargs="+", metavar="n", help="only time n × n cell maps")
    ap.add_argument("--n", type=int, nargs="+", default=list(NS))
    ap.add_argument("--cases", nargs="+", choices=sorted(SHORT), default=list(SHORT))
    ap.add_argument("--no-mmg", action="store_true")
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    if args.figure:
        figure(args.figure)
        return
    if args.timing:
        line = timing(args.timing)
        if not args.no_page:
            report_page.write_page(
                __file__, sys.argv, "Heterogeneous media: the cost of regions",
                f"Seconds of `qmesh.mesh` for the layered box (`qmesh.domain.media_cases.layered`, five "
                f"regions) at target N = {args.timing}, and for the same box with one Q (the "
                f"second region's) and no interfaces.", notes=[line + "."], suffix="timing")
        return
    if args.cells:
        print(*CELL_HEADERS, sep=" | ")
        rows = cells_timing(args.cells)
        if not args.no_page:
            report_page.write_page(
                __file__, sys.argv, "Heterogeneous media: grids of cells",
                "CPU seconds of `qmesh.Domain.from_cells` and of `qmesh.mesh` at target N = 8 n² "
                "on n × n cells of the unit square (`cell_maps` in the script): a random map of "
                "three media, and every cell its own conductivity (every cell a region); the "
                "least share of `q_ij ≥ 0` over interior, boundary and interface edges.",
                tables=[report_page.Table(CELL_HEADERS, rows)], suffix="cells")
        return
    print(HEADER)
    rows = run([SHORT[c] for c in args.cases], args.n, mmg=not args.no_mmg)
    notes = summary(rows)
    print("", *notes, sep="\n")
    if not args.no_page:
        figures = []
        if "inclusion" in args.cases and not args.no_mmg:
            path = report_page.figure_path(__file__, "inclusion.png")
            figure(path)
            figures.append(report_page.Figure(
                path, "inclusion, N = 2000: qmesh, MMG2D and Triangle; regions coloured, q_ij < 0 "
                      "in red"))
        if "fvca6_test5" in args.cases and not args.no_mmg:
            path = report_page.figure_path(__file__, "fvca6_test5.png")
            figure(path, case="fvca6_test5")
            figures.append(report_page.Figure(
                path, "FVCA6 test 5 (2-D), N = 2000: qmesh, MMG2D and Triangle; quadrants "
                      "coloured, q_ij < 0 in red"))
        report_page.write_page(
            __file__, sys.argv, "Heterogeneous media against MMG2D and Triangle",
            "Cases of `qmesh.domain.media_cases` (its docstring cites the benchmarks' papers and "
            "the participant's code their data were read in): FVCA5 test 4 (vertical fault: "
            "strips 0.1 high of K2 = diag(1e2, 1e1) and K1 = diag(1e-2, 1e-3), offset by 0.05 "
            "across x = 0.5, u = 1 − x on ∂Ω), tests 6 (oblique drain) and 7 (oblique barrier) "
            "with step data, FVCA6 test 5 on a plane (quadrants K = diag(10, 0.01), diag(0.1, 100), "
            "diag(0.01, 10), diag(100, 0.1) meeting at the cross point (½, ½), exact "
            "u = α sin 2πx sin 2πy with α = 0.1, 10, 100, 0.01, f = −div(K∇u) per quadrant, "
            "u = 0 on ∂Ω), a layered box and an inclusion (step data). For each target N, qmesh "
            "(`qmesh.mesh(domain, {tag: Anisotropy}, target_vertices=N)`); MMG2D (mmgpy) from the "
            "constrained triangulation of every region edge, triangle references = regions, the "
            "per-vertex metric ∇²s_r / k_r of the vertex's region (the mean of its regions' on an "
            "interface), scaled to qmesh's N; Triangle, isotropic, regions as segments (`pq30a`, "
            "area calibrated to N). Columns: N; share of q_ij ≥ 0 on interior / interface / "
            "boundary edges (each triangle's own Q); for the cases without a source, the discrete "
            "maximum principle on −div(Q∇u) = 0, u = g on ∂Ω (g the case's data): vertices outside "
            "[min g, max g] (beyond 1e-10 of the range) and the worst excess relative to the "
            "range; for FVCA6 test 5, ‖u_h − u‖_L2 of the P1 solution (stiffness with each "
            "triangle's region K, load and error by the degree-4 Dunavant rule with the "
            "triangle's region's f and u; ‖u‖_L2 = 25.1); κ2 of the Dirichlet matrix; min metric "
            "quality (2.94) in each triangle's own metric, and the most the corners of the case's "
            "regions allow it to be (a triangle's angle at a corner of its region, on the outline "
            "or an interface, is no wider than that corner measured in the triangle's metric, "
            "and bounds its quality: `benchmarks/corners.py`); seconds (qmesh: the whole run; peers: "
            "their final calibrated run). FVCA6 test 5's u varies as fast along x as along y in "
            "every quadrant, while a mesh that follows its 1000:1 ellipses is stretched by up to "
            "√1000 ≈ 32: at equal N such a mesh interpolates u worse than an isotropic one, so its "
            "L2 column measures how well a mesh approximates this u, not the M-matrix property.",
            tables=[report_page.Table(HEADERS, [_cells(r) for r in rows])],
            notes=[n + "." for n in notes], figures=figures)


def summary(rows) -> list[str]:
    """The notes under the table: κ2 against MMG2D, qmesh's violations, quality and N, the L2
    errors' ratios and any refusal."""
    by = {(r["case"], r["target"], r["mesher"]): r for r in rows}
    q = [r for r in rows if r["mesher"] == "qmesh" and "refused" not in r]
    pairs = [(r, by[r["case"], r["target"], "MMG2D"]) for r in q
             if (r["case"], r["target"], "MMG2D") in by]
    notes = []
    if pairs:
        ratio = np.exp(np.mean([np.log(a["kappa2"] / b["kappa2"]) for a, b in pairs]))
        notes.append(f"geometric mean of κ2(qmesh) / κ2(MMG2D): {ratio:.3f}")
    if q:
        mp = [r for r in q if "mp" in r]
        notes.append(f"qmesh: {sum(r['mp'] for r in mp)} maximum-principle violations in "
                     f"{len(mp)} meshes; min quality {min(r['min_q'] for r in q):.3f}; N within "
                     f"{max(abs(r['N'] - r['target']) / r['target'] for r in q):.1%} of the target")
        short = [r for r in q if r["min_q"] < min(0.3, r["bound"]) - 5e-4]
        notes.append(f"qmesh: min quality ≥ 0.3, or at its corners' bound where that is lower, in "
                     f"{len(q) - len(short)} of {len(q)} meshes"
                     + "".join(f"; {r['case']} at {r['target']}: {r['min_q']:.3f} (bound "
                               f"{r['bound']:.3f})" for r in short))
    for r in q:
        if "l2" not in r:
            continue
        parts = [f"{r['l2'] / by[r['case'], r['target'], p]['l2']:.2f}× {p}'s"
                 for p in ("MMG2D", "Triangle") if (r["case"], r["target"], p) in by]
        notes.append(f"{r['case']}, N = {r['N']}: L2 error of qmesh {r['l2']:.3e}, "
                     + ", ".join(parts))
    for r in rows:
        if "refused" in r:
            notes.append(f"qmesh refused {r['case']} at target {r['target']}: {r['refused']}")
    return notes


if __name__ == "__main__":
    main()
