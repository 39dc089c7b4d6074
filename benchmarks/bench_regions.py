"""Cost against the number of regions: building the domain, refusing it, meshing it.

Hexagonal inclusions on a grid in the unit square (a constant anisotropy inside them, another
outside), a plain box at the same N beside them; a refusal of 1,000 inclusions (one pair
overlapping, and a target below the input points); `Domain.from_cells` on n × n cells whose
conductivities all differ (domain built, meshing not started). Times are this process's CPU
seconds (time.process_time): the other processes of a shared machine do not count; a mesh's
and the box's are the least of --repeat runs.

    python benchmarks/bench_regions.py [--inclusions 100 300 1000] [--n 5000 5000 20000]
                                       [--cells 50 100 200] [--repeat 3] [--no-mesh] [--no-page]
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

import report_page  # noqa: I001  (the run's start time is taken on import)

import qmesh

P = qmesh.Anisotropy.principal
INSIDE, OUTSIDE = P(10.0, 1.0, 30.0), P(1.0, 4.0, -20.0)
INCLUSIONS, TARGETS = (100, 300, 1000), (5000, 5000, 20000)    # the defaults of --inclusions, --n
FEW = 6     # vertices per inclusion: a target below the input points, refused


def hexagons(n: int, overlap: bool = False) -> list[np.ndarray]:
    """n hexagons on a grid in the unit square, radius a third of the spacing; with `overlap`
    the last one moved onto its neighbour."""
    k = int(np.ceil(np.sqrt(n)))
    step = 1.0 / k
    t = np.pi / 3 * np.arange(6)
    unit = np.column_stack([np.cos(t), np.sin(t)]) * step / 3
    c = (np.stack(np.meshgrid(np.arange(k), np.arange(k)), -1).reshape(-1, 2)[:n] + 0.5) * step
    out = [ci + unit for ci in c]
    if overlap:
        out[-1] = out[-2] + [0.3 * step, 0.0]
    return out


def timed(f, repeat: int = 1):
    """(CPU seconds, result) of f(), the least of `repeat` runs: CPU time, so the machine's other
    processes do not count, and the least of a few, since sharing the cores still slows a run."""
    best = None
    for _ in range(repeat):
        t = time.process_time()
        try:
            out = f()
        except qmesh.QmeshError as e:
            out = e
        dt = time.process_time() - t
        best = dt if best is None else min(best, dt)
    return best, out


def box(regions):
    return qmesh.Domain([(0, 0), (1, 0), (1, 1), (0, 1)], regions=regions)


def conductivity(n: int) -> dict:
    """OUTSIDE for region 0, INSIDE for each of n inclusions."""
    return {0: OUTSIDE, **{k: INSIDE for k in range(1, n + 1)}}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--inclusions", type=int, nargs="+", default=list(INCLUSIONS))
    ap.add_argument("--n", type=int, nargs="+", default=list(TARGETS),
                    help="target vertices, one per --inclusions entry")
    ap.add_argument("--cells", type=int, nargs="+", default=[50, 100, 200])
    ap.add_argument("--no-mesh", action="store_true", help="only build and refuse domains")
    ap.add_argument("--repeat", type=int, default=3, help="meshes timed this many times, the least kept")
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    rows_dom, rows_mesh, rows_cells = [], [], []
    for n, N in zip(args.inclusions, args.n):
        t_dom, d = timed(lambda: box(hexagons(n)))
        t_bad, err = timed(lambda: box(hexagons(n, overlap=True)))
        t_few, err2 = timed(lambda: qmesh.mesh(d, conductivity(n), target_vertices=FEW * n))
        rows_dom.append([n, FEW * n, f"{t_dom:.2f}", f"{t_bad:.2f}", f"{t_few:.2f}",
                         str(err).split(":")[0][:60]])
        print(f"{n} inclusions: domain {t_dom:.2f} s, overlap refused {t_bad:.2f} s, "
              f"target {FEW * n} refused {t_few:.2f} s ({str(err2)[:70]})", flush=True)
        if args.no_mesh:
            continue
        cond = conductivity(n)
        t_m, m = timed(lambda: qmesh.mesh(d, cond, target_vertices=N), args.repeat)
        t_b, b = timed(lambda: qmesh.mesh(qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]), OUTSIDE,
                                          target_vertices=N), args.repeat)
        nm = m.n_vertices if isinstance(m, qmesh.Mesh) else str(m)[:60]
        rows_mesh.append([n, N, nm, f"{t_m:.1f}", f"{t_b:.2f}",
                          f"{t_m / t_b:.0f}" if isinstance(m, qmesh.Mesh) else "—"])
        print(f"{n} inclusions at N {N}: {nm} vertices in {t_m:.1f} s; box {t_b:.2f} s", flush=True)
    rng = np.random.default_rng(0)
    for c in args.cells:
        x = np.linspace(0, 1, c + 1)
        k1 = 1 + rng.random((c, c))
        t_c, out = timed(lambda: qmesh.Domain.from_cells(x, x, k1, 1.0, 0.0))
        nreg = len(out[0].regions) if isinstance(out, tuple) else str(out)[:60]
        rows_cells.append([f"{c} × {c}", nreg, f"{t_c:.2f}"])
        print(f"from_cells {c} x {c}: {nreg} regions in {t_c:.2f} s", flush=True)
    tables = [report_page.Table(["inclusions", "target refused", "Domain (CPU s)", "overlap refused (CPU s)",
                                 "target refused (CPU s)", "overlap message"], rows_dom,
                                "Building the domain and refusing it")]
    if rows_mesh:
        tables.append(report_page.Table(["inclusions", "target N", "N", "mesh (CPU s)", "plain box (CPU s)",
                                         "ratio"], rows_mesh, "Meshing"))
    tables.append(report_page.Table(["cells", "regions", "Domain.from_cells (CPU s)"], rows_cells,
                                    "All-different cells"))
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "Cost against the number of regions",
            "Hexagonal inclusions on a grid in the unit square (`principal(10, 1, 30)` inside, "
            "`principal(1, 4, -20)` outside): the CPU time to build the `Domain` (every region "
            "checked and the planar partition made), to refuse one whose last two inclusions "
            "overlap, to refuse a target of 6 vertices per inclusion (below the input points), "
            "and to mesh it, beside a plain box at the same N; then `Domain.from_cells` on "
            "n × n cells whose conductivities all differ (n² regions), up to the domain.",
            tables=tables)


if __name__ == "__main__":
    main()
