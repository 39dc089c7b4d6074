"""Stress the mesher with random cases and print a summary of the defects found.

    python benchmarks/stress.py [--cases 2000] [--seed 1] [--kinds regular,convex,thin,holed]
                                [--conductivity any] [--max-target 3000] [--show 2] [--no-page]
                                [--fields 300] [--field-kinds principal,expressions,callable,raster]
                                [--media 300] [--polygons 400] [--time-limit 60]
                                [--reproducers FILE]

(the defaults: the whole mix, about six minutes on two cores; 0 leaves a mix out)

Draws cases from the property suite's strategies (tests/properties/strategies.py: `--cases`
plain domains with a constant Q or a varying s; field_strategies.py: `--fields` TensorFields on
those domains; media_strategies.py: `--media` media of 1–3 regions, each a constant Q or a field;
polygon_strategies.py: `--polygons` random simple polygons with sharp corners), meshes each,
checks it with the independent evaluator (tests/properties/invariants.py), meshes every tenth
case a second time (same seed ⇒ same mesh), and runs every invalid call of
tests/properties/bad_calls.py once. Prints, per mix, the share of cases with a defect, the count
per category with the shortest reproducer of each, the refusals by reason (each corner refusal
with the corner's angle in the metric, measured by the evaluator), and the time per case.
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
import field_strategies  # noqa: E402
import invariants  # noqa: E402
import media_strategies  # noqa: E402
import polygon_strategies  # noqa: E402
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
    p.add_argument("--cases", type=int, default=2000,
                   help="random cases on plain domains, constant Q or varying s (default 2000)")
    p.add_argument("--fields", type=int, default=300,
                   help="random TensorFields on those domains (default 300)")
    p.add_argument("--field-kinds", default=",".join(field_strategies.FIELD_KINDS),
                   help="field kinds, comma-separated: " + ", ".join(field_strategies.FIELD_KINDS))
    p.add_argument("--media", type=int, default=300, help="random media of 1-3 regions (default 300)")
    p.add_argument("--polygons", type=int, default=400,
                   help="random simple polygons with sharp corners, constant Q or a field (default 400)")
    p.add_argument("--reproducers", metavar="FILE",
                   help="append each defective case's defects and whole reproducer to FILE")
    p.add_argument("--time-limit", type=float, default=60.0,
                   help="seconds after which a case is a defect (default 60)")
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


SHARP_BANDS = (3.0, 1.0, 0.1)
"""Degrees: the cases whose sharpest corner in the metric is below each, and how they ended."""


def _names(text: str, known, what: str) -> list[str]:
    names = [k.strip() for k in text.split(",") if k.strip()]
    unknown = [k for k in names if k not in known]
    if unknown:
        raise SystemExit(f"stress: unknown {what} {unknown}; choose from {list(known)}")
    return names


def mixes(args) -> list[tuple[str, int, object]]:
    """(name, cases, strategy) of each mix the options ask for."""
    kinds = _names(args.kinds, KINDS, "kinds")
    field_kinds = tuple(_names(args.field_kinds, field_strategies.FIELD_KINDS, "field kinds"))
    domains = st.one_of(*[KINDS[k]() for k in kinds])
    out = [("plain", args.cases, strategies.cases(domains, conductivity=args.conductivity,
                                                  max_target=args.max_target)),
           ("fields", args.fields, field_strategies.field_cases(domains, field_kinds, args.max_target)),
           ("media", args.media, media_strategies.media_cases(args.max_target)),
           ("polygons", args.polygons, polygon_strategies.polygon_cases(args.max_target))]
    return [m for m in out if m[1] > 0]


def run_cases(args, name: str, cases: int, strategy) -> dict:
    found = {"name": name, "n": 0, "bad": 0, "refused": [], "seconds": [], "by_kind": Counter(),
             "bad_by_kind": Counter(), "categories": Counter(), "examples": defaultdict(list),
             "slowest": (0.0, ""), "bad_not_boundary_q": 0, "refinement_off": Counter(),
             "messages": Counter(), "reasons": Counter(), "corners": [], "warned_off_target": 0,
             "sharp": Counter()}

    @seed(args.seed)
    @settings(max_examples=cases, phases=[Phase.generate], database=None, deadline=None,
              suppress_health_check=list(HealthCheck))
    @given(strategy)
    def one(case):
        found["n"] += 1
        out = invariants.run(case, args.time_limit)
        if found["n"] % 10 == 0 and out.mesh is not None and not out.defects:
            again = invariants.run(case, args.time_limit)
            if again.mesh is None or not (np.array_equal(again.mesh.points, out.mesh.points)
                                          and np.array_equal(again.mesh.triangles, out.mesh.triangles)):
                out.defects.append("determinism: the same case gave a different mesh")
        found["seconds"].append(out.seconds)
        found["by_kind"][case.domain.kind] += 1
        if out.seconds > found["slowest"][0]:
            found["slowest"] = (out.seconds, case.reproducer())
        if out.error is not None and not out.defects:
            found["reasons"][invariants.refusal_reason(out.error)] += 1
        if out.sharpest is not None:
            end = ("a defect" if out.defects else "meshed" if out.mesh is not None
                   else "refused for the corner" if out.corner is not None else "refused otherwise")
            for floor in SHARP_BANDS:
                if out.sharpest < floor:
                    found["sharp"][floor, end] += 1
        if out.corner is not None:
            found["corners"].append((*out.corner, case.reproducer()))
        if out.error is not None and not out.defects:
            found["refused"].append(out.error)
        target = case.options.get("target_vertices")
        if out.mesh is not None and out.warned and not abs(out.mesh.n_vertices - target) <= 0.1 * target:
            found["warned_off_target"] += 1
        if out.defects:
            found["bad"] += 1
            if args.reproducers:
                with open(args.reproducers, "a", encoding="utf-8") as fh:
                    fh.write("\n".join([f"# {name}", *out.defects, case.reproducer(), ""]) + "\n")
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
            print(f"  {name}: {found['n']} cases, {found['bad']} with defects", file=sys.stderr, flush=True)

    one()
    return found


def report(found: dict, args) -> None:
    n, bad = found["n"], found["bad"]
    sec = np.array(found["seconds"]) if found["seconds"] else np.zeros(1)
    print(f"[{found['name']}] qmesh {qmesh.__version__}: {n} random cases, {bad} with a defect "
          f"({100 * bad / max(n, 1):.1f}%)")
    print(f"with a defect other than boundary q_ij < 0: {found['bad_not_boundary_q']} "
          f"({100 * found['bad_not_boundary_q'] / max(n, 1):.1f}%)")
    print("by kind: " + ", ".join(f"{k} {found['bad_by_kind'][k]}/{c}" for k, c in sorted(found["by_kind"].items())))
    print(f"time per case: median {np.median(sec):.3f} s, max {sec.max():.2f} s, total {sec.sum():.0f} s")
    print(f"refused with a reason (QmeshError naming the option or what to change): {len(found['refused'])}")
    reasons = ", ".join(f"{r} {c}" for r, c in found["reasons"].most_common())
    print(f"refusals by reason: {reasons or 'none'}")
    for msg in sorted(set(found["refused"]))[:5]:
        print(f"    {msg[:160]}")
    if found["warned_off_target"]:
        print(f"meshes more than 10% off the target, with a warning saying why: {found['warned_off_target']}")
    for floor in SHARP_BANDS:
        ends = {e: c for (f, e), c in found["sharp"].items() if f == floor}
        print(f"sharpest corner under {floor:g}° in the metric: {sum(ends.values())} cases"
              + (" (" + ", ".join(f"{e} {c}" for e, c in sorted(ends.items())) + ")" if ends else ""))
    if found["corners"]:
        print("corner refusals (the angle qmesh states, the smallest metric angle at that corner "
              "measured by the evaluator, in degrees):")
    for stated, measured, code in sorted(found["corners"], key=lambda c: -c[1]):
        print(f"    {stated:.3g}  {measured:.3g}  {code[:200]}")
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
    runs = [run_cases(args, *m) for m in mixes(args)]
    with report_page.capture() as printed:
        for found in runs:
            report(found, args)
        if not args.no_bad_calls:
            run_bad_calls()
        print(f"wall time {time.perf_counter() - t0:.0f} s")
    if not args.no_page:
        rows = []
        for f in runs:
            n, sec = f["n"], np.array(f["seconds"]) if f["seconds"] else np.zeros(1)
            corners = sorted(c[1] for c in f["corners"])
            rows.append([f["name"], n, f"{f['bad']} ({100 * f['bad'] / max(n, 1):.1f}%)",
                         ", ".join(f"{c} {k}" for k, c in f["categories"].most_common()) or "—",
                         ", ".join(f"{r} {c}" for r, c in f["reasons"].most_common()) or "—",
                         ", ".join(f"{a:.3g}" for a in corners) or "—",
                         f"{np.median(sec):.3f}, {sec.max():.2f}"])
        report_page.write_page(
            __file__, sys.argv, "Stress: random cases and their defects",
            "Cases drawn from the property suite's strategies: plain domains "
            f"(`tests/properties/strategies.py`; domain kinds {args.kinds}, conductivity "
            f"{args.conductivity}), conductivity fields on them "
            f"(`field_strategies.py`; kinds {args.field_kinds}), media of 1–3 regions each a "
            "constant Q or a field (`media_strategies.py`), and random simple polygons with sharp "
            "corners under a constant Q or a field (`polygon_strategies.py`); target N up to "
            f"{args.max_target}, hypothesis seed {args.seed}. Each is meshed and checked by the "
            "independent evaluator (`tests/properties/invariants.py`, `field_invariants.py`: "
            "every q_ij ≥ 0 with the mesh's own element means, interface shares each on its own; "
            "a corner refused only below 0.1° in the metric), a case past "
            f"{args.time_limit:g} s is a defect; every tenth case is meshed a second time (same "
            "seed ⇒ same mesh), and every invalid call of `tests/properties/bad_calls.py` is run "
            "once" + (" (not in this run)" if args.no_bad_calls else "") + ". The console output "
            "lists the shortest reproducer of each defect category.",
            tables=[report_page.Table(["mix", "cases", "with a defect", "defects by category",
                                       "refusals by reason", "corner refusals: metric angle (°)",
                                       "time per case: median, max (s)"], rows)],
            output=printed())
    return 0


if __name__ == "__main__":
    sys.exit(main())
