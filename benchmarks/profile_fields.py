"""CPU seconds per stage of bench_fields cases, against Anisotropy.constant(Q̄), in minutes.

bench_fields.py takes a quarter of an hour for its page; this runs a few of its cases in this
process, each the least CPU seconds of `--repeats` runs (a new field each run), with the stages
as bench_fields.py splits them, the mesh's hash (sha256 of its points and triangles: a pure
speed-up keeps it), and, with `--check`, the positive off-diagonals and the minimum quality by
the benchmark's own element means. Beside each field, the same domain and N meshed with
`Anisotropy.constant(Q̄)` and a constant `TensorField` of Q̄, Q̄ the field's area mean by the
benchmark's means on a 2000-vertex mesh of the domain. `--profile K` prints the K functions of
most cumulative and own time of one more run of the first case.
"""

from __future__ import annotations

import argparse
import cProfile
import hashlib
import pstats
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_fields as bf  # noqa: E402
import report_page  # noqa: E402

import qmesh  # noqa: E402

CASES = ("plasma:2000", "plasma:20000", "islands:2000", "islands:20000", "spiral:2000")
KINDS = ("field", "constQ", "constfield")
HEADERS = ["case", "N target", "meshed as", "N", "CPU s", "× constQ", *bf.STAGES, "hash",
           "K_ij > 0", "min quality"]


def area_mean(case) -> np.ndarray:
    """Q̄: the field's area mean over the case's domain, by the benchmark's means."""
    m = qmesh.mesh(case.domain(), qmesh.Anisotropy.constant(np.eye(2)), target_vertices=2000)
    P, T = np.asarray(m.points), np.asarray(m.triangles)
    Qbar = bf.independent_means(case, P, T, None if case.kind == "raster" else bf.sympy_problem(case))
    _, area = bf.element_matrices(P, T, Qbar)
    return np.einsum("m,mij->ij", area, Qbar) / area.sum()


def one_run(case, n, kind, Q):
    """(mesh, CPU seconds per stage, CPU seconds of the whole run)."""
    domain = case.domain()
    c0 = time.process_time()
    if kind == "constQ":
        return qmesh.mesh(domain, qmesh.Anisotropy.constant(Q), target_vertices=n), {}, \
            time.process_time() - c0
    fld = (case.field() if kind == "field" else
           qmesh.TensorField.from_expressions(*(repr(float(v)) for v in (Q[0, 0], Q[0, 1], Q[1, 1]))))
    records, stamps = [], [time.process_time()]
    for step in qmesh.iterate(domain, fld, target_vertices=n):
        stamps.append(time.process_time())
        records.append((step.stage, step.iteration, step.stats.seconds))
    return step.mesh, bf.stage_seconds(records, stamps), time.process_time() - c0


def digest(m) -> str:
    """The first 12 hex digits of the sha256 of the mesh's points and triangles."""
    h = hashlib.sha256(np.ascontiguousarray(m.points, dtype=float).tobytes())
    h.update(np.ascontiguousarray(m.triangles, dtype=np.int64).tobytes())
    return h.hexdigest()[:12]


def checked(case, m) -> tuple[str, str]:
    """Positive off-diagonals (interior / boundary) and the minimum quality, by the benchmark's
    means."""
    P, T = np.asarray(m.points), np.asarray(m.triangles)
    Qbar = bf.independent_means(case, P, T, None if case.kind == "raster" else bf.sympy_problem(case))
    n_in, n_b, _ = bf.positive_off_diagonals(P, T, Qbar)
    q = qmesh.measure.quality(qmesh.Mesh(P, T, np.asarray(m.fixed)), Qbar)
    return f"{n_in} / {n_b}", f"{float(np.nanmin(q)):.3f}"


def rows_of(name: str, n: int, kinds, repeats: int, check: bool) -> list[list[str]]:
    case = bf.CASES[name]
    Q = area_mean(case)
    out, const = [], None
    for kind in kinds:
        best = None
        for _ in range(repeats):
            m, stages, cpu = one_run(case, n, kind, Q)
            if best is None or cpu < best[2]:
                best = (m, stages, cpu)
        m, stages, cpu = best
        if kind == "constQ":
            const = cpu
        extra = checked(case, m) if check and kind == "field" else ("", "")
        out.append([name, str(n), kind, str(m.n_vertices), f"{cpu:.3f}", "",
                    *(f"{stages[s]:.3f}" if s in stages else "" for s in bf.STAGES), digest(m),
                    *extra])
        print(" ".join(out[-1]), flush=True)
    for row in out:
        if const:
            row[5] = f"{float(row[4]) / const:.1f}"
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases", nargs="*", default=list(CASES), help="NAME:N, e.g. plasma:20000")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--kinds", default=",".join(KINDS), help="of " + ", ".join(KINDS))
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--profile", type=int, default=0, metavar="K")
    report_page.add_option(ap)
    a = ap.parse_args(argv)
    kinds = [k for k in a.kinds.split(",") if k]
    specs = [(c.split(":")[0], int(c.split(":")[1])) for c in a.cases]
    rows = [r for name, n in specs for r in rows_of(name, n, kinds, a.repeats, a.check)]
    if a.profile:
        name, n = specs[0]
        prof = cProfile.Profile()
        prof.enable()
        one_run(bf.CASES[name], n, "field", None)
        prof.disable()
        for key in ("cumulative", "tottime"):
            pstats.Stats(prof).sort_stats(key).print_stats(a.profile)
    if not a.no_page:
        report_page.write_page(__file__, sys.argv, "Conductivity fields: CPU seconds per stage",
                               __doc__.split("\n\n", 1)[1],
                               tables=[report_page.Table(HEADERS, rows, "Least CPU seconds of "
                                                         f"{a.repeats} runs")])


if __name__ == "__main__":
    main()
