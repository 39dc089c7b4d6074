"""Debian's Chromium driven by Playwright, for the viewer's and the widget's browser tests.

HEADLESS.md: never `playwright install`; the browser is /usr/bin/chromium, started with the
flags that work as root with no network, and a fresh browser context for each page. Every
wait is bounded.
"""

from __future__ import annotations

import atexit
import contextlib
import io
import os
import signal
import socket
import subprocess
import time

import numpy as np
from PIL import Image
from playwright.sync_api import sync_playwright

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                  "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync"]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def until(predicate, timeout: float, what: str, interval: float = 0.25):
    """Poll `predicate` until it returns something other than None/False, or raise TimeoutError."""
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value is not None and value is not False:
            return value
        if time.monotonic() > deadline:
            raise TimeoutError(f"waited {timeout} s for {what}")
        time.sleep(interval)


_shared: dict = {}


def shared_browser():
    """One headless Chromium per process, launched on first use and kept for the next page.

    Launching is cheap, but a browser's first page costs ~4 s of CPU (renderer start-up, the
    app's scripts compiled) and a later page ~1 s: on two cores the browser tests are CPU-bound,
    so they share the process and each gets its own fresh context (no cookies, storage or
    cache from an earlier page). `close_shared_browser` ends it (the tests' session end, or exit)."""
    if "browser" not in _shared:
        if not os.path.exists(CHROMIUM):
            raise RuntimeError(f"{CHROMIUM} is missing: apt-get install chromium")
        playwright = sync_playwright().start()
        _shared["playwright"] = playwright
        _shared["browser"] = playwright.chromium.launch(
            executable_path=CHROMIUM, headless=True, args=CHROMIUM_FLAGS)
        atexit.register(close_shared_browser)
    return _shared["browser"]


def close_shared_browser() -> None:
    """Close the shared Chromium and Playwright's driver, if they were started."""
    browser, playwright = _shared.pop("browser", None), _shared.pop("playwright", None)
    if browser is not None:
        browser.close()
    if playwright is not None:
        playwright.stop()


@contextlib.contextmanager
def chromium_page(url: str, viewport=(1280, 720), before=None):
    """A Playwright page in headless Debian Chromium, in a fresh browser context, opened at `url`
    (after `before(page)`, when given: listeners that must hear the whole load).

    The default 1280×720, a laptop's screen, renders the views' pixels in software about 10%
    faster than 1600×900 (the baselines and bench_view.py ask for 1600×900)."""
    ctx = shared_browser().new_context(viewport={"width": viewport[0], "height": viewport[1]})
    try:
        page = ctx.new_page()
        page.set_default_timeout(30_000)
        if before is not None:
            before(page)
        page.goto(url)
        yield page
    finally:
        ctx.close()


def screenshot(locator) -> np.ndarray:
    """What the browser shows in `locator` right now, as RGB (h, w, 3)."""
    return np.asarray(Image.open(io.BytesIO(locator.screenshot())).convert("RGB"))


def colour_count(image: np.ndarray) -> int:
    """How many distinct RGB colours `image` holds. Each colour packed into one integer: the
    waits poll this on every view several times a second, and np.unique over rows (axis=0)
    takes ~0.2 s for one view where a sort of packed integers takes ~5 ms."""
    rgb = np.asarray(image)[..., :3].reshape(-1, 3).astype(np.uint32)
    return len(np.unique(rgb[:, 0] << 16 | rgb[:, 1] << 8 | rgb[:, 2]))


def drawn(image: np.ndarray, background=(255, 255, 255), min_colours: int = 8,
          min_fraction: float = 0.02) -> bool:
    """True when an image shows something: enough distinct colours and non-background pixels.

    A blank view has one or two colours; a view that lost its GL context is mostly black.
    """
    rgb = np.asarray(image)[..., :3].reshape(-1, 3)
    colours = colour_count(rgb)
    foreground = np.mean(np.any(np.abs(rgb.astype(int) - background) > 8, axis=1))
    dark = np.mean(rgb.max(axis=1) < 24)
    return colours >= min_colours and foreground >= min_fraction and dark < 0.5


def stop_process(proc: subprocess.Popen, interrupts: int = 0, timeout: float = 10.0) -> None:
    """Stop a server this test started (its PID only): SIGINT `interrupts` times, then
    terminate, then kill."""
    if proc.poll() is not None:
        return
    for _ in range(interrupts):
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=timeout)
            return
        except subprocess.TimeoutExpired:
            continue
    proc.terminate()
    try:
        proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(timeout=timeout)
