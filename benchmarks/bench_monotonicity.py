"""The monotonicity certificate on FVCA5 test 5's quarter annulus: qmesh, isotropic Triangle and
meshes aligned with Q's principal directions, beside the exact test.

    python benchmarks/bench_monotonicity.py [--n 1000 2000] [--no-page]

Ω = {0.5 < r < 1, 0 < θ < π/2}, Q = FVCA5 test 5's tensor (δ = 1e-3: 1 along the circles, δ
across), every matrix assembled with the element means of the field (`TensorField.means`).
Meshes at about N vertices: qmesh's (`qmesh.mesh(domain, field)`), Triangle's quality mesh
(isotropic, `pq30a…`), and rays and arcs (aligned with Q) of cell aspect 1 and 31.6 (= 1/√δ,
Q's own), each cell cut by one diagonal the same way ("uniform") or alternating ("union jack").
Columns: N, positive off-diagonals of A and positive boundary couplings (beyond 1e-9 of the
largest |K_ij|), the certificate (`measure.monotonicity`), the vertices it eliminated, its
seconds, and the exact test of `tests/core/monotone_oracle.py` (dense LU): min A⁻¹ / ‖A⁻¹‖₂,
min −A⁻¹B / (‖A⁻¹‖₂‖B‖₂), the solve's round-off τ = 64·n·ε·κ₂ they are held to, and whether
both are ≥ −τ.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import report_page

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "core"))

import qmesh  # noqa: E402
from qmesh import measure  # noqa: E402
from monotone_oracle import ccw, exact  # noqa: E402

DELTA = 1e-3
R0, R1 = 0.5, 1.0
FIELD = qmesh.TensorField.from_expressions(
    f"({DELTA}*x**2 + y**2)/(x**2 + y**2)", f"({DELTA} - 1)*x*y/(x**2 + y**2)",
    f"(x**2 + {DELTA}*y**2)/(x**2 + y**2)")


def outline(arc: int) -> np.ndarray:
    """The quarter annulus as a polygon, `arc` segments on each arc."""
    t = np.linspace(0.0, np.pi / 2, arc + 1)
    outer = np.column_stack([R1 * np.cos(t), R1 * np.sin(t)])
    inner = np.column_stack([R0 * np.cos(t), R0 * np.sin(t)])[::-1]
    return np.vstack([outer, inner])


def aligned(n: int, aspect: float, union_jack: bool) -> qmesh.Mesh:
    """Rays and arcs, about n vertices, cells `aspect` times longer along the arcs (at the
    mean radius) than across; each cell cut by one diagonal."""
    # nr · nt = n and (π/2 · 0.75 / (nt − 1)) = aspect · (0.5 / (nr − 1))
    nr = max(3, int(round(np.sqrt(n * aspect * 0.5 / (np.pi / 2 * 0.75)))))
    nt = max(3, int(round(n / nr)))
    r, t = np.linspace(R0, R1, nr), np.linspace(0.0, np.pi / 2, nt)
    Rr, Tt = np.meshgrid(r, t, indexing="ij")
    P = np.column_stack([(Rr * np.cos(Tt)).ravel(), (Rr * np.sin(Tt)).ravel()])
    v = np.arange(nr * nt).reshape(nr, nt)
    a, b, c, d = v[:-1, :-1].ravel(), v[1:, :-1].ravel(), v[1:, 1:].ravel(), v[:-1, 1:].ravel()
    flip = np.zeros((nr - 1, nt - 1), bool)
    if union_jack:
        flip = np.add.outer(np.arange(nr - 1), np.arange(nt - 1)) % 2 == 1
    f = flip.ravel()[:, None]
    T = np.vstack([np.where(f, np.column_stack([a, b, d]), np.column_stack([a, b, c])),
                   np.where(f, np.column_stack([b, c, d]), np.column_stack([a, c, d]))])
    return qmesh.Mesh(P, ccw(P, T))


def triangle_mesh(n: int) -> qmesh.Mesh:
    import triangle
    poly = outline(max(8, int(np.sqrt(n))))
    seg = np.column_stack([np.arange(len(poly)), (np.arange(len(poly)) + 1) % len(poly)])
    area = np.pi / 4 * (R1 ** 2 - R0 ** 2) / (2 * n) * 1.65   # ≈ n vertices: 2n triangles, most below the bound
    t = triangle.triangulate({"vertices": poly, "segments": seg}, f"pq30a{area:.3g}")
    return qmesh.Mesh(t["vertices"], ccw(t["vertices"], t["triangles"]))


def row(name: str, mesh: qmesh.Mesh) -> list[str]:
    Q = mesh.conductivity if mesh.conductivity is not None else FIELD.means(mesh.points, mesh.triangles)
    start = time.perf_counter()
    cert = measure.monotonicity(mesh, Q)
    seconds = time.perf_counter() - start
    truth = exact(mesh, Q, cert.perturbation)
    return [name, str(mesh.n_vertices), str(cert.n_positive), str(cert.n_positive_boundary), str(cert),
            str(cert.n_eliminated), f"{seconds:.3f}", f"{truth.min_inverse:.2g}",
            f"{truth.min_harmonic:.2g}", f"{truth.tolerance:.1g}", "yes" if truth.monotone else "no"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[1000, 2000], help="vertex counts")
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    headers = ["mesh", "N", "K_ij > 0", "b_iγ > 0", "certificate", "eliminated", "s",
               "min A⁻¹", "min −A⁻¹B", "τ", "exact DMP"]
    print("| " + " | ".join(headers) + " |")
    print("|" + "---|" * len(headers))
    rows = []
    for n in args.n:
        meshes = [("qmesh", lambda: qmesh.mesh(qmesh.Polygon(outline(64)), FIELD, target_vertices=n)),
                  ("Triangle, isotropic", lambda: triangle_mesh(n))]
        for aspect in (1.0, 1.0 / np.sqrt(DELTA)):
            for jack in (False, True):
                meshes.append((f"aligned, aspect {aspect:.3g}, {'union jack' if jack else 'uniform'}",
                               lambda a=aspect, j=jack: aligned(n, a, j)))
        for name, make in meshes:
            rows.append(row(name, make()))
            print("| " + " | ".join(rows[-1]) + " |", flush=True)
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "The monotonicity certificate on FVCA5 test 5",
            __doc__.split("\n\n", 2)[2].strip(), tables=[report_page.Table(headers, rows)])


if __name__ == "__main__":
    main()
