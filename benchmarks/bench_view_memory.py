"""Peak memory of a whole viewer request, per vertex: the figures behind
`qmesh_view.memory.BYTES_PER_VERTEX` (and VIRTUAL_BYTES_PER_VERTEX).

A request in `qmesh-view` is more than `qmesh.mesh`: the run keeps every Step of its history,
the status line measures each stage (κ2 factorises the stiffness matrix), and the three views
build their scenes and render them. Each case runs in a fresh Python process, as the server
does: after the imports and a small warm-up request (drawn and rendered) its resident memory is
the baseline; then a `Session` at the target is run to its end, every stage measured as the
app measures it (`Session.status`) and drawn and rendered off-screen (`ViewSet`). The peak is
/proc/self/status VmHWM; its phases are told apart by resetting VmHWM between them
(/proc/self/clear_refs). Alongside, `qmesh.mesh` alone in its own process (what
`qmesh.mesher.budget` counts). Bytes per vertex = (peak − baseline) / N.

    python benchmarks/bench_view_memory.py [--sizes 20000 50000 100000] [--domains disk inclusion] [--no-draw]
    python benchmarks/bench_view_memory.py --budget 1.5G [--domains disk inclusion]

`--budget` checks the guard instead: in a process that has drawn a first request, a `Session`
under that memory budget is asked for 1,000,000 vertices; the refusal names the largest target
that fits, which is then run to its end, measured and drawn; the process's peak (VmHWM) is
printed beside the budget.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

import report_page

CHILD = r"""
import json, os, sys, tempfile, time
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
n, domain, s_text, draw = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4] == "1"
from qmesh_view.session import Session
from qmesh_view.draw import ViewSet

def status(field):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field):
                return int(line.split()[1]) * 1024

def reset_peak():
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")

extra = {"q_mode": "expression", "s_text": s_text} if s_text else {}
BIG = 2**50
views = ViewSet() if draw else None
def request(target):
    s = Session(memory_budget=BIG, domain=domain, target_vertices=target, **extra)
    if views is not None:
        views.draw(s.current, s.anisotropy, domain=s.domain); views.images()
    while not s.at_end:
        s.step(); s.status()
        if views is not None:
            views.draw(s.current, s.anisotropy, domain=s.domain); views.images()
    s.convergence()
    return s
request(300)                                # warm-up: lazy imports, the GL context
base, vbase = status("VmRSS:"), status("VmSize:")
reset_peak()
t = time.perf_counter()
s = request(n)
seconds = time.perf_counter() - t
peak = status("VmHWM:")
steps = len(s.history)
kept = sum(st.mesh.n_vertices for st in s.history)
print(json.dumps({"n": s.current.mesh.n_vertices, "base": base, "peak": peak,
                  "vbase": vbase, "vpeak": status("VmPeak:"),
                  "held": status("VmRSS:"), "steps": steps, "kept": kept, "seconds": seconds}))
"""

BUDGET_CHILD = r"""
import json, os, re, sys
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
allowed, domain, s_text = int(sys.argv[1]), sys.argv[2], sys.argv[3]
from qmesh_view.session import Session
from qmesh_view.draw import ViewSet

def status(field):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field):
                return int(line.split()[1]) * 1024

extra = {"q_mode": "expression", "s_text": s_text} if s_text else {}
views = ViewSet()
s = Session(memory_budget=allowed, domain=domain, **extra)
def show():
    views.draw(s.current, s.anisotropy, domain=s.domain); views.images()
show()
out = s.change("target_vertices", 1_000_000)
found = re.search(r"fits is about (\d+)", out.message)
most = int(found.group(1)) if found else None
done = s.change("target_vertices", most) if most else None
show()
while done is not None and done.ok and not s.at_end:
    done = s.step()
    s.status(); show()
s.convergence()
print(json.dumps({"refused": out.kind == "refused", "message": out.message, "most": most,
                  "n": s.current.mesh.n_vertices, "ok": done is not None and done.ok,
                  "hwm": status("VmHWM:")}))
"""

MESH_CHILD = r"""
import json, sys, time
import qmesh
from qmesh_view.controller import Params
from qmesh_view.problem import make_anisotropy, make_domain
n, domain, s_text = int(sys.argv[1]), sys.argv[2], sys.argv[3]
def p(target):
    extra = {"q_mode": "expression", "s_text": s_text} if s_text else {}
    return Params(domain=domain, target_vertices=target, **extra)
def status(field):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field):
                return int(line.split()[1]) * 1024
def run(q):
    return qmesh.mesh(make_domain(q, {}), make_anisotropy(q), target_vertices=q.target_vertices, seed=0)
run(p(300))
base = status("VmRSS:")
with open("/proc/self/clear_refs", "w") as f:
    f.write("5")
m = run(p(n))
print(json.dumps({"n": m.n_vertices, "base": base, "peak": status("VmHWM:")}))
"""


def child(code: str, *args) -> dict:
    out = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def check_budget(a) -> None:
    from qmesh_view.cli import memory_size
    allowed = memory_size(a.budget)
    rows = []
    for case in a.domains:
        domain, _, s_text = case.partition(":")
        r = child(BUDGET_CHILD, allowed, domain, s_text)
        print(f"{case}: 1e6 {'refused' if r['refused'] else 'ACCEPTED'}: {r['message']}")
        print(f"{case}: ran N = {r['n']} ({'to its end' if r['ok'] else 'FAILED'}), peak "
              f"{r['hwm'] / 2**30:.2f} GiB against the budget {allowed / 2**30:.2f} GiB", flush=True)
        rows.append([case, "refused" if r["refused"] else "accepted", r["most"], r["n"],
                     f"{r['hwm'] / 2**30:.2f}", f"{allowed / 2**30:.2f}"])
    if not a.no_page:
        report_page.write_page(
            __file__, sys.argv, "The viewer's memory guard under a budget",
            f"In a process that has drawn a first request, a `Session` under the memory budget "
            f"{a.budget} is asked for 1,000,000 vertices; its refusal names the largest target that "
            "fits, which is run to its end, every stage measured and drawn off-screen; the "
            "process's peak resident memory (VmHWM) beside the budget.",
            tables=[report_page.Table(["case", "1e6", "largest that fits", "N", "peak GiB",
                                       "budget GiB"], rows)], suffix="budget")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", nargs="+", type=int, default=[20_000, 50_000, 100_000])
    p.add_argument("--domains", nargs="+", default=["disk", "disk:exp(x) + y**2", "inclusion"],
                   help="a domain name, or name:s(x, y) for a varying s")
    p.add_argument("--no-draw", action="store_true", help="measure without the views")
    p.add_argument("--budget", help="check the guard under this budget (e.g. 1.5G) instead")
    report_page.add_option(p)
    a = p.parse_args()
    if a.budget:
        check_budget(a)
        return
    rows = []
    print(f"{'case':<22}{'target':>9}{'N':>9}{'steps':>7}{'base MB':>9}{'peak MB':>9}"
          f"{'view B/v':>10}{'held B/v':>10}{'mesh B/v':>10}{'ratio':>7}{'VM B/v':>8}{'s':>7}")
    for case in a.domains:
        domain, _, s_text = case.partition(":")
        for n in a.sizes:
            t = time.perf_counter()
            r = child(CHILD, n, domain, s_text, "0" if a.no_draw else "1")
            m = child(MESH_CHILD, n, domain, s_text)
            per = (r["peak"] - r["base"]) / r["n"]
            mesh_per = (m["peak"] - m["base"]) / m["n"]
            held = (r["held"] - r["base"]) / r["n"]
            virtual = (r["vpeak"] - r["vbase"]) / r["n"]
            print(f"{case:<22}{n:>9}{r['n']:>9}{r['steps']:>7}{r['base'] / 1e6:>9.0f}"
                  f"{r['peak'] / 1e6:>9.0f}{per:>10.0f}{held:>10.0f}{mesh_per:>10.0f}"
                  f"{per / mesh_per:>7.2f}{virtual:>8.0f}"
                  f"{time.perf_counter() - t:>7.0f}", flush=True)
            rows.append([case, n, r["n"], r["steps"], f"{r['base'] / 1e6:.0f}",
                         f"{r['peak'] / 1e6:.0f}", f"{per:.0f}", f"{held:.0f}", f"{mesh_per:.0f}", f"{virtual:.0f}"])
    if not a.no_page:
        report_page.write_page(
            __file__, sys.argv, "Peak memory of a viewer request",
            "Peak resident memory of one whole request in the viewer (a `Session` run to its end, "
            "every stage kept, measured by `Session.status` and drawn off-screen by `ViewSet`"
            + (", the views left out" if a.no_draw else "") + "), above the baseline of a "
            "process that has already served a small request; beside it `qmesh.mesh` alone in its "
            "own process, what `qmesh.mesher.budget` counts. Peaks are /proc/self/status VmHWM. "
            "MB are 10^6 bytes; B/v = (peak − baseline) / N; held B/v is what the finished request still holds (its history, its scenes) over N; VM B/v the address space's peak (VmPeak) above the baseline's VmSize over N, what an address-space limit (RLIMIT_AS) counts. The figures behind "
            "`qmesh_view.memory.BYTES_PER_VERTEX` (and VIRTUAL_BYTES_PER_VERTEX).",
            tables=[report_page.Table(["case", "target", "N", "steps", "base MB", "peak MB",
                                       "view B/v", "held B/v", "mesh B/v", "VM B/v"], rows)])


if __name__ == "__main__":
    main()
