"""Stress the mesher with random cases and print a summary of the defects found.

    python benchmarks/stress.py --cases 2000 [--seed 1] [--kinds regular,convex,thin,holed]
                                [--conductivity any] [--max-target 3000] [--show 2] [--no-page]

Draws cases from the property suite's strategies (tests/properties/strategies.py), meshes each,
checks it with the independent evaluator (tests/properties/invariants.py), meshes every tenth
case a second time (same seed ⇒ same mesh), and runs every invalid call of
tests/properties/bad_calls.py once. Prints the share of cases with a defect, the count per
category with the shortest reproducer of each, the QmeshErrors that explained a refusal, and
the time per case.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, Phase, given, seed, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "properties"))

import bad_calls  # noqa: E402
import invariants  # noqa: E402
import strategies  # noqa: E402

import qmesh  # noqa: E402
import report_page  # noqa: E402

KINDS = {
    "regular": strategies.regular_domains,
    "convex": strategies.convex_domains,
    "thin": strategies.thin_domains,
    "holed": strategies.holed_domains,
    "named": strategies.named_domains,
}


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", type=int, default=2000, help="random cases to mesh (default 2000)")
    p.add_argument("--seed", type=int, default=1,
                   help="hypothesis seed (default 1); the cases drawn may still differ between runs")
    p.add_argument("--kinds", default="regular,convex,thin" + (",holed,named" if strategies.HAS_DOMAIN else ""),
                   help="domain kinds, comma-separated: " + ", ".join(KINDS))
    p.add_argument("--conductivity", default="any", choices=["constant", "varying", "any"])
    p.add_argument("--max-target", type=int, default=strategies.MAX_TARGET)
    p.add_argument("--show", type=int, default=1, help="reproducers to print per category")
    p.add_argument("--no-bad-calls", action="store_true", help="skip the invalid calls")
    report_page.add_option(p)
    return p.parse_args(argv)


def run_cases(args) -> dict:
    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        raise SystemExit(f"stress: unknown kinds {unknown}; choose from {list(KINDS)}")
    domains = st.one_of(*[KINDS[k]() for k in kinds])
    found = {"n": 0, "bad": 0, "refused": [], "seconds": [], "by_kind": Counter(), "bad_by_kind": Counter(),
             "categories": Counter(), "examples": defaultdict(list), "slowest": (0.0, ""),
             "bad_not_boundary_q": 0, "refinement_off": Counter(), "messages": Counter()}

    @seed(args.seed)
    @settings(max_examples=args.cases, phases=[Phase.generate], database=None, deadline=None,
              suppress_health_check=list(HealthCheck))
    @given(strategies.cases(domains, conductivity=args.conductivity, max_target=args.max_target))
    def one(case):
        found["n"] += 1
        out = invariants.run(case)
        if found["n"] % 10 == 0 and out.mesh is not None and not out.defects:
            again = invariants.run(case)
            if again.mesh is None or not (np.array_equal(again.mesh.points, out.mesh.points)
                                          and np.array_equal(again.mesh.triangles, out.mesh.triangles)):
                out.defects.append("determinism: the same case gave a different mesh")
        found["seconds"].append(out.seconds)
        found["by_kind"][case.domain.kind] += 1
        if out.seconds > found["slowest"][0]:
            found["slowest"] = (out.seconds, case.reproducer())
        if out.error is not None and not out.defects:
            found["refused"].append(out.error)
        if out.defects:
            found["bad"] += 1
            found["bad_by_kind"][case.domain.kind] += 1
            cats = {invariants.category(d) for d in out.defects}
            if cats - {"q_ij-boundary"}:
                found["bad_not_boundary_q"] += 1
            for d in out.defects:
                if invariants.category(d) in ("error", "exception", "warning", "refused-domain"):
                    found["messages"][re.sub(r"[-+]?\d[\d.e+-]*", "#", d)[:110]] += 1
            for cat in sorted(cats):
                found["categories"][cat] += 1
                found["refinement_off"][cat] += not case.options.get("boundary_refinement", True)
                first = next(d for d in out.defects if invariants.category(d) == cat)
                found["examples"][cat].append((len(case.reproducer()), case.reproducer(), first))
        if found["n"] % 100 == 0:
            print(f"  {found['n']} cases, {found['bad']} with defects", file=sys.stderr, flush=True)

    one()
    return found


def report(found: dict, args) -> None:
    n, bad = found["n"], found["bad"]
    sec = np.array(found["seconds"]) if found["seconds"] else np.zeros(1)
    print(f"qmesh {qmesh.__version__}: {n} random cases, {bad} with a defect ({100 * bad / max(n, 1):.1f}%)")
    print(f"with a defect other than boundary q_ij < 0: {found['bad_not_boundary_q']} "
          f"({100 * found['bad_not_boundary_q'] / max(n, 1):.1f}%)")
    print("by kind: " + ", ".join(f"{k} {found['bad_by_kind'][k]}/{c}" for k, c in sorted(found["by_kind"].items())))
    print(f"time per case: median {np.median(sec):.3f} s, max {sec.max():.2f} s, total {sec.sum():.0f} s")
    print(f"refused with a reason (QmeshError naming the option): {len(found['refused'])}")
    for msg in sorted(set(found["refused"]))[:5]:
        print(f"    {msg[:160]}")
    if found["categories"]:
        print("defects (cases per category; of them with boundary_refinement=False):")
    for cat, count in found["categories"].most_common():
        print(f"  {cat:<14} {count:5d}  ({found['refinement_off'][cat]} without refinement)")
        for _, code, first in sorted(found["examples"][cat])[:args.show]:
            print(f"      {first[:200]}")
            print(f"      {code[:600]}")
    if found["messages"]:
        print("errors, exceptions and warnings (numbers replaced by #):")
    for msg, count in found["messages"].most_common():
        print(f"  {count:5d}  {msg}")
    if found["slowest"][1]:
        print(f"slowest case ({found['slowest'][0]:.2f} s): {found['slowest'][1][:300]}")


def run_bad_calls() -> None:
    problems = [(b.what, bad_calls.outcome(b)) for b in bad_calls.CALLS]
    problems = [(w, p) for w, p in problems if p is not None]
    kinds = Counter(p.split(" ")[0] if "instead" in p else p.split(":")[0][:60] for _, p in problems)
    print(f"invalid calls: {len(bad_calls.CALLS)}, {len(problems)} without a QmeshError naming the argument")
    for kind, count in kinds.most_common():
        print(f"  {count:4d}  {kind}")
    entries = Counter(w.split("(")[0] for w, _ in problems)
    print("  by entry point: " + ", ".join(f"{e} {c}" for e, c in entries.most_common()))


def main(argv=None) -> int:
    args = parse_args(argv)
    t0 = time.perf_counter()
    found = run_cases(args)
    with report_page.capture() as printed:
        report(found, args)
        if not args.no_bad_calls:
            run_bad_calls()
        print(f"wall time {time.perf_counter() - t0:.0f} s")
    if not args.no_page:
        n, sec = found["n"], np.array(found["seconds"]) if found["seconds"] else np.zeros(1)
        rows = [["random cases", n],
                ["with a defect", f"{found['bad']} ({100 * found['bad'] / max(n, 1):.1f}%)"],
                ["with a defect other than boundary q_ij < 0",
                 f"{found['bad_not_boundary_q']} ({100 * found['bad_not_boundary_q'] / max(n, 1):.1f}%)"],
                ["refused with a QmeshError naming the option", len(found["refused"])],
                ["time per case: median, max (s)", f"{np.median(sec):.3f}, {sec.max():.2f}"]]
        rows += [[f"defects in category {cat}", count] for cat, count in found["categories"].most_common()]
        report_page.write_page(
            __file__, sys.argv, "Stress: random cases and their defects",
            f"{n} cases drawn from the property suite's strategies "
            f"(`tests/properties/strategies.py`; domain kinds {args.kinds}, conductivity "
            f"{args.conductivity}, target N up to {args.max_target}, hypothesis seed {args.seed}), "
            "each meshed and checked by the independent evaluator "
            "(`tests/properties/invariants.py`); every tenth case is meshed a second time (same "
            "seed ⇒ same mesh), and every invalid call of `tests/properties/bad_calls.py` is run "
            "once" + (" (not in this run)" if args.no_bad_calls else "") + ". The console output "
            "lists the shortest reproducer of each defect category.",
            tables=[report_page.Table(["", "value"], rows)], output=printed())
    return 0


if __name__ == "__main__":
    sys.exit(main())
