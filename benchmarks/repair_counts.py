"""Where certify and its repair ask a field for points: points asked and seconds per repair step.

    python benchmarks/repair_counts.py [--cases islands fvca5 plasma] [--n 2000 20000] [--no-page]

Each case of bench_fields.py (`--cases`) is meshed at each target N (`--n`) by `qmesh.mesh` in
this process, with the repair's steps wrapped: the points the field is asked for
(`TensorField.evaluations.asked`) and the seconds each step takes, its own (a step called inside
another counts for itself, not for the outer one). The steps: the mesher before certify;
certify's first means (`RepairState.of`); the mending flips; the splits (their candidates ranked
on rough means); the isosceles slides, the relax moves and the polish, each with its tries
(`moves._judged`) on rough or on adaptive ("full") means; the quality flips; the means of what a
step changed (`RepairState.refresh`) and the tightening of means that fail by their bound only;
the rest of certify. Also each mesh's hash (points, triangles, conductivity: tests/cpu/meshes.py's
`digest`), so that a change can be shown to leave the meshes bit-identical.
"""

from __future__ import annotations

import argparse
import functools
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

import qmesh
import qmesh.fields.certify as certify_module
import qmesh.fields.mesher as mesher_module
import qmesh.fields.moves as moves_module
from qmesh.fields.repair_state import RepairState

import bench_fields
import report_page

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.cpu.meshes import digest  # noqa: E402

STEPS = ("before certify", "first means", "mending flips", "splits", "isosceles",
         "isosceles: full tries", "relax", "relax: full tries", "polish", "polish: rough tries",
         "polish: full tries", "quality flips", "refresh", "tighten", "certify, the rest")


class Counter:
    """Points asked and own seconds per step of one run (`STEPS`)."""

    def __init__(self, field):
        self.field = field
        self.points = defaultdict(int)
        self.seconds = defaultdict(float)
        self.stack: list[list] = []         # [label, points at entry, t at entry, inner s, inner p]

    def asked(self) -> int:
        return self.field.evaluations.asked

    def enter(self, label):
        self.stack.append([label, self.asked(), time.perf_counter(), 0.0, 0])

    def leave(self):
        label, p0, t0, inner_s, inner_p = self.stack.pop()
        p, s = self.asked() - p0, time.perf_counter() - t0
        self.points[label] += p - inner_p
        self.seconds[label] += s - inner_s
        if self.stack:
            self.stack[-1][3] += s
            self.stack[-1][4] += p


COUNTER: Counter | None = None


def _wrapped(f, label):
    @functools.wraps(f)
    def g(*args, **kwargs):
        if COUNTER is None:
            return f(*args, **kwargs)
        name = label(*args, **kwargs) if callable(label) else label
        COUNTER.enter(name)
        try:
            return f(*args, **kwargs)
        finally:
            COUNTER.leave()
    return g


def install() -> None:
    """Wrap the repair's steps where certify.py and moves.py look them up."""
    for name, label in (("mending_flips", "mending flips"), ("split_failing", "splits"),
                        ("split_failing_medium", "splits"), ("isosceles", "isosceles"),
                        ("relax", "relax"), ("polish", "polish"),
                        ("quality_flips", "quality flips")):
        setattr(certify_module, name, _wrapped(getattr(certify_module, name), label))
    moves_module._judged = _wrapped(
        moves_module._judged,
        lambda *a, how="means_with_error", **k: f"{COUNTER.stack[-1][0]}: "
        + ("rough tries" if how == "rough" else "full tries"))
    RepairState.refresh = _wrapped(RepairState.refresh,
                                   lambda st, t, tighten=False: "tighten" if tighten else "refresh")
    of = RepairState.of.__func__
    RepairState.of = classmethod(_wrapped(of, lambda *a, **k: "first means"))
    certify_module.certify = _wrapped(certify_module.certify, "certify, the rest")
    mesher_module.certify = certify_module.certify


def run(case_name: str, n: int) -> dict:
    """One run of `case_name` at target n, counted: points and seconds per step, N, the hash."""
    global COUNTER
    case = bench_fields.CASES[case_name]
    field = case.field()
    COUNTER = Counter(field)
    t0 = time.perf_counter()
    COUNTER.enter("before certify")
    try:
        m = qmesh.mesh(case.domain(), field, target_vertices=n)
    finally:
        COUNTER.leave()
        counter, COUNTER = COUNTER, None
    return {"case": case_name, "n": n, "N": m.n_vertices, "seconds": time.perf_counter() - t0,
            "points": dict(counter.points), "step_seconds": dict(counter.seconds),
            "asked": field.evaluations.asked, "hash": digest(m)}


def rows_of(results) -> list[list]:
    rows = []
    for r in results:
        total = max(r["asked"], 1)
        for step in STEPS:
            p, s = r["points"].get(step, 0), r["step_seconds"].get(step, 0.0)
            if p or s >= 0.005:
                rows.append([r["case"], r["n"], step, f"{p:,}", f"{100 * p / total:.1f}%",
                             f"{s:.2f}"])
        rows.append([r["case"], r["n"], "whole run", f"{r['asked']:,}", "100%",
                     f"{r['seconds']:.2f}"])
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=["islands", "fvca5", "plasma"],
                    choices=[k for k, c in bench_fields.CASES.items()
                             if c.kind in ("formula", "callable")])
    ap.add_argument("--n", nargs="+", type=int, default=[2000, 20000])
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    install()
    results = []
    for n in args.n:
        for name in args.cases:
            r = run(name, n)
            results.append(r)
            print(f"{name} N={r['N']} asked={r['asked']:,} {r['seconds']:.2f} s "
                  f"hash {r['hash']}", flush=True)
    headers = ["case", "target N", "step", "points asked", "share", "own s"]
    rows = rows_of(results)
    print(report_page.markdown_table(headers, rows))
    summary = [[r["case"], r["n"], r["N"], f"{r['asked']:,}", f"{r['seconds']:.2f}", r["hash"]]
               for r in results]
    print(report_page.markdown_table(["case", "target N", "N", "points asked", "s", "mesh hash"],
                                     summary))
    if not args.no_page:
        report_page.write_page(
            __file__, sys.argv if argv is None else ["benchmarks/repair_counts.py", *argv],
            "Points a field is asked for, per step of the repair", __doc__.split("\n\n", 2)[2],
            tables=[report_page.Table(headers, rows, "Points asked and own seconds per step"),
                    report_page.Table(["case", "target N", "N", "points asked", "s",
                                       "mesh hash"], summary, "Each run")])


if __name__ == "__main__":
    main()
