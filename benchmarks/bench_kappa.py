"""κ2 of the Dirichlet stiffness matrix: seconds at 1e4 and 1e5 vertices on the chapter's case.

    python benchmarks/bench_kappa.py [--sizes 1e4 1e5] [--vb 256] [--repeat 3] [--no-media] [--no-page]

Q = diag(0.1, 10) on Disk(VB) (the chapter's case), meshed by `qmesh.mesh` at each size. Timed,
best of --repeat, wall-clock and CPU seconds of this process (CPU time hardly depends on what
else the machine runs; wall time does):
- `measure.conditioning(mesh, Q)`: λ_max by Lanczos on K (on a second thread, while λ_min is
  computed); λ_min by LOBPCG preconditioned by smoothed-aggregation multigrid (pyamg) from
  `multigrid_eigen.MULTIGRID_LIMIT` unknowns on, below it (and wherever multigrid does not
  converge) by Lanczos on K⁻¹ through one LDLᵀ factorisation (qdldl, AMD ordering);
- the same with λ_min by the factorisation at every N (`method="sparse"`), and without qdldl
  (its fallback: SuperLU in symmetric mode, minimum degree on Kᵀ + K);
- the same with Q = I (`kappa2_laplacian`), and `measure.report`, which computes both (Q = I's
  on a second thread);
- for comparison, the former computation: eigsh at tol 1e-10 for λ_max and for λ_max(K⁻¹)
  through a COLAMD-ordered SuperLU factorisation with partial pivoting.
Where the time of `measure.conditioning` goes at each N (CPU seconds, best of --repeat): the
checks and the assembly of K, λ_max's Lanczos steps (one product K·v each), the
factorisation, λ_min's Lanczos steps (one solve each), each run alone: their sum is more than
the wall time of `measure.conditioning`, where λ_max's steps overlap the factorisation.
With the media presets (unless --no-media), every Step of `qmesh.iterate` is measured: how
many stages have a κ2, how many have none and why, and that no κ2 is below 1 or not finite.
Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from collections import Counter

import numpy as np
import scipy.sparse.linalg as spla

import qmesh
from qmesh import measure, multigrid_eigen

import report_page

CHAPTER_Q = [[0.1, 0.0], [0.0, 10.0]]


def timed(f, repeat: int):
    """(result, best wall seconds, best CPU seconds) of `repeat` calls of f()."""
    wall, cpu, out = [], [], None
    for _ in range(repeat):
        w, c = time.perf_counter(), time.process_time()
        out = f()
        wall.append(time.perf_counter() - w)
        cpu.append(time.process_time() - c)
    return out, min(wall), min(cpu)


def former_kappa2(mesh, anisotropy) -> float:
    """κ2 as it was computed before: eigsh at tol 1e-10 on K and on K⁻¹ (COLAMD SuperLU)."""
    K = measure.stiffness_interior(mesh, anisotropy)
    n = K.shape[0]
    v0 = np.random.default_rng(0).random(n)
    lmax = spla.eigsh(K, k=1, which="LA", tol=1e-10, v0=v0, return_eigenvectors=False)[0]
    lu = spla.splu(K.tocsc())
    K_inv = spla.LinearOperator((n, n), matvec=lu.solve, dtype=float)
    mu = spla.eigsh(K_inv, k=1, which="LA", tol=1e-10, v0=v0, return_eigenvectors=False)[0]
    return float(lmax * mu)


def without_qdldl(f):
    """f() with `import qdldl` failing, as where it is not installed (measure's SuperLU path)."""
    saved = sys.modules.get("qdldl", False)
    sys.modules["qdldl"] = None
    try:
        return f()
    finally:
        if saved is False:
            del sys.modules["qdldl"]
        else:
            sys.modules["qdldl"] = saved


def counted(apply):
    """apply, and a list whose length is how many times it was called."""
    calls = []

    def wrapped(x):
        calls.append(None)
        return apply(x)
    return wrapped, calls


PARTS = ("assembly", "lmax", "factor", "lmin", "hierarchy", "lobpcg")


def parts_rows(mesh, unknowns: int, repeat: int) -> list[list[object]]:
    """CPU seconds of each part of measure.conditioning, Q and Q = I, best of `repeat`."""
    rows = []
    for label, A in (("Q", qmesh.Anisotropy.constant(CHAPTER_Q)), ("I", None)):
        resolved = measure._resolve(mesh, A)
        best = {}
        for _ in range(repeat):
            t = [time.process_time()]
            free = measure.free_vertices(mesh)
            measure._not_positive_definite(mesh, resolved)
            measure._floating(mesh, free)
            K = measure._stiffness_interior(mesh, resolved)
            t.append(time.process_time())
            v0 = np.random.default_rng(0).random(len(free))
            matvec, products = counted(K.dot)
            measure._largest_eigenvalue(matvec, v0, 1e-6, every=4)     # as conditioning
            t.append(time.process_time())
            solve = measure._inverse(K)
            t.append(time.process_time())
            inverse, solves = counted(solve)
            measure._largest_eigenvalue(inverse, v0, 1e-6)
            t.append(time.process_time())
            cycle, cycles = counted(multigrid_eigen.preconditioner(K))
            t.append(time.process_time())
            found = multigrid_eigen._lobpcg(K.dot, cycle, v0, np.sqrt(1e-6))
            t.append(time.process_time())
            for key, s in zip(PARTS, np.diff(t)):
                best[key] = min(best.get(key, np.inf), s)
        by_factor = best["assembly"] + best["factor"] + best["lmin"]
        by_multigrid = best["assembly"] + best["hierarchy"] + best["lobpcg"]
        steps = f"{len(cycles)}" if found is not None else f"{len(cycles)}, gave up"
        print(f"N = {mesh.n_vertices:>7} {label}: checks + assembly {best['assembly']:.3f}, "
              f"λ_max {best['lmax']:.3f} ({len(products)} steps), factorisation {best['factor']:.3f}, "
              f"λ_min {best['lmin']:.3f} ({len(solves)} solves), multigrid {best['hierarchy']:.3f}, "
              f"LOBPCG {best['lobpcg']:.3f} ({steps} steps); λ_min's path by factorisation "
              f"{by_factor:.3f}, by multigrid {by_multigrid:.3f} s CPU", flush=True)
        rows.append([mesh.n_vertices, unknowns, label, f"{best['assembly']:.3f}",
                     f"{best['lmax']:.3f} ({len(products)})", f"{best['factor']:.3f}",
                     f"{best['lmin']:.3f} ({len(solves)})", f"{best['hierarchy']:.3f}",
                     f"{best['lobpcg']:.3f} ({steps})", f"{by_factor:.3f}", f"{by_multigrid:.3f}"])
    return rows


def size_rows(n: int, vb: int, repeat: int) -> tuple[list[list[object]], list[list[object]]]:
    A = qmesh.Anisotropy.constant(CHAPTER_Q)
    mesh = qmesh.mesh(qmesh.Disk(vb), A, target_vertices=n, seed=0)
    unknowns = len(measure.free_vertices(mesh))
    rows = []
    for label, f in (("measure.conditioning(mesh, Q)", lambda: measure.conditioning(mesh, A).kappa2),
                     ("the same, λ_min by factorisation",
                      lambda: measure.conditioning(mesh, A, method="sparse").kappa2),
                     ("the same without qdldl (SuperLU)",
                      lambda: without_qdldl(lambda: measure.conditioning(mesh, A, method="sparse").kappa2)),
                     ("measure.conditioning(mesh, I)", lambda: measure.conditioning(mesh, None).kappa2),
                     ("former κ2 (Q)", lambda: former_kappa2(mesh, A)),
                     ("measure.report (κ2 for Q and I)", lambda: measure.report(mesh, A)["kappa2"])):
        value, wall, cpu = timed(f, repeat)
        print(f"N = {mesh.n_vertices:>7} ({unknowns} unknowns)  {label:<34} κ2 = {value:.10g}  "
              f"{wall:.3f} s wall, {cpu:.3f} s CPU", flush=True)
        rows.append([mesh.n_vertices, unknowns, label, f"{value:.10g}", f"{wall:.3f}", f"{cpu:.3f}"])
    return rows, parts_rows(mesh, unknowns, repeat)


REASONS = ("touch no boundary vertex", "no interior vertex", "not positive definite",
           "numerically singular", "zero-area", "singular")


def short(reason: str) -> str:
    """The kind of reason conditioning gave, for a table cell."""
    return next((r for r in REASONS if r in reason), reason[:50])


def media_rows(target: int) -> list[list[object]]:
    from qmesh.domain import media_cases
    rows = []
    for name in ("layered", "inclusion"):
        domain, conductivity, _ = getattr(media_cases, name)()
        values, reasons = [], Counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for step in qmesh.iterate(domain, conductivity, target_vertices=target, seed=0):
                c = measure.conditioning(step.mesh, conductivity)
                if c.kappa2 is None:
                    reasons[short(str(c.reason))] += 1
                else:
                    values.append(c.kappa2)
        bad = sum(not (np.isfinite(v) and v >= 1.0) for v in values)
        why = "; ".join(f"{k} (×{v})" for k, v in reasons.items()) or "—"
        print(f"{name}: {len(values) + sum(reasons.values())} stages, κ2 on {len(values)} "
              f"(range {min(values, default=np.nan):.3g} to {max(values, default=np.nan):.3g}, "
              f"{bad} not finite ≥ 1), none on {sum(reasons.values())}: {why}", flush=True)
        rows.append([name, len(values) + sum(reasons.values()), len(values),
                     f"{min(values, default=np.nan):.3g} – {max(values, default=np.nan):.3g}", bad,
                     sum(reasons.values()), why])
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=float, nargs="+", default=[1e4, 1e5])
    ap.add_argument("--vb", type=int, default=256)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--media-target", type=int, default=600)
    ap.add_argument("--no-media", action="store_true")
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    measured = [size_rows(int(n), args.vb, args.repeat) for n in args.sizes]
    tables = [report_page.Table(["N", "unknowns", "computation", "κ2", "wall s", "CPU s"],
                                [r for rows, _ in measured for r in rows],
                                f"Q = diag(0.1, 10) on Disk({args.vb}), best of {args.repeat}"),
              report_page.Table(["N", "unknowns", "conductivity", "checks + assembly", "λ_max (steps)",
                                 "factorisation", "λ_min (solves)", "multigrid hierarchy",
                                 "λ_min by LOBPCG (steps)", "assembly + factorisation + solves",
                                 "assembly + multigrid + LOBPCG"],
                                [r for _, parts in measured for r in parts],
                                f"Where measure.conditioning's CPU seconds go, best of {args.repeat} "
                                "for each part")]
    if not args.no_media:
        tables.append(report_page.Table(
            ["medium", "stages", "with κ2", "κ2 range", "κ2 not finite ≥ 1", "without κ2", "why"],
            media_rows(args.media_target), f"Every Step of qmesh.iterate on the media presets, "
                                           f"target {args.media_target}"))
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "κ2 of the Dirichlet stiffness matrix",
            "Seconds to compute κ2 = λ_max/λ_min of the Dirichlet stiffness matrix on the chapter's "
            f"case (Q = diag(0.1, 10) on Disk({args.vb})) at each N: `measure.conditioning` (λ_max "
            "by Lanczos on K, on a second thread while the factorisation runs; λ_min by Lanczos "
            "on K⁻¹ through one LDLᵀ factorisation by qdldl), "
            "the same without qdldl (SuperLU in symmetric mode, its fallback), the same for "
            "Q = I, `measure.report` (both), and the former computation (eigsh at tol 1e-10, "
            "COLAMD factorisation with partial pivoting) on the same machine in the same run. "
            f"Wall and CPU seconds of this process, best of {args.repeat}; then where "
            "`measure.conditioning`'s CPU time goes, each part run alone. The media table measures every Step of a medium's run: a stage whose "
            "Dirichlet matrix is singular (a face meshed alone, touching no boundary) has no κ2 "
            "and says why.",
            tables=tables)


if __name__ == "__main__":
    main()
