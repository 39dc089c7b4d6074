"""Start `qmesh-view --server` and drive Debian's Chromium with Playwright (HEADLESS.md).

Every wait is bounded; the server started here is always stopped, and each page gets a fresh
browser context. Never `playwright install`: the browser is /usr/bin/chromium.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import time
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np

from headless_browser import chromium_page, colour_count, drawn, free_port, screenshot, stop_process, until  # noqa: F401
from view_cases import ARTIFACTS

VIEWS = ("lifted", "mesh", "quality")


def _answers(url: str) -> bool:
    try:
        with urllib.request.urlopen(url, timeout=2):
            return True
    except (urllib.error.URLError, ConnectionError, OSError):
        return False


@contextlib.contextmanager
def qmesh_view_server(*args: str, start_timeout: float = 60.0):
    """Run `qmesh-view --server --port <free> *args` on 127.0.0.1; yield its URL; always stop it."""
    exe = shutil.which("qmesh-view")
    if exe is None:
        raise RuntimeError("the qmesh-view command is not installed (pip install -e '.[view]')")
    port = free_port()
    ARTIFACTS.mkdir(exist_ok=True)
    log = open(ARTIFACTS / f"qmesh-view-server-{port}.log", "wb")
    env = dict(os.environ, PYVISTA_OFF_SCREEN="true",
               VTK_DEFAULT_OPENGL_WINDOW="vtkEGLRenderWindow")
    proc = subprocess.Popen([exe, "--server", "--port", str(port), *args], stdout=log,
                            stderr=subprocess.STDOUT, env=env)
    url = f"http://127.0.0.1:{port}/"
    _servers.append(proc.pid)
    try:
        deadline = time.monotonic() + start_timeout
        while not _answers(url):
            if proc.poll() is not None:
                raise RuntimeError(f"qmesh-view exited with {proc.returncode}; see {log.name}")
            if time.monotonic() > deadline:
                raise TimeoutError(f"qmesh-view did not answer on {url} in {start_timeout} s")
            time.sleep(0.25)
        yield url
    finally:
        stop_process(proc)
        log.close()


_servers: list[int] = []


def last_server_pid() -> int:
    """The process id of the last `qmesh_view_server` started (to read its memory)."""
    return _servers[-1]


def view_image(page, name: str) -> np.ndarray:
    """What the browser shows in view `name` right now, as RGB (h, w, 3)."""
    return screenshot(page.locator(f"#view-{name}"))


def views(page) -> dict:
    return {name: view_image(page, name) for name in VIEWS}


def wait_drawn(page, timeout: float = 60.0) -> dict:
    """Wait until all three views show a drawn scene (not blank, not a splash); return them."""
    page.wait_for_selector("#status-line", timeout=timeout * 1000)

    def all_drawn():
        imgs = views(page)
        return imgs if all(drawn(img) for img in imgs.values()) else None
    return until(all_drawn, timeout, "all three views to be drawn")


def status(page) -> str:
    return page.inner_text("#status-line").strip()


def wait_status_change(page, old: str, timeout: float = 30.0) -> str:
    def changed():
        line = status(page)
        return line if line and line != old else None
    return until(changed, timeout, f"the status line to change from {old!r}")


def settled_status(page, old: str, timeout: float = 30.0) -> str:
    """After an action: wait for the status line to change, then for the work to finish.

    The app shows a stage's quick numbers first and κ2 and the q_ij signs when measured, so the
    line can change twice; this returns the final one.
    """
    wait_status_change(page, old, timeout)
    wait_idle(page, timeout)
    return status(page)


def wait_idle(page, timeout: float = 30.0) -> None:
    """Wait until the busy bar is hidden and no Run is going (its button reads Run, not Stop):
    no mesher work running. A Run shows no busy bar, and the measures after it do."""
    page.wait_for_function(
        "() => { const b = document.querySelector('#busy');"
        " const r = document.querySelector('#btn-run');"
        " return (!b || getComputedStyle(b).display === 'none')"
        " && (!r || !r.innerText.includes('Stop')); }", timeout=timeout * 1000)


def wait_view_change(page, name: str, old: np.ndarray, timeout: float = 20.0,
                     min_diff: float = 1.0) -> np.ndarray:
    """Wait until view `name` differs from `old` by a mean absolute pixel difference ≥ min_diff."""
    def changed():
        img = view_image(page, name)
        same_shape = img.shape == old.shape
        return img if (not same_shape or mean_diff(img, old) >= min_diff) and drawn(img) else None
    return until(changed, timeout, f"view {name!r} to change")


def mean_diff(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a.astype(int) - b.astype(int)).mean())


def save(page, name: str) -> Path:
    """Save a full-page screenshot under test-artifacts/ and return its path."""
    ARTIFACTS.mkdir(exist_ok=True)
    path = ARTIFACTS / f"{name}.png"
    page.screenshot(path=str(path))
    return path


def page_text(page, selector: str) -> str:
    return page.inner_text(selector).strip()


# ----------------------------------------------------------------------------- latency probe
LATENCY_PROBE = """
(() => {
  const now = () => performance.timeOrigin + performance.now();
  const qv = window.__qv = {input: [], frames: {}};
  const viewOf = el => { const v = el && el.closest && el.closest('[id^="view-"]');
                         return v ? v.id.slice(5) : null; };
  const mark = (name, tag) => {
    if (!name) return;
    const list = qv.frames[name] = qv.frames[name] || [];
    const t = now();
    if (!list.length || t - list[list.length - 1][0] > 2) list.push([t, tag]);
  };
  // local (vtk.js) views: the time WebGL is asked to draw into a view's canvas
  for (const proto of [WebGLRenderingContext.prototype, WebGL2RenderingContext.prototype])
    for (const fn of ['drawArrays', 'drawElements']) {
      const orig = proto[fn];
      proto[fn] = function (...a) { mark(viewOf(this.canvas), 'gl'); return orig.apply(this, a); };
    }
  // remote views: a new image decoded into the view's <img>, with a checksum of its pixels
  const probe = document.createElement('canvas');
  probe.width = probe.height = 64;
  const ctx = probe.getContext('2d', {willReadFrequently: true});
  document.addEventListener('load', e => {
    if (e.target.tagName !== 'IMG') return;
    ctx.drawImage(e.target, 0, 0, 64, 64);
    const px = ctx.getImageData(0, 0, 64, 64).data;
    let h = 0;
    for (let i = 0; i < px.length; i += 1) h = (h * 31 + px[i]) >>> 0;
    mark(viewOf(e.target), h);
  }, true);
  for (const type of ['click', 'keydown'])
    document.addEventListener(type, e => qv.input.push(performance.timeOrigin + e.timeStamp), true);
  // the status line: every text it shows, with the time it changed
  qv.status = [];
  const line = document.querySelector('#status-line');
  const note = () => { const text = line.textContent.trim();
                       const last = qv.status[qv.status.length - 1];
                       if (!last || last[1] !== text) qv.status.push([now(), text]); };
  if (line) { note(); new MutationObserver(note).observe(line, {childList: true, subtree: true,
                                                                 characterData: true}); }
})();
"""
"""A script (evaluated once the page is drawn) that timestamps, in the page, every input event,
every new picture of a view (a WebGL draw into its canvas for local views, a new image in its
<img> with a pixel checksum for remote views) and every text the status line shows. No screen
recorder: it would cost the CPU it measures."""


def probe_marks(page) -> dict:
    """{"input": [epoch ms…], "frames": {view: [[epoch ms, "gl" | checksum], …]},
    "status": [[epoch ms, text], …]} so far."""
    return page.evaluate("() => window.__qv")


def run_latency(page, action, timeout: float = 300.0, names=VIEWS) -> dict:
    """Seconds from the input event of `action()` (a click on Run) to the end of the run:
    "converged" when the status line first says so and every view shows its last picture
    (the later of the two), and "measured" when that line also shows κ2 (measured after the
    views, in the app's worker). Waits until the app is idle again; None for what never came."""
    n_input = len(probe_marks(page)["input"])
    action()
    until(lambda: "converged" in status(page) or None, timeout, "the run to converge")
    page.wait_for_function("() => !document.querySelector('#btn-run').textContent"
                           ".includes('Stop')", timeout=timeout * 1000)   # the run has ended
    wait_idle(page, timeout)                         # and the stage it ended at is measured
    page.wait_for_timeout(500)                       # frames of the last stage still on the way
    marks = probe_marks(page)
    t_in = marks["input"][n_input]
    said = [t for t, text in marks["status"] if t > t_in and "converged" in text]
    measured = [t for t, text in marks["status"]
                if t > t_in and "converged" in text and "κ2 = –" not in text]
    frames = [max((t for t, _ in marks["frames"].get(n, []) if t > t_in), default=None)
              for n in names]
    out = {"converged": None, "measured": None}
    if said and all(f is not None for f in frames):
        out["converged"] = (max(said[0], *frames) - t_in) / 1000
    if measured:
        out["measured"] = (measured[0] - t_in) / 1000
    return out


def click_latency(page, action, names=VIEWS, timeout: float = 10.0) -> dict:
    """Seconds from the input event of `action()` to the first changed picture in each view.

    A remote view's picture counts as changed when its checksum differs from the one shown
    before the input; a local view's on its first WebGL draw after it. Views that did not
    change within `timeout` are None.
    """
    before = probe_marks(page)
    last = {n: (before["frames"].get(n) or [[0, None]])[-1][1] for n in names}
    n_input = len(before["input"])
    action()
    deadline = time.monotonic() + timeout
    out: dict = {}
    while time.monotonic() < deadline:
        marks = probe_marks(page)
        if len(marks["input"]) > n_input:
            t_in = marks["input"][n_input]
            for n in names:
                if n in out:
                    continue
                for t, tag in marks["frames"].get(n, []):
                    if t > t_in and (tag == "gl" or tag != last[n]):
                        out[n] = (t - t_in) / 1000
                        break
            if len(out) == len(names):
                break
        page.wait_for_timeout(50)
    return {n: out.get(n) for n in names}
