"""How the run's sizing lands on the target: random cases from the property suite.

    python benchmarks/bench_sizing.py [--cases 300] [--seed 0] [--max-target 3000] [--no-page]

For each case, runs `qmesh.mesh` (watching its Steps through `progress`) and counts the runs
that needed a second, smaller-sized run (a second Step of iteration 0), the refusals
(QmeshError), and how far the final N is from the target. Prints figures; asserts nothing.
The script uses only the public API, so it runs unchanged on an older checkout.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, Phase, given, seed, settings

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "properties"))

import qmesh  # noqa: E402
import strategies  # noqa: E402

import report_page  # noqa: E402


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=300)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-target", type=int, default=3000)
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    rows = []

    @seed(args.seed)
    @settings(max_examples=args.cases, deadline=None, database=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @given(strategies.cases(strategies.any_domain(), conductivity="any", max_target=args.max_target))
    def run(case):
        target = case.options["target_vertices"]
        starts = []
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", qmesh.QmeshWarning)
            try:
                m = qmesh.mesh(case.domain.build(), case.conductivity.build(), **case.options,
                               progress=lambda step: starts.append(step.iteration == 0))
            except qmesh.QmeshError:
                rows.append((target, sum(starts), None))
                return
        rows.append((target, sum(starts), m.n_vertices))

    run()
    refused = sum(n is None for _, _, n in rows)
    second = sum(s > 1 for _, s, _ in rows)
    dev = np.array([abs(n - t) / t for t, _, n in rows if n is not None])
    print(f"cases {len(rows)}: meshed {len(dev)}, refused {refused} (QmeshError), "
          f"second run {second}")
    table = [["cases", len(rows)], ["meshed", len(dev)], ["refused (QmeshError)", refused],
             ["needed a second, smaller-sized run", second]]
    if len(dev):
        print(f"|N - target| / target: median {np.median(dev):.3f}, 95th percentile "
              f"{np.percentile(dev, 95):.3f}, max {dev.max():.3f}")
        table += [["|N − target| / target, median", f"{np.median(dev):.3f}"],
                  ["|N − target| / target, 95th percentile", f"{np.percentile(dev, 95):.3f}"],
                  ["|N − target| / target, max", f"{dev.max():.3f}"]]
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv, "How the sizing lands on the target",
            f"{args.cases} random cases from the property suite's strategies (any domain, any "
            f"conductivity, target N up to {args.max_target}, hypothesis seed {args.seed}): each "
            "runs `qmesh.mesh`, watching its Steps through `progress`; counted are the runs that "
            "needed a second, smaller-sized run (a second Step of iteration 0), the refusals "
            "(QmeshError), and how far the final N is from the target.",
            tables=[report_page.Table(["", "value"], table)])


if __name__ == "__main__":
    main()
