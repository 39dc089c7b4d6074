"""Timings of the viewer's interactive paths, printed, never asserted.

1. Server side: one stage of Algorithm 2.1 plus the re-render of all three views at ~1e4 vertices.
2. Server side: a Q slider change at VB = 64, the run restarted with the new Q and redrawn; also
   the whole re-mesh to convergence with the new Q and its redraw.
3. In the browser (targets 0.25 s at N = 212, 0.5 s at N = 1e5): `qmesh-view --server` driven
   by Debian's Chromium through Playwright; from the click on Step (or the key press on the k1
   slider) to the first changed picture of each view, for remote (server-rendered images, the
   default) or local (vtk.js in the browser) views. Measured in the page by
   `tests/view/view_browser.LATENCY_PROBE`, without a screen recorder.
4. In the browser (target 5 s at N = 1e5): from the click on Run (from the first triangulation)
   to the converged picture and status line, and to the κ2 of that stage.
5. With --presets, in the browser (target: 1.5× the disk's): Run on each preset from its first
   triangulation to the converged picture and status line, clicked 0.5 s after the page is idle
   (up to 5 000 vertices the app meshes the run's stages ahead meanwhile) and at once; 5a. the CPU seconds of the worker's
   part of that Run outside the browser (what the machine's load does not change).

    python benchmarks/bench_view.py [--vertices 10000] [--window 520 480] [--repeat 6]
                                    [--sizes 212 100000] [--modes remote] [--no-page]
    python benchmarks/bench_view.py --browser [--modes remote local] [--sizes 212 1000 100000]
    python benchmarks/bench_view.py --no-browser
    python benchmarks/bench_view.py --browser --sizes --presets --no-page    (5. and 5a. alone)

The page is docs/benchmarks/bench_view.md (all four; 1. and 2. only with --no-browser), or
bench_view-browser.md (3. and 4., with --browser).

Off-screen rendering (Mesa llvmpipe here, SwiftShader WebGL in Chromium); the status line's κ2 is
timed separately because the app computes it in its worker thread after the views are updated.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

from qmesh_view.controller import Controller  # noqa: E402
from qmesh_view.session import Session  # noqa: E402
from qmesh_view.draw import ViewSet  # noqa: E402

import report_page  # noqa: E402


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return time.perf_counter() - t, out


def redraw(views: ViewSet, c) -> None:
    """Scene functions, then render and read back all three views (what a remote view sends)."""
    views.draw(c.current, c.anisotropy, domain=c.domain)
    views.images()


def stage_at_size(n: int, window, repeat: int) -> report_page.Table:
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
    return report_page.Table(
        ["stage", "N", "stage s", "scene s", "render s", "total s", "status (κ2) s"],
        [[stage, nv, f"{a:.3f}", f"{b:.3f}", f"{r:.3f}", f"{a + b + r:.3f}", f"{s:.3f}"]
         for stage, nv, a, b, r, s in rows],
        f"1. One stage + re-render of the three views, VB = {vb}, target {n}, window "
        f"{window[0]}x{window[1]} per view")


def q_change(window, repeat: int) -> report_page.Table:
    c = Session()
    views = ViewSet(window)
    redraw(views, c)
    restart, full = [], []
    for i in range(repeat):
        k2 = 9.0 + 0.25 * i                      # a slider move: a new Q each time
        t_restart, _ = timed(lambda: (c.change("k2", k2), redraw(views, c)))
        restart.append(t_restart)
        t_full, _ = timed(lambda: (c.change("k2", k2 + 0.1), c.controller.finish(),
                                   redraw(views, c)))
        full.append((t_full, len(c.history), c.current.mesh.n_vertices))
    views.close()
    print(f"2. Q slider change at VB = 64 (target 212), window {window[0]}x{window[1]} per view")
    print(f"   restart with the new Q + redraw (what the app does): median "
          f"{statistics.median(restart):.3f} s, max {max(restart):.3f} s (target ≤ 1 s)")
    ts = [t for t, _, _ in full]
    print(f"   re-mesh to convergence + redraw: median {statistics.median(ts):.3f} s, "
          f"max {max(ts):.3f} s ({full[0][1]} stages, N = {full[0][2]})")
    return report_page.Table(
        ["after a Q slider change", "median s", "max s", "runs"],
        [["restart with the new Q + redraw (what the app does)", f"{statistics.median(restart):.3f}",
          f"{max(restart):.3f}", len(restart)],
         [f"re-mesh to convergence + redraw ({full[0][1]} stages, N = {full[0][2]})",
          f"{statistics.median(ts):.3f}", f"{max(ts):.3f}", len(ts)]],
        f"2. Q slider change at VB = 64 (target 212), window {window[0]}x{window[1]} per view")


VB_FOR = {212: 64, 1000: 128, 10_000: 512, 100_000: 512}
STEP_TARGET = {212: 0.25, 1000: 0.25, 10_000: 0.6, 100_000: 0.5}   # seconds, Step → picture
RUN_TARGET = {100_000: 5.0}                                        # seconds, Run → converged


def browser_latency(mode: str, n: int, repeat: int) -> list:
    """Step clicks, k1 key presses and one Run in Chromium; rows (action, N shown, seconds)."""
    tests = Path(__file__).resolve().parents[1] / "tests"
    sys.path[:0] = [str(tests), str(tests / "view")]
    import view_browser as b
    vb = VB_FOR.get(n, max(8, min(512, n // 20)))
    rows = []
    with b.qmesh_view_server("--views", mode, "--vb", str(vb), "--target-vertices", str(n)) as url, \
            b.chromium_page(url, (1600, 900)) as page:
        t0 = time.monotonic()
        b.wait_drawn(page, timeout=300)
        b.wait_idle(page, timeout=300)
        print(f"   {mode} N = {n}: first picture and measurements after "
              f"{time.monotonic() - t0:.1f} s", flush=True)
        page.evaluate(b.LATENCY_PROBE)
        page.wait_for_timeout(500)
        step = page.get_by_role("button", name="Step", exact=True)
        for _ in range(repeat):
            if step.is_disabled():
                break
            lat = b.click_latency(page, step.click)
            rows.append(("Step", b.status(page).split(" · ")[2], lat))
            b.wait_idle(page, timeout=120)
            page.wait_for_timeout(300)
        thumb = page.locator("#slider-k1 .v-slider-thumb")
        for _ in range(max(1, repeat // 2)):
            thumb.focus()
            lat = b.click_latency(page, lambda: page.keyboard.press("ArrowRight"))
            rows.append(("k1 →", b.status(page).split(" · ")[2], lat))
            b.wait_idle(page, timeout=120)
            page.wait_for_timeout(300)
        # a whole run from the first triangulation the last k1 move made
        run = page.get_by_role("button", name="Run", exact=True)
        lat = b.run_latency(page, run.click)
        rows.append(("Run", b.status(page).split(" · ")[2], lat))
    return rows


def browser(modes, sizes, repeat: int) -> list:
    print("3. in Chromium: from the input event to the first changed picture, seconds "
          "(all: the slowest view that changed; n/c: the view's picture did not change)")
    print(f"   {'views':<8}{'target':>7}  {'action':<7}{'N shown':>10}{'lifted':>8}{'mesh':>8}"
          f"{'quality':>9}{'all':>7}")
    table, runs = [], []
    for n in sizes:
        for mode in modes:
            worst = {}
            for action, shown, lat in browser_latency(mode, n, repeat):
                def f(x):
                    return "  n/c" if x is None else f"{x:.3f}"
                if action == "Run":
                    print(f"   {mode:<8}{n:>7}  Run to convergence ({shown}): converged picture "
                          f"and status after {f(lat['converged'])} s, κ2 shown after "
                          f"{f(lat['measured'])} s", flush=True)
                    runs.append([mode, n, shown, f(lat["converged"]).strip(),
                                 f(lat["measured"]).strip(), RUN_TARGET.get(n, "")])
                    continue
                # a view whose picture is identical after the click (n/c: e.g. an insert stage
                # that added nothing leaves the lifted view as it was) has nothing to wait for
                vals = [v for v in lat.values() if v is not None]
                slowest = max(vals) if vals else None
                worst.setdefault(action, []).append(slowest)
                print(f"   {mode:<8}{n:>7}  {action:<7}{shown:>10}{f(lat['lifted']):>8}"
                      f"{f(lat['mesh']):>8}{f(lat['quality']):>9}{f(slowest):>7}", flush=True)
            for action, xs in worst.items():
                ok = [x for x in xs if x is not None]
                med = f"{statistics.median(ok):.3f}" if ok else "-"
                target = STEP_TARGET.get(n, 0.25 if n <= 1000 else 0.6)
                print(f"   {mode:<8}{n:>7}  {action:<7} median of the slowest view {med} s, max "
                      f"{max(ok) if ok else float('nan'):.3f} s over {len(ok)} inputs "
                      f"(target {target} s; no view changed: {len(xs) - len(ok)})")
                table.append([mode, n, action, med, f"{max(ok) if ok else float('nan'):.3f}",
                              len(ok), len(xs) - len(ok), target])
    return [report_page.Table(
        ["views", "target N", "action", "median s (slowest view)", "max s", "inputs",
         "inputs with no view changed", "target s"], table,
        "3. In Chromium: from the input event to the first changed picture"),
        report_page.Table(
        ["views", "target N", "N at the end", "converged picture and status s",
         "κ2 shown s", "target s"], runs,
        "4. In Chromium: from the click on Run (after the k1 moves: from the first "
        "triangulation) to the converged picture and status line, and to its κ2")]


PRESETS = ("disk", "rotating", "raster", "layered", "inclusion")
PRESET_RUN_RATIO = 1.5
"""A preset's Run may take at most this multiple of the default case's (the disk at 212)."""
LOOK = 500
"""Milliseconds from the idle page to the click on Run (a look at the first picture)."""


def preset_cpu() -> report_page.Table:
    """CPU seconds of each preset's Run outside the browser, in the worker's parts: its stages
    up to the last, the last (a field's certification, a medium's stitched mesh), and a field's
    element means of every stage before the last (a Run computes them only for the stages it
    draws or measures)."""
    print("5a. CPU seconds of a Run on each preset outside the browser, by part")
    rows = []
    for name in PRESETS:
        c = Controller(domain=name)
        seconds = []
        while True:
            t = time.process_time()
            if not c.step():
                break
            seconds.append(time.process_time() - t)
        t = time.process_time()
        for i in range(len(c.history) - 1):
            c.scrub(i)
            c.warm()
        means = time.process_time() - t if c.is_field else None
        row = [name, len(seconds), f"{sum(seconds[:-1]):.3f}", f"{seconds[-1]:.3f}",
               "" if means is None else f"{means:.3f}"]
        print(f"   {name:<10} {row[1]:>3} stages: up to the last {row[2]} s, the last {row[3]} s"
              + ("" if means is None else f", means of the stages before it {row[4]} s"))
        rows.append(row)
    return report_page.Table(["preset", "stages", "stages before the last s", "last stage s",
                              "a field's means of those stages s"], rows,
                             "5a. CPU seconds of a Run on each preset outside the browser "
                             "(the last stage: a field's certification, a medium's stitching)")


def preset_runs(repeat: int) -> report_page.Table:
    """Run on each preset from its first triangulation, at the preset's own target, in Chromium:
    seconds to the converged picture and status line, and the ratio to the default case's;
    clicked half a second after the page is idle and at once. The server starts on the preset
    and meshes a small run's stages ahead while the page loads, so both measure what a user who
    opens the preset gets; the worker's CPU seconds from scratch are 5a's."""
    tests = Path(__file__).resolve().parents[1] / "tests"
    sys.path[:0] = [str(tests), str(tests / "view")]
    import view_browser as b
    print("5. in Chromium: Run on each preset, from its first triangulation to the converged "
          "picture and status line, seconds")
    seconds = {}
    for name in PRESETS:
        runs = {LOOK: [], 0: []}
        for _ in range(max(1, repeat // 3)):
            for wait in runs:
                with b.qmesh_view_server("--views", "remote", "--domain", name) as url, \
                        b.chromium_page(url, (1600, 900)) as page:
                    b.wait_drawn(page, timeout=300)
                    b.wait_idle(page, timeout=300)
                    page.evaluate(b.LATENCY_PROBE)
                    page.wait_for_timeout(wait)
                    lat = b.run_latency(page,
                                        page.get_by_role("button", name="Run", exact=True).click)
                    shown = b.status(page).split(" · ")[2]
                runs[wait].append(lat["converged"])
                print(f"   {name:<10} Run ({shown}) clicked {wait / 1000:g} s after idle: "
                      f"converged picture and status after {lat['converged']:.3f} s", flush=True)
        seconds[name] = ({w: statistics.median(r) for w, r in runs.items()}, shown,
                         len(runs[LOOK]))
    base = seconds["disk"][0]
    rows = [[name, shown, f"{t[LOOK]:.3f}", f"{t[LOOK] / base[LOOK]:.2f}", f"{t[0]:.3f}",
             f"{t[0] / base[0]:.2f}", n, "" if name == "disk" else PRESET_RUN_RATIO]
            for name, (t, shown, n) in seconds.items()]
    for row in rows:
        print(f"   {row[0]:<10} median {row[2]} s, {row[3]}× the default case's "
              f"(clicked at once: {row[4]} s, {row[5]}×)")
    return report_page.Table(["preset", "N at the end", f"median s, clicked {LOOK / 1000:g} s "
                              "after idle", "× the disk's", "median s, clicked at once",
                              "× the disk's", "runs", "target ×"], rows,
                             "5. In Chromium: Run on each preset at its own target, from its "
                             "first triangulation to the converged picture and status line")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--vertices", type=int, default=10_000)
    p.add_argument("--window", type=int, nargs=2, default=(520, 480))
    p.add_argument("--repeat", type=int, default=6)
    part = p.add_mutually_exclusive_group()
    part.add_argument("--browser", action="store_true", help="only the in-browser latencies (3., 4.)")
    part.add_argument("--no-browser", action="store_true", help="only the server side (1., 2.)")
    p.add_argument("--modes", nargs="+", default=["remote"], choices=["remote", "local"])
    p.add_argument("--sizes", nargs="*", type=int, default=[212, 100_000])
    p.add_argument("--presets", action="store_true",
                   help="also Run on each preset in Chromium (5.), and its CPU seconds by part (5a.)")
    report_page.add_option(p)
    a = p.parse_args()
    with report_page.capture() as printed:
        print(f"load average before: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
        tables = []
        if not a.browser:
            tables += [stage_at_size(a.vertices, tuple(a.window), a.repeat),
                       q_change(tuple(a.window), a.repeat)]
        if not a.no_browser:
            tables += browser(a.modes, a.sizes, a.repeat)
        if a.presets:
            tables += [preset_cpu(), preset_runs(a.repeat)]
        print(f"load average after: {os.getloadavg()[0]:.2f}")
    if a.no_page:
        return
    browser_text = (
        "In Chromium (`qmesh-view --server` driven by Debian's Chromium through Playwright, "
        "SwiftShader WebGL): (3) from the click on Step (or the key press on the k1 slider) "
        "to the first changed picture of each view, for remote (server-rendered images) or "
        "local (vtk.js in the browser) views (targets: 0.25 s at N = 212, 0.5 s at N = 1e5); "
        "(4) from the click on Run to the converged picture and status line (target 5 s at "
        "N = 1e5), and to its κ2; measured in the page by "
        "`tests/view/view_browser.LATENCY_PROBE`. The machine's other processes share the "
        "cores (the load average is printed): repeat and compare medians.")
    server_text = (
        "Timed on the server: (1) one stage of Algorithm 2.1 plus the scene functions and the "
        "render and read-back of all three views, at stages near the target N (target ≤ 0.3 s); "
        "the status line's κ2 is timed separately because the app computes it in its worker "
        "thread after the views are updated; (2) a Q slider change at VB = 64: the run "
        "restarted with the new Q and redrawn (target ≤ 1 s), and the whole re-mesh to "
        "convergence with its redraw. Off-screen rendering (Mesa llvmpipe).")
    if a.browser:
        report_page.write_page(__file__, sys.argv, "Viewer latency in the browser", browser_text,
                               tables=tables, output=printed(), suffix="browser")
    else:
        report_page.write_page(
            __file__, sys.argv, "Viewer timings", server_text + (
                "" if a.no_browser else " " + browser_text),
            tables=tables, output=printed())


if __name__ == "__main__":
    main()
