"""How often a moved or scaled domain gets the very same triangles.

For random star-shaped polygons about 1 across (tests/properties/test_scale_invariance.py) and a
random constant Q (anisotropy up to 100, any angle), meshes the polygon at unit scale and again
scaled by 10**U(-300, 300) and shifted by up to S of its sizes, and counts identical triangle
arrays. Powers of two are exact by construction (the property test checks them); this prints
what happens for the rest.

    python benchmarks/bench_invariance.py [--cases 25] [--n 150] [--no-page]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import qmesh

import report_page

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "properties"))
from test_scale_invariance import polygon  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=25)
    ap.add_argument("--n", type=int, default=150, help="target vertex count")
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(0)
    print("| shift (sizes) | same triangles | same N |")
    print("|---|---|---|")
    rows = []
    for S in (0.0, 1e2, 1e4, 1e6, 1e8):
        same = same_n = 0
        for _ in range(args.cases):
            seed, n = int(rng.integers(0, 2**31)), int(rng.integers(5, 12))
            A = qmesh.Anisotropy.principal(1.0, float(rng.uniform(1, 100)), float(rng.uniform(0, 180)))
            ref = qmesh.mesh(qmesh.Polygon(polygon(seed, n)), A, target_vertices=args.n)
            f, shift = 10.0 ** rng.uniform(-300, 300), rng.uniform(-1, 1, 2) * S
            m = qmesh.mesh(qmesh.Polygon(polygon(seed, n) * f + shift * f), A, target_vertices=args.n)
            same_n += m.n_vertices == ref.n_vertices
            same += m.n_vertices == ref.n_vertices and np.array_equal(m.triangles, ref.triangles)
        rows.append([f"{S:g}", f"{same}/{args.cases}", f"{same_n}/{args.cases}"])
        print("| " + " | ".join(rows[-1]) + " |")
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "Moved and scaled domains: the same triangles?",
            f"Random star-shaped polygons about 1 across (5–11 corners, "
            f"`tests/properties/test_scale_invariance.py`) under a random constant Q (anisotropy "
            f"up to 100, any angle), meshed at unit scale and again scaled by 10^U(−300, 300) and "
            f"shifted by up to S of their sizes, target N = {args.n}, {args.cases} cases per "
            f"shift: how many gave an identical triangle array, and how many the same N. Powers "
            f"of two are exact by construction (the property test checks them); this page shows "
            f"the rest.",
            tables=[report_page.Table(["shift S (sizes)", "same triangles", "same N"], rows)])


if __name__ == "__main__":
    main()
