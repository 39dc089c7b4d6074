"""CPU seconds of the chapter's case in this checkout against another, runs interleaved.

    python benchmarks/cpu_against.py --other /path/to/other/checkout [--sizes 1e5 1e6] [--runs 3]
           [--no-command] [--no-triangle]

For a machine shared with other work, where wall seconds say more about the others than about
qmesh: each measurement runs in its own process, the two checkouts one after the other in every
round, and the best of the rounds is kept (peak memory: the least and the most of the rounds).
Per checkout and size: the CPU seconds (user + system) of `qmesh.iterate` on Q = diag(0.1, 10)
over Disk(512), stage by stage, with a hash of the mesh's points and triangles (a rewrite that
should change nothing must keep it) and the process's peak RSS; and the whole
`qmesh mesh --Q 0.1 0 10 --disk 512 --target-vertices N -o x.msh` command: wall and CPU seconds
and peak RSS of its process. Triangle's CPU seconds on the same disk (pq30a, its area calibrated
by one probe run, as bench_mesher.py does) are the yardstick. Prints a Markdown table and
writes it to docs/benchmarks/cpu_against.md (unless --no-page), naming both checkouts' commits.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))
import report_page  # noqa: E402 — beside this script

HEADERS = ["N", "checkout", "meshing CPU s", "stages (CPU s)", "mesh hash", "meshing peak MB",
           "command wall s", "command CPU s", "command peak MB", "meshing / Triangle",
           "command CPU / Triangle"]


def child_mesh(n: int) -> dict:
    """The run's CPU seconds in this process, by stage, and the mesh's hash."""
    import hashlib

    import numpy as np
    import qmesh
    domain, anisotropy = qmesh.Disk(512), qmesh.Anisotropy.constant(qmesh.CHAPTER_Q)
    iterate = qmesh.iterate                   # imported before the clock starts
    stages: dict[str, float] = {}
    start = last = time.process_time()
    for step in iterate(domain, anisotropy, target_vertices=n, seed=0):
        now = time.process_time()
        stages[step.stage] = stages.get(step.stage, 0.0) + now - last
        last, mesh = now, step.mesh
    cpu = time.process_time() - start
    digest = hashlib.sha256(np.ascontiguousarray(mesh.points).tobytes()
                            + np.ascontiguousarray(mesh.triangles, np.int64).tobytes()).hexdigest()
    return {"cpu": cpu, "stages": stages, "hash": digest[:16], "n": mesh.n_vertices,
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def child_triangle(n: int) -> dict:
    """Triangle's CPU seconds for about n vertices on the same disk, isotropic (pq30a)."""
    import numpy as np
    import qmesh
    import triangle
    domain = qmesh.Disk(512)
    pslg = {"vertices": np.array(domain.seeds), "segments": np.array(domain.segments, np.int32)}
    a = domain.area / n
    a *= len(triangle.triangulate(pslg, f"pq30a{a:.15f}Q")["vertices"]) / n
    start = time.process_time()
    out = triangle.triangulate(pslg, f"pq30a{a:.15f}Q")
    return {"cpu": time.process_time() - start, "n": len(out["vertices"])}


def _child(kind: str, n: int, checkout: Path) -> dict:
    """One measurement in a fresh interpreter that imports qmesh from `checkout`."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(checkout)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    out = subprocess.run([sys.executable, __file__, "--child", kind, str(n)], env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _command(n: int, checkout: Path) -> dict:
    """The whole `qmesh mesh … -o x.msh` command from `checkout`: wall and CPU seconds (user +
    system, from its rusage) and its peak RSS."""
    env = dict(os.environ, PYTHONPATH=str(checkout))
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "qmesh", "mesh", "--Q", "0.1", "0", "10", "--disk", "512",
               "--target-vertices", str(n), "-o", os.path.join(tmp, "x.msh")]
        with open(os.path.join(tmp, "stderr"), "w+") as err:
            start = time.perf_counter()
            # run from the temporary folder: `python -m` puts the working directory first on
            # sys.path, so from a checkout's root it would import that checkout's qmesh
            proc = subprocess.Popen(cmd, env=env, cwd=tmp, stdout=subprocess.DEVNULL, stderr=err)
            _, status, usage = os.wait4(proc.pid, 0)
            wall = time.perf_counter() - start
            proc.returncode = os.waitstatus_to_exitcode(status)       # reaped here, not by Popen
            if status != 0:
                err.seek(0)
                raise RuntimeError(f"{' '.join(cmd)} failed: {err.read()[-300:]}")
    return {"wall": wall, "cpu": usage.ru_utime + usage.ru_stime, "peak_mb": usage.ru_maxrss / 1024.0}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--other", type=Path, help="the checkout to compare with (its root folder)")
    p.add_argument("--sizes", type=float, nargs="+", default=[1e5, 1e6])
    p.add_argument("--runs", type=int, default=3, help="rounds; the best of them is kept")
    p.add_argument("--no-command", action="store_true", help="time the meshing only")
    p.add_argument("--no-triangle", action="store_true", help="leave Triangle out")
    p.add_argument("--child", nargs=2, metavar=("KIND", "N"), help=argparse.SUPPRESS)
    report_page.add_option(p)
    args = p.parse_args(argv)
    if args.child:
        kind, n = args.child[0], int(float(args.child[1]))
        print(json.dumps(child_mesh(n) if kind == "mesh" else child_triangle(n)))
        return 0
    if args.other is None:
        p.error("--other is required")
    checkouts = {"this": HERE, "other": args.other.resolve()}
    print(f"this: {HERE}; other: {checkouts['other']}; best of {args.runs} interleaved rounds")
    print("| " + " | ".join(HEADERS) + " |")
    print("|" + "---|" * len(HEADERS))
    rows = []
    for n in (int(s) for s in args.sizes):
        best: dict[tuple[str, str], dict] = {}
        peaks: dict[tuple[str, str], list[float]] = {}
        for _ in range(args.runs):
            for name, root in checkouts.items():
                for kind in ("mesh",) if args.no_command else ("mesh", "command"):
                    r = _child("mesh", n, root) if kind == "mesh" else _command(n, root)
                    peaks.setdefault((name, kind), []).append(r["peak_mb"])
                    old = best.get((name, kind))
                    if old is None or r["cpu"] < old["cpu"]:
                        best[(name, kind)] = r
            if not args.no_triangle:
                r = _child("triangle", n, HERE)
                old = best.get(("Triangle", "mesh"))
                if old is None or r["cpu"] < old["cpu"]:
                    best[("Triangle", "mesh")] = r
        tri = best[("Triangle", "mesh")]["cpu"] if ("Triangle", "mesh") in best else None
        tri = tri or None                     # too fast for the clock: no ratios

        def span(key):
            return f"{min(peaks[key]):,.0f}–{max(peaks[key]):,.0f}"
        for name in checkouts:
            m, c = best[(name, "mesh")], best.get((name, "command"))
            stages = ", ".join(f"{k} {v:.2f}" for k, v in m["stages"].items())
            cells = [f"{n:,}", name, f"{m['cpu']:.2f}", stages, m["hash"], span((name, "mesh")),
                     *(["", "", ""] if c is None else
                       [f"{c['wall']:.2f}", f"{c['cpu']:.2f}", span((name, "command"))]),
                     "" if tri is None else f"{m['cpu'] / tri:.1f}",
                     "" if tri is None or c is None else f"{c['cpu'] / tri:.1f}"]
            rows.append(cells)
            print("| " + " | ".join(cells) + " |", flush=True)
        if ("Triangle", "mesh") in best:
            rows.append([f"{n:,}", "Triangle (pq30a)", f"{best[('Triangle', 'mesh')]['cpu']:.2f}"])
            print(f"| {n:,} | Triangle (pq30a) | {best[('Triangle', 'mesh')]['cpu']:.2f} |"
                  + "  |" * 8, flush=True)
    if not args.no_page:
        names = {name: _commit(root) for name, root in checkouts.items()}
        report_page.write_page(
            __file__, sys.argv, "The chapter's case: this checkout against another, CPU seconds",
            __doc__.split("\n\n", 2)[2].strip(),
            tables=[report_page.Table(HEADERS, rows, f"Best of {args.runs} interleaved rounds: "
                                      f"this = {names['this']}, other = {names['other']}")])
    return 0


def _commit(root: Path) -> str:
    """The checkout's commit (short), or its folder when it is not a git checkout."""
    out = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
                         capture_output=True, text=True)
    return out.stdout.strip() or str(root)


if __name__ == "__main__":
    sys.exit(main())
