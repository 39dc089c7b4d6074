"""Timings of the viewer's two interactive paths (issue 4 targets), printed, never asserted.

1. One stage of Algorithm 2.1 plus the re-render of all three views at ~1e4 vertices (≤ 0.3 s).
2. A Q slider change at VB = 64: the run restarted with the new Q and redrawn (≤ 1 s); also the
   whole re-mesh to convergence with the new Q and its redraw.

    python benchmarks/bench_view.py [--vertices 10000] [--window 520 480] [--repeat 6]

Off-screen rendering (Mesa llvmpipe here); the status line's κ2 is timed separately because the
app computes it in its worker thread after the views are already updated.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

from qmesh_view.controller import Controller  # noqa: E402
from qmesh_view.draw import ViewSet  # noqa: E402


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return time.perf_counter() - t, out


def redraw(views: ViewSet, c: Controller) -> None:
    """Scene functions, then render and read back all three views (what a remote view sends)."""
    views.draw(c.current, c.anisotropy, domain=c.domain)
    views.images()


def stage_at_size(n: int, window, repeat: int) -> None:
    vb = 512
    c = Controller(vb=vb, target_vertices=n)
    while c.current.mesh.n_vertices < 0.5 * n and c.step():
        pass
    views = ViewSet(window)
    redraw(views, c)                                   # first render: context set-up, not timed
    rows = []
    for _ in range(4 * repeat):
        if len(rows) == repeat:
            break
        t_step, moved = timed(c.step)
        if not moved:
            break
        t_draw, _ = timed(lambda: views.draw(c.current, c.anisotropy, domain=c.domain))
        t_render, _ = timed(views.images)
        t_status, _ = timed(c.status)
        if c.current.mesh.n_vertices < 0.8 * n:
            continue                                   # only stages at ~n vertices count
        rows.append((c.current.stage, c.current.mesh.n_vertices, t_step, t_draw, t_render,
                     t_status))
    views.close()
    print(f"1. one stage + re-render of the three views, VB = {vb}, target {n}, "
          f"window {window[0]}x{window[1]} per view")
    print(f"   {'stage':<12}{'N':>7}{'stage s':>10}{'scene s':>10}{'render s':>10}"
          f"{'total s':>10}{'status(κ2) s':>14}")
    for stage, nv, a, b, r, s in rows:
        print(f"   {stage:<12}{nv:>7}{a:>10.3f}{b:>10.3f}{r:>10.3f}{a + b + r:>10.3f}{s:>14.3f}")
    totals = [a + b + r for _, _, a, b, r, _ in rows]
    print(f"   median total {statistics.median(totals):.3f} s, max {max(totals):.3f} s "
          f"(target ≤ 0.3 s)")


def q_change(window, repeat: int) -> None:
    c = Controller()
    views = ViewSet(window)
    redraw(views, c)
    restart, full = [], []
    for i in range(repeat):
        k2 = 9.0 + 0.25 * i                      # a slider move: a new Q each time
        t_restart, _ = timed(lambda: (c.set_params(k2=k2), redraw(views, c)))
        restart.append(t_restart)
        t_full, _ = timed(lambda: (c.set_params(k2=k2 + 0.1), c.run(), redraw(views, c)))
        full.append((t_full, len(c.history), c.current.mesh.n_vertices))
    views.close()
    print(f"2. Q slider change at VB = 64 (target 212), window {window[0]}x{window[1]} per view")
    print(f"   restart with the new Q + redraw (what the app does): median "
          f"{statistics.median(restart):.3f} s, max {max(restart):.3f} s (target ≤ 1 s)")
    ts = [t for t, _, _ in full]
    print(f"   re-mesh to convergence + redraw: median {statistics.median(ts):.3f} s, "
          f"max {max(ts):.3f} s ({full[0][1]} stages, N = {full[0][2]})")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--vertices", type=int, default=10_000)
    p.add_argument("--window", type=int, nargs=2, default=(520, 480))
    p.add_argument("--repeat", type=int, default=6)
    a = p.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    stage_at_size(a.vertices, tuple(a.window), a.repeat)
    q_change(tuple(a.window), a.repeat)
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
