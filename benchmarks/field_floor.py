"""What a text field's certificate costs before any meshing, against a constant Q's whole run.

    python benchmarks/field_floor.py [--cases fvca5 plasma layers spiral] [--n 20000] [--runs 3]

For each text case of bench_fields, its final mesh at the target N is made once; then, on that
mesh's points and triangles and with a new TensorField each run (nothing cached), the CPU seconds
of the element means by the adaptive rule at the tolerance certify asks
(`TensorField.means_with_error` at `qmesh.fields.cache.RTOL`, no proven bound) and of one enclosure
pass bounding them (`TensorField.enclosure_errors`: what the certificate proves once per triangle
before any refinement), against the CPU seconds of the whole `qmesh.mesh` run of
`Anisotropy.constant(Q̄)` on the same domain at the same N, Q̄ the area mean of the mesh's own
element means. Least of the runs. Means plus one enclosure pass is a floor of a field's run that no
speed-up of the mesher removes.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_fields  # noqa: E402 — beside this script
import report_page  # noqa: E402

import qmesh  # noqa: E402
from qmesh.fields.cache import RTOL  # noqa: E402 — the means' tolerance certify asks

TEXT_CASES = [name for name, c in bench_fields.CASES.items() if c.kind == "formula"]


def _cpu(fn) -> float:
    start = time.process_time()
    fn()
    return time.process_time() - start


def floor(name: str, n: int, runs: int) -> list:
    """One row: the case's N and triangles, and the least CPU seconds of each part."""
    case = bench_fields.CASES[name]
    domain = case.domain()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        mesh = qmesh.mesh(domain, case.field(), target_vertices=n)
    P, T = np.asarray(mesh.points), np.asarray(mesh.triangles)
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    area = 0.5 * np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    Qbar = np.einsum("t,tij->ij", area, np.asarray(mesh.conductivity)) / area.sum()
    constant = qmesh.Anisotropy.constant(Qbar)
    best = {"means": np.inf, "enclosures": np.inf, "constant": np.inf}
    for _ in range(runs):
        best["means"] = min(best["means"], _cpu(lambda: case.field().means_with_error(
            P, T, rtol=RTOL, bound_rtol=None)))
        best["enclosures"] = min(best["enclosures"],
                                 _cpu(lambda: case.field().enclosure_errors(P, T)))
        best["constant"] = min(best["constant"],
                               _cpu(lambda: qmesh.mesh(domain, constant, target_vertices=n)))
    both = best["means"] + best["enclosures"]
    return [name, n, mesh.n_vertices, len(T), f"{best['means']:.3f}", f"{best['enclosures']:.3f}",
            f"{both:.3f}", f"{best['constant']:.3f}", f"{both / best['constant']:.1f}×"]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", choices=TEXT_CASES, default=TEXT_CASES)
    ap.add_argument("--n", type=int, nargs="+", default=[20000])
    ap.add_argument("--runs", type=int, default=3)
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    headers = ["case", "target N", "N", "triangles", "element means CPU s",
               "one enclosure pass CPU s", "both CPU s", "Anisotropy.constant(Q̄) whole run CPU s",
               "both / constant"]
    rows = [floor(name, n, args.runs) for name in args.cases for n in args.n]
    table = report_page.markdown_table(headers, rows)
    print(table)
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "What a text field's certificate costs before any meshing",
            __doc__.split("\n\n")[2].replace("\n", " "),
            tables=[report_page.Table(headers, rows, f"least of {args.runs} runs")],
            output=table)


if __name__ == "__main__":
    main()
