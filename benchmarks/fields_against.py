"""CPU seconds of bench_fields cases in this checkout against another, runs interleaved.

    python benchmarks/fields_against.py --other /path/to/other/checkout [--rounds 3]
           [NAME:N ...]

For a change to certify and repair meant to keep every mesh: each round runs the cases once
per checkout, each checkout in a process of its own (this script with --worker, the checkout
first on its path: its qmesh, this checkout's cases), one after the other, after a warm-up of every case at 500 vertices (the
formulas' one-time set-ups); the least CPU seconds over the rounds is kept. Per case: N, the
CPU seconds of certify and repair (the last Step, `bench_fields.stage_seconds`) and of the
whole run (`qmesh.iterate` from building the field), and whether the mesh's hash (sha256 of
its points and triangles) is the same in every run of both checkouts. Prints a Markdown table;
writes no page.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent
CASES = ("spiral:2000", "plasma:2000", "fvca5:2000", "layers:2000", "islands:2000",
         "spiral:20000", "plasma:20000", "fvca5:20000", "layers:20000", "islands:20000")
WARM_UP = 500


def worker(specs: list[str]) -> list[dict]:
    """Each case once in this process (after its warm-up): N, certify and whole-run CPU seconds,
    the mesh's hash."""
    import hashlib
    import warnings

    import numpy as np
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import bench_fields as bf
    import qmesh
    warnings.simplefilter("ignore")            # the repair's N warnings: N is reported

    def run(name: str, n: int) -> dict:
        case = bf.CASES[name]
        domain = case.domain()
        start = time.process_time()
        field = case.field()
        records, stamps = [], [time.process_time()]
        for step in qmesh.iterate(domain, field, target_vertices=n):
            stamps.append(time.process_time())
            records.append((step.stage, step.iteration, step.stats.seconds))
        whole = time.process_time() - start
        mesh = step.mesh
        digest = hashlib.sha256(np.ascontiguousarray(mesh.points, dtype=float).tobytes())
        digest.update(np.ascontiguousarray(mesh.triangles, dtype=np.int64).tobytes())
        return {"N": mesh.n_vertices, "certify": bf.stage_seconds(records, stamps)["certify"],
                "whole": whole, "hash": digest.hexdigest()[:12]}

    cases = [(s.split(":")[0], int(s.split(":")[1])) for s in specs]
    for name in dict.fromkeys(name for name, _ in cases):
        run(name, WARM_UP)
    return [run(name, n) for name, n in cases]


def measured(root: Path, specs: list[str]) -> list[dict]:
    """`worker` with the qmesh of the checkout at root (this script and its cases either way),
    in a process of its own."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root)] + [
        p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    out = subprocess.run([sys.executable, __file__, "--worker", *specs], env=env, check=True,
                         capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def table(specs: list[str], runs: dict[str, list[list[dict]]]) -> str:
    rows = ["| case | N target | N other / this | certify CPU s other → this | "
            "whole run CPU s other → this | mesh hash |", "|---|---|---|---|---|---|"]
    for k, spec in enumerate(specs):
        a, b = ([r[k] for r in runs[side]] for side in ("other", "this"))
        ca, cb = min(x["certify"] for x in a), min(x["certify"] for x in b)
        wa, wb = min(x["whole"] for x in a), min(x["whole"] for x in b)
        same = "same" if len({x["hash"] for x in a + b}) == 1 else "differs"
        name, n = spec.split(":")
        rows.append(f"| {name} | {n} | {a[0]['N']} / {b[0]['N']} | {ca:.2f} → {cb:.2f} "
                    f"({(cb / ca - 1) * 100:+.0f}%) | {wa:.2f} → {wb:.2f} "
                    f"({(wb / wa - 1) * 100:+.0f}%) | {same} |")
    return "\n".join(rows)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases", nargs="*", default=list(CASES), help="NAME:N, e.g. spiral:2000")
    ap.add_argument("--other", type=Path, help="the other checkout's root")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        print(json.dumps(worker(a.cases)))
        return
    if a.other is None:
        ap.error("--other is required")
    runs: dict[str, list[list[dict]]] = {"other": [], "this": []}
    for _ in range(a.rounds):
        for side, root in (("other", a.other.resolve()), ("this", HERE)):
            runs[side].append(measured(root, a.cases))
    print(f"Least CPU seconds of {a.rounds} interleaved rounds; other: {a.other.resolve()}, "
          f"this: {HERE}")
    print(table(a.cases, runs))


if __name__ == "__main__":
    main()
