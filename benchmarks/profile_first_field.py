"""A field's first triangulation at scale: bench_fields' raster512 (512² cells, every cell
different) meshed at each target N, one fresh subprocess per run, printing CPU seconds per stage
(`qmesh.iterate`'s Steps, split as bench_fields' STAGES: the first triangulation is the first
Step's own seconds), peak RSS (VmHWM of /proc/self/status) after the first triangulation and
over the run, N, the negative q_ij on the mesh's own element means (interior / boundary) and the
min quality; --profile adds a cProfile in CPU seconds of the first triangulation (top functions
by own time), --memory the peak RSS after each stage, --hash a hash of the mesh (the same mesh
before and after a pure speed-up). CPU seconds, not wall: the machine may be shared.

    python benchmarks/profile_first_field.py [--n 200000 1000000] [--case raster512]
                                             [--profile] [--top 25] [--memory] [--hash]
                                             [--no-page]
"""

from __future__ import annotations

import argparse
import cProfile
import hashlib
import json
import pstats
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import report_page  # noqa: E402 — beside this script

STAGES = ("set-up", "first triangulation", "adjust", "insert", "triangulate", "certify")


def _rss_kb(key: str = "VmHWM:") -> int:
    """A line of /proc/self/status in kB (VmHWM: the peak so far)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key):
                return int(line.split()[1])
    return 0


def _worker(case_name: str, n: int, profile: bool, top: int, memory: bool) -> dict:
    """One run in this process: CPU seconds per stage, peak RSS, the mesh's checks."""
    import qmesh
    from bench_fields import CASES
    from qmesh import measure

    fld = CASES[case_name].field()
    domain = CASES[case_name].domain()
    cpu = dict.fromkeys(STAGES, 0.0)
    peaks: list[tuple[str, int]] = []
    prof = cProfile.Profile(time.process_time) if profile else None     # CPU: the machine is shared
    steps = qmesh.iterate(domain, fld, target_vertices=n)
    t = time.process_time()
    t_all = t
    if prof is not None:
        prof.enable()
    step = first = next(steps)
    if prof is not None:
        prof.disable()
    now = time.process_time()
    own = first.stats.seconds     # wall seconds of the first triangulation: the rest is set-up
    cpu["first triangulation"] += min(own, now - t)
    cpu["set-up"] += now - t - min(own, now - t)
    peaks.append(("first triangulation", _rss_kb()))
    first_peak = peaks[-1][1]
    t = now
    parts = []
    for step in steps:
        now = time.process_time()
        parts.append((step.stage, now - t))
        t = now
        if memory:
            peaks.append((step.stage, _rss_kb()))
    for k, (stage, seconds) in enumerate(parts):   # the last Step: certify and repair
        cpu["certify" if k == len(parts) - 1 else stage] += seconds
    total = time.process_time() - t_all
    m = step.mesh
    r_in, r_b, _ = measure._relative_q(m, measure._resolve(m, None), split=True)
    out = {"case": case_name, "target": n, "N": m.n_vertices, "cpu": cpu, "total": total,
           "peak_mb": _rss_kb() / 1024, "first_peak_mb": first_peak / 1024,
           "positive": [int((r_in < -measure.Q_RTOL).sum()), int((r_b < -measure.Q_RTOL).sum())],
           "min_quality": float(measure.quality(m).min())}
    out["hash"] = hashlib.sha256(np.ascontiguousarray(m.points).tobytes()
                                 + np.ascontiguousarray(m.triangles).tobytes()).hexdigest()[:16]
    if memory:
        out["peaks"] = [(stage, kb / 1024) for stage, kb in peaks]
    if prof is not None:
        stats = pstats.Stats(prof).stats
        rows = sorted(((tt, ct, nc, f"{fn.rsplit('/', 1)[-1]}:{name}")
                       for (fn, line, name), (cc, nc, tt, ct, callers) in stats.items()),
                      reverse=True)
        out["profile"] = [(name, tt, ct, nc) for tt, ct, nc, name in rows[:top]]
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=float, nargs="+", default=[200_000, 1_000_000])
    ap.add_argument("--case", default="raster512")
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--top", type=int, default=25)
    ap.add_argument("--memory", action="store_true")
    ap.add_argument("--hash", action="store_true", help="print the mesh's hash")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    report_page.add_option(ap)
    args = ap.parse_args(argv)
    if args.worker:
        print(json.dumps(_worker(args.case, int(args.n[0]), args.profile, args.top, args.memory)))
        return
    rows, lines = [], []
    for n in args.n:
        cmd = [sys.executable, __file__, "--worker", "--case", args.case, "--n", str(int(n)),
               "--top", str(args.top)] + (["--profile"] if args.profile else []) \
            + (["--memory"] if args.memory else [])
        r = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
        stages = "  ".join(f"{s} {r['cpu'][s]:.2f}" for s in STAGES)
        text = [f"{r['case']} target {r['target']}: N {r['N']}, CPU {r['total']:.2f} s "
                f"({stages}), peak RSS {r['peak_mb']:.0f} MB",
                f"  q_ij < 0 (the mesh's means) interior / boundary: {r['positive'][0]} / "
                f"{r['positive'][1]}, min quality {r['min_quality']:.3f}"]
        text += [f"  hash {r['hash']}"] if args.hash else []
        text += [f"  peak RSS after {s}: {mb:.0f} MB" for s, mb in r.get("peaks", [])]
        text += [f"  {tt:8.2f} own {ct:8.2f} cum {nc:9d} calls  {name}"
                 for name, tt, ct, nc in r.get("profile", [])]
        print("\n".join(text), flush=True)
        lines += text
        rows.append([r["case"], str(r["target"]), str(r["N"]),
                     *(f"{r['cpu'][s]:.2f}" for s in STAGES), f"{r['total']:.2f}",
                     f"{r['first_peak_mb']:.0f}", f"{r['peak_mb']:.0f}",
                     f"{r['positive'][0]} / {r['positive'][1]}", f"{r['min_quality']:.3f}"])
    if not args.no_page:
        headers = ["case", "target N", "N", *(f"{s} CPU s" for s in STAGES), "whole run CPU s",
                   "peak RSS MB after the first triangulation", "peak RSS MB",
                   "q_ij < 0 interior / boundary", "min quality"]
        report_page.write_page(
            __file__, sys.argv, "A field's first triangulation at scale",
            __doc__.split("\n\n")[0].replace("\n", " "),
            tables=[report_page.Table(headers, rows, "one fresh process per run")],
            output="\n".join(lines))


if __name__ == "__main__":
    main()
