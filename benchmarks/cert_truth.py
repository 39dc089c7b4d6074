"""Whether any certificate is false: text fields with jumps and narrow features, each certified
mesh checked against exact element means computed without qmesh's quadrature.

    python benchmarks/cert_truth.py [--draws 2] [--n 300 1000 3000] [--seed 0] [--no-page]

The fields (tests/fields/hostile_fields.py), on the unit square, anisotropy 10–1e3, drawn at
random positions and angles: a principal field whose angle jumps by 90° across a line
(`abs(u)/u`; on constant pieces, and on pieces whose angle turns), two crossing jumps, a step
between two tensors (`(1 + abs(u)/u)/2`, a Heaviside), a narrow ramp of k2 written with `abs`
(min and max: a kink at each side of a band 0.003–0.03 wide), two Gaussian bumps of k2 and a
Gaussian ridge of k2 0.003–0.03 wide; the jump a sampled rule once certified falsely
(0° | 90° across x + 0.3y = 0.537), and one along the diagonal x + y = 1, where the mesher's
samples fall on the line. `--draws` fields of each kind, each meshed by `qmesh.mesh` at
each target N. The exact means (tests/fields/exact_means.py): each triangle cut exactly along
the lines where Q jumps or kinks and a collapsed Gauss rule (another family than the mesher's)
on each smooth piece; bumps by a one-dimensional Gauss rule along each edge in polar
coordinates about the bump's centre; ridges in closed form (erf along the ridge's normal). With
them, the edges' exact q_ij / Σ|q_ij^T| (assembled independently): an edge the certificate
passes below −1e-9 is a false certificate. The mesh keeps its means but not their bounds: each triangle's stated bound
is read from certify's last assembly (tests/fields/truth.py), and |exact − stored| is set
against it. Last, a callable with a jump (two 1000 : 1 tensors across a line, `np.where`),
whose means nothing bounds: the mesh must say the resolution its means sampled Q at
(`Mesh.means_sampled_at`, and `measure.report`), and the same check shows what sampling missed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import report_page  # noqa: E402 — beside this script

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import qmesh  # noqa: E402
from tests.fields import hostile_fields as hf  # noqa: E402
from tests.fields import truth  # noqa: E402
from tests.fields.reference import principal  # noqa: E402

HEADERS = ["case", "target N", "N", "edges the certificate leaves failing",
           "false interior edges", "false boundary edges", "least exact q_ij / Σ|q_ij^T|",
           "triangles outside their bound", "max |exact − stored| / bound",
           "max |exact − stored| / ‖Q̄‖", "max bound / ‖Q̄‖", "exact means' own error / ‖Q̄‖",
           "mesh s"]


def callable_jump(rng: np.random.Generator) -> hf.Case:
    """Two 1000 : 1 tensors, 0° and 90°, across a random line: a callable (`np.where`)."""
    line, _ = hf._line(rng)

    def Q(x, y):
        x, y = np.asarray(x, float), np.asarray(y, float)
        return principal(1000.0, 1.0, np.where(line[0] * x + line[1] * y - line[2] > 0, 0.0, 90.0))

    return hf.Case("callable: 1000 : 1, 0° | 90° (np.where)", "callable",
                   lambda: qmesh.TensorField(Q), lambda x, y: Q(x, y), [line])


def row(case: hf.Case, n: int) -> tuple[list, truth.Verdict | None, qmesh.Mesh | None]:
    """The table's row of `case` meshed at target n, its Verdict and mesh (None, None where
    qmesh refuses the field at n: the row says why)."""
    try:
        m, v = truth.mesh_and_check(case, n)
    except qmesh.QmeshError as e:
        cells = [case.name, n, "refused", f"`qmesh.QmeshError: {' '.join(str(e).split())}`"]
        print(" | ".join(str(c) for c in cells), flush=True)
        return cells + [""] * (len(HEADERS) - len(cells)), None, None
    cells = [case.name, n, v.n, v.remaining, v.false_interior, v.false_boundary, f"{v.worst:.3g}",
             v.outside, f"{v.gap_over_bound:.3g}", f"{v.largest_gap:.2e}", f"{v.largest_bound:.2e}",
             f"{v.reference_error:.1e}", f"{v.seconds:.1f}"]
    print(" | ".join(str(c) for c in cells), flush=True)
    return cells, v, m


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=2, help="fields of each kind")
    ap.add_argument("--n", type=int, nargs="+", default=[300, 1000, 3000])
    ap.add_argument("--seed", type=int, default=0)
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    cases = [hf.fooled_jump(), hf.diagonal_jump()] + hf.drawn(rng, args.draws)
    with report_page.capture() as out:
        rows, verdicts, refused = [], [], 0
        for case in cases:
            for n in args.n:
                cells, v, _ = row(case, n)
                rows.append(cells)
                refused += v is None
                verdicts += [] if v is None else [v]
        labels = [[c.name, f"`{c.field().label}`"] for c in cases]
        sampled_rows, labelled, missed = [], True, []
        jump = callable_jump(rng)
        for n in args.n:
            cells, v, m = row(jump, n)
            if v is None:
                labelled = False
                continue
            missed.append(v)
            said = qmesh.measure.report(m, laplacian=False).get("means_sampled_at")
            ok = v.sampled_at is not None and said == v.sampled_at
            labelled &= ok
            sampled_rows.append(cells[:3] + [f"{v.sampled_at:.3g}" if v.sampled_at else "none",
                                             f"{said:.3g}" if said else "none"] + cells[3:])
    false = sum(v.false_interior + v.false_boundary for v in verdicts)
    outside = sum(v.outside for v in verdicts)
    flagged = [v for v in verdicts if v.remaining]
    summary = (f"{len(verdicts)} meshes of {len(cases)} text fields ({refused} refused by "
               f"qmesh at the N asked): {false} false certificates (edges the certificate "
               f"passes with exact q_ij < 0), {outside} triangles whose exact mean is outside "
               f"the stated bound; the least exact q_ij / Σ|q_ij^T| "
               f"{min(v.worst for v in verdicts):.3g}, the largest |exact − stored| "
               f"{max(v.gap_over_bound for v in verdicts):.3g} of its bound. "
               f"{len(flagged)} meshes whose certificate says edges still fail "
               f"({sum(v.remaining for v in flagged)} edges, warned)"
               + (f": the least exact q_ij / Σ|q_ij^T| over every edge of those, the flagged "
                  f"ones included, {min(v.worst for v in flagged):.3g}. " if flagged else ". ")
               + "The callable: " + ("labelled sampled on every mesh, in the Mesh and in "
                                     "measure.report" if labelled else "NOT labelled sampled on "
                                     "every mesh")
               + f"; its sampled means: {sum(v.false_interior + v.false_boundary for v in missed)}"
               f" false edges, {sum(v.outside for v in missed)} triangles outside their bound.")
    print(summary)
    if not args.no_page:
        sampled_headers = HEADERS[:3] + ["Mesh.means_sampled_at", "measure.report's"] + HEADERS[3:]
        report_page.write_page(
            __file__, sys.argv, "Certificates against exact element means: jumps, ramps, bumps, ridges",
            __doc__.split("\n\n", 2)[2].replace("\n", " "),
            tables=[report_page.Table(HEADERS, rows, "text fields: each certified mesh against "
                                      "the exact means"),
                    report_page.Table(sampled_headers, sampled_rows, "a callable with a jump: "
                                      "sampled means, labelled"),
                    report_page.Table(["case", "the field"], labels, "the text fields drawn")],
            notes=[summary], output=out())


if __name__ == "__main__":
    main()
