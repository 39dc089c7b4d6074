"""`qmesh table`: the chapter's Tables 2.2/2.3 reproduced beside qmesh and its peers.

For every VB: the isotropic mesh (Triangle, as in the chapter), the qmesh adapted mesh with the
chapter's adapted N as target, and with `peers` BAMG and MMG2D at the same N. Every mesh is
measured by `qmesh.measure.report` and put beside the chapter's printed value with the ratio to
it; `solve` appends the solver payoff (`compare.solve`). Writes OUT/table.md, OUT/table.csv and
the Figures 2.15–2.18, and returns the Markdown.
"""

from __future__ import annotations

import csv
import time
from pathlib import Path
from typing import Callable

import numpy as np

from qmesh import CHAPTER_Q, measure
from qmesh.conductivity.anisotropy import Anisotropy
from qmesh.domain.domain import Disk
from qmesh.errors import QmeshError
from qmesh.mesher.loop import mesh as adapted_mesh
from qmesh.compare import chapter, figures, isotropic
from qmesh.compare import peers as peer_meshers
from qmesh.compare import solve as solver

MEASURED = ("n_vertices", "n_boundary", "l2_error", "h1_error", "kappa2",
            "q_nonnegative_fraction", "min_quality", "mean_quality")
SOLVED = ("u_max_error", "u_l2_error") + tuple(
    f"cg_{p}_{what}" for p in solver.PRECONDITIONERS for what in ("iterations", "seconds"))
COLUMNS = (("vb", "mesher", "target", "seconds", "runs") + MEASURED
           + tuple(f"chapter_{q}" for q in chapter.QUANTITIES)
           + tuple(f"ratio_{q}" for q in chapter.QUANTITIES))


def _check_vb(vb) -> list[int]:
    if vb is None:
        return list(chapter.VB)
    try:
        values = sorted({int(v) for v in vb})
    except (TypeError, ValueError) as exc:
        raise QmeshError(f"VB values must be integers, got {vb!r}") from exc
    if not values:
        raise QmeshError("give at least one VB")
    if values[0] < 3:
        raise QmeshError(f"VB must be at least 3, got {values[0]}")
    if values[-1] > 4096:
        raise QmeshError(f"VB = {values[-1]} is beyond this comparison (the chapter stops at 512)")
    return values


def _row(vb: int, mesher: str, mesh, seconds: float, anisotropy, target=None, runs=1,
         solve: bool = False) -> dict:
    """Measurements of one mesh beside the chapter's printed values and the ratios to them."""
    rep = measure.report(mesh, anisotropy, laplacian=False)   # κ2 for Q = I is not a column
    row = {"vb": vb, "mesher": mesher, "target": target, "seconds": seconds, "runs": runs}
    row.update({k: rep.get(k) for k in MEASURED})
    ref = chapter.row(vb, "isotropic" if mesher == "isotropic" else "adapted")
    for q in chapter.QUANTITIES:
        c = ref[q] if ref else None
        row[f"chapter_{q}"] = c
        row[f"ratio_{q}"] = row[q] / c if (c and row[q] is not None) else None
    if solve:
        sol = solver.solve_report(mesh, anisotropy)
        row.update({k: sol[k] for k in SOLVED})
    return row


def build_rows(vb=None, peers: bool = False, solve: bool = False,
               progress: Callable[[str], None] | None = None, *, scheduler: str | None = None,
               workers: int | None = None) -> tuple[list[dict], dict]:
    """Mesh and measure every (VB, mesher); returns the rows and {peer: reason} for skipped peers.

    Each (VB, mesher) cell is one `table_row` call: in this process, or, with `scheduler` (a
    running Dask scheduler's address) or `workers` (a LocalCluster of that many processes), one
    Dask task each (qmesh.sweep.runner.map_ordered; the `sweep` extra). The rows are the same
    either way, apart from `seconds`, which then includes the other tasks' load.
    """
    vbs = _check_vb(vb)
    skipped = {}
    active = []
    if peers:
        for name, reason in peer_meshers.available().items():
            (skipped.__setitem__(name, reason) if reason else active.append(name))
    meshers = ("isotropic", "qmesh", *active)
    cells = [(v, m, solve) for v in vbs for m in meshers]
    rows: list[dict] = []

    def done(row: dict) -> None:
        rows.append(row)
        mine = sorted((r for r in rows if r["vb"] == row["vb"]), key=lambda r: meshers.index(r["mesher"]))
        if progress and len(mine) == len(meshers):
            progress(f"VB {row['vb']}: " + ", ".join(f"{r['mesher']} N={r['n_vertices']}" for r in mine))

    if scheduler is None and workers is None:
        return [_done(table_row(*c), done) for c in cells], skipped
    from qmesh.sweep.runner import map_ordered
    return map_ordered(table_row, cells, scheduler=scheduler, workers=workers, done=done), skipped


def _done(row: dict, done) -> dict:
    done(row)
    return row


def table_row(vb: int, mesher: str, solve: bool = False) -> dict:
    """One cell of the table: mesher "isotropic" (Triangle, the chapter's areas), "qmesh" (the
    chapter's adapted N as target, seed 0) or a peer's name, on Disk(vb), measured."""
    anisotropy = Anisotropy.constant(CHAPTER_Q)
    domain, target = Disk(vb), chapter.adapted_target(vb)
    t0 = time.perf_counter()
    if mesher == "isotropic":
        iso = isotropic.isotropic_mesh(vb)
        return _row(vb, mesher, iso, time.perf_counter() - t0, anisotropy, solve=solve)
    if mesher == "qmesh":
        ada = adapted_mesh(domain, anisotropy, target_vertices=target, seed=0)
        return _row(vb, mesher, ada, time.perf_counter() - t0, anisotropy, target, solve=solve)
    pm = peer_meshers.peer_mesh(mesher, domain, anisotropy, target)
    return _row(vb, mesher, pm.mesh, pm.seconds, anisotropy, target, pm.runs, solve)


# --------------------------------------------------------------------------- formatting

def _g(x, digits: int = 3) -> str:
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return "–"
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    if x != 0 and (abs(x) >= 1e4 or abs(x) < 1e-2):
        return f"{x:.{digits - 1}e}"
    return f"{x:.{digits}g}"


def _r(x) -> str:
    return "–" if x is None else f"{x:.2f}"


def _table(header: list[str], lines: list[list[str]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(line) + " |" for line in lines]
    return "\n".join(out)


def _geomean(values) -> float | None:
    v = np.array([x for x in values if x is not None and x > 0], dtype=float)
    return float(np.exp(np.log(v).mean())) if len(v) else None


def _equal_n_advantage(rows: list[dict], mesher: str, key: str) -> float | None:
    """Geometric mean over the mesher's rows of (isotropic power-law fit at its N) / its value."""
    iso = [r for r in rows if r["mesher"] == "isotropic" and r.get(key)]
    mine = [r for r in rows if r["mesher"] == mesher and r.get(key)]
    if len({r["n_vertices"] for r in iso}) < 2 or not mine:
        return None
    c = np.polyfit(np.log([r["n_vertices"] for r in iso]), np.log([r[key] for r in iso]), 1)
    return _geomean([np.exp(np.polyval(c, np.log(r["n_vertices"]))) / r[key] for r in mine])


def markdown(rows: list[dict], skipped: dict, solve: bool, seconds: float) -> str:
    """The Markdown report: Table 2.2, Table 2.3, the solver table, a summary and notes."""
    meshers = [m for m in figures.STYLE if any(r["mesher"] == m for r in rows)]
    t22 = _table(
        ["VB", "mesher", "N", "N ch.", "N ratio", "‖e‖L2", "L2 ch.", "L2 ratio",
         "\\|e\\|h1", "h1 ch.", "h1 ratio"],
        [[str(r["vb"]), r["mesher"], _g(r["n_vertices"]), _g(r["chapter_n_vertices"]),
          _r(r["ratio_n_vertices"]), _g(r["l2_error"]), _g(r["chapter_l2_error"]),
          _r(r["ratio_l2_error"]), _g(r["h1_error"]), _g(r["chapter_h1_error"]),
          _r(r["ratio_h1_error"])] for r in rows])
    t23 = _table(
        ["VB", "mesher", "N", "κ2", "κ2 ch.", "κ2 ratio", "q_ij ≥ 0", "min quality",
         "mean quality", "mesh s"],
        [[str(r["vb"]), r["mesher"], _g(r["n_vertices"]), _g(r["kappa2"]), _g(r["chapter_kappa2"]),
          _r(r["ratio_kappa2"]), f"{100 * r['q_nonnegative_fraction']:.1f}%",
          _g(r["min_quality"]), _g(r["mean_quality"]), f"{r['seconds']:.3f}"] for r in rows])
    parts = ["## Table 2.2 — interpolation error of s (ours beside the chapter's printed values)",
             "", t22, "",
             "## Table 2.3 — conditioning κ2 and mesh quality", "", t23, ""]
    if solve:
        pre = solver.PRECONDITIONERS
        ts = _table(
            ["VB", "mesher", "N", "max\\|u_h − u\\|", "‖u_h − u‖L2"]
            + [f"CG its ({p})" for p in pre] + [f"CG s ({p})" for p in pre],
            [[str(r["vb"]), r["mesher"], _g(r["n_vertices"]), _g(r["u_max_error"]),
              _g(r["u_l2_error"])] + [str(r[f"cg_{p}_iterations"]) for p in pre]
             + [f"{r[f'cg_{p}_seconds']:.3f}" for p in pre] for r in rows])
        parts += ["## Solver payoff — −div(Q∇u) = f, P1 FEM, CG to relative residual "
                  f"{solver.RTOL:g}", "", ts, ""]
    # summary
    keys = [("n_vertices", "N"), ("l2_error", "L2"), ("h1_error", "h1"), ("kappa2", "κ2")]
    lines = []
    for m in meshers:
        mine = [r for r in rows if r["mesher"] == m]
        cells = [m]
        for q, _ in keys:
            cells.append(_r(_geomean([r[f"ratio_{q}"] for r in mine])))
        cells.append(_r(max((r["ratio_kappa2"] for r in mine if r["ratio_kappa2"]), default=None)))
        for q in ("l2_error", "h1_error", "kappa2") + (("u_l2_error", "cg_none_iterations")
                                                        if solve else ()):
            cells.append("–" if m == "isotropic" else _r(_equal_n_advantage(rows, m, q)))
        p = figures.slope
        cells += [_r(p([r["n_vertices"] for r in mine], [r[q] for r in mine]))
                  for q in ("l2_error", "h1_error", "kappa2")]
        cells.append(_r(p([r["vb"] for r in mine], [r["n_vertices"] for r in mine])))
        lines.append(cells)
    header = (["mesher"] + [f"{k} ratio (geo. mean)" for _, k in keys] + ["κ2 ratio (max)"]
              + ["iso/this L2 @ equal N", "iso/this h1 @ equal N", "iso/this κ2 @ equal N"]
              + (["iso/this u error @ equal N", "iso/this CG its @ equal N"] if solve else [])
              + ["slope L2~N^p", "slope h1~N^p", "slope κ2~N^p", "slope N~VB^p"])
    parts += ["## Summary", "", _table(header, lines), ""]
    notes = [
        f"- **L2 column.** The chapter's printed ‖e‖L2 appears low by a factor √2 ≈ "
        f"{chapter.L2_FACTOR:.3f}: on the isotropic meshes, which match the chapter's N within "
        "2.5% and whose h1 and κ2 match without any factor, our exact integral (degree-4 "
        "quadrature, exact for quadratic s) is ≈ 1.4× the printed value. We show our correct "
        "value, the chapter's, and the ratio; the figures draw the chapter's L2 ×√2.",
        "- Ratios are ours / the chapter's printed value: the isotropic mesh against its "
        "isotropic column, every adapted mesher (qmesh and the peers) against its adapted column. "
        "\"iso/this @ equal N\" divides the isotropic meshes' power-law fit, evaluated at this "
        "mesher's N, by this mesher's value (the chapter's headline: ~4× in L2, ~3× in h1, ~5× "
        "in κ2).",
        "- κ2 = λmax/λmin of the stiffness matrix for Q = diag(0.1, 10) restricted to interior "
        "vertices (homogeneous Dirichlet); q_ij ≥ 0 is the share of interior edges with "
        "nonnegative weight (relative tolerance 1e-9); quality is the metric quality (2.94).",
        "- Isotropic: Triangle `pq30a<A>YQ` with the chapter's areas. qmesh: "
        "`qmesh.mesh(Disk(VB), Q, target_vertices=<chapter's adapted N>, seed=0)`. "
        "\"mesh s\" is the wall time of producing the mesh; for a peer, of its final run "
        "(its metric scale was calibrated over `runs` runs, in table.csv).",
    ]
    if peer_meshers.PEERS and any(r["mesher"] in peer_meshers.PEERS for r in rows):
        notes.append("- Peers get the constant metric ∇²s / h², h scaled to reach the same N; "
                     "the VB-gon's sides are kept whole (BAMG: 2-node transfinite lines; MMG2D: "
                     "required edges and vertices, `nosizreq`, re-run on its own output until the median "
                     "metric edge length is within 10% of 1). BAMG via gmsh is not deterministic: "
                     "its rows vary slightly between runs.")
    for name, reason in skipped.items():
        notes.append(f"- Peer **{name}** skipped: {reason}")
    if solve:
        notes.append("- Solver: manufactured u(x) = g(H^½x), g(ξ) = sin ξ₁ cos ξ₂ + ξ₁ξ₂/2 "
                     "(smooth on the unit scale of the metric H = ∇²s), f = −div(Q∇u) derived "
                     "analytically, exact u on the boundary; the u errors are of the sparse direct "
                     "solution against the exact u; CG starts from zero, plain, with Jacobi and with "
                     "symmetric Gauss–Seidel (SSOR). Iteration counts are deterministic; CG seconds "
                     "vary with the machine's load.")
    notes.append(f"- Whole run: {seconds:.1f} s on this machine.")
    return "\n".join(parts + ["## Notes", ""] + notes) + "\n"


def write_csv(rows: list[dict], path: Path, solve: bool) -> None:
    cols = COLUMNS + (SOLVED if solve else ())
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in cols})


def run_table(vb: list[int] | None = None, out: str = "results", peers: bool = False,
              solve: bool = False, *, progress: Callable[[str], None] | None = None,
              scheduler: str | None = None, workers: int | None = None) -> str:
    """Build, measure and compare every mesh; write OUT/table.md, table.csv and the figures.

    Returns the Markdown (the CLI prints it). `progress` receives one line per VB. `scheduler`
    / `workers`: run the cells on Dask (see build_rows).
    """
    t0 = time.perf_counter()
    rows, skipped = build_rows(vb, peers, solve, progress, scheduler=scheduler, workers=workers)
    out_dir = Path(out)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_csv(rows, out_dir / "table.csv", solve)
    figures.plot(rows, out_dir)
    text = markdown(rows, skipped, solve, time.perf_counter() - t0)
    (out_dir / "table.md").write_text(text)
    return text
