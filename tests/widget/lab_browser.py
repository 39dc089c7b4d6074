"""Start JupyterLab on a copy of a notebook and drive it with Debian's Chromium (HEADLESS.md).

`jupyter_lab(folder)` runs `python -m jupyterlab` on 127.0.0.1, a free port and a random token,
with no browser, its own settings and workspace folders and no network look-ups, and always
stops it (its PID only). `lab_page(url)` opens a Playwright page in /usr/bin/chromium with a
fresh profile. Every wait is bounded. Never `playwright install`.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
from PIL import Image
from playwright.sync_api import sync_playwright

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
CHROMIUM = "/usr/bin/chromium"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                  "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync"]

LAB_SETTINGS = {
    # open the notebook with its kernel, no "Select Kernel" dialog
    ("@jupyterlab/notebook-extension", "tracker"): {"autoStartDefaultKernel": True},
    # no news toast (and no request for it)
    ("@jupyterlab/apputils-extension", "notification"): {"fetchNews": "false"},
    # Lab 4.6's default, spelled out: widget messages arrive on a kernel subshell thread,
    # the case that turned views black (HEADLESS.md)
    ("@jupyterlab/apputils-extension", "kernels-settings"): {"commsOverSubshells": "perCommTarget"},
}


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


def _api_ok(url: str) -> bool:
    try:
        with urllib.request.urlopen(url, timeout=2) as r:
            json.load(r)
            return True
    except (urllib.error.URLError, ConnectionError, OSError, ValueError):
        return False


def _stop(proc: subprocess.Popen) -> None:
    """Stop the server we started (SIGINT twice is Jupyter's clean shutdown), then kill it."""
    if proc.poll() is not None:
        return
    for sig in (signal.SIGINT, signal.SIGINT):
        proc.send_signal(sig)
        try:
            proc.wait(timeout=5)
            return
        except subprocess.TimeoutExpired:
            continue
    proc.terminate()
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(timeout=5)


@contextlib.contextmanager
def jupyter_lab(folder: Path, env: dict, start_timeout: float = 60.0):
    """Run JupyterLab serving `folder`; yield (base URL, token); always stop it.

    Its configuration, settings, workspaces and runtime files live in a new temporary folder
    (no news feed, no update check: the machine has no network). `env` is added to the server's environment (its kernels inherit it). The server's log goes
    to test-artifacts/jupyter-lab-<port>.log.
    """
    port, token = free_port(), secrets.token_hex(16)
    state = Path(tempfile.mkdtemp(prefix="qmesh-lab-state-"))
    ARTIFACTS.mkdir(exist_ok=True)
    log_path = ARTIFACTS / f"jupyter-lab-{port}.log"
    (state / "config").mkdir()
    (state / "config" / "jupyter_lab_config.json").write_text(json.dumps(
        {"LabApp": {"news_url": None,
                    "check_for_updates_class": "jupyterlab.NeverCheckForUpdate"}}))
    for (extension, name), values in LAB_SETTINGS.items():
        path = state / "settings" / extension / f"{name}.jupyterlab-settings"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(values))
    full_env = dict(os.environ, **env,
                    JUPYTER_CONFIG_DIR=str(state / "config"),
                    JUPYTERLAB_SETTINGS_DIR=str(state / "settings"),
                    JUPYTERLAB_WORKSPACES_DIR=str(state / "workspaces"),
                    JUPYTER_RUNTIME_DIR=str(state / "runtime"))
    cmd = [sys.executable, "-m", "jupyterlab", "--no-browser", "--allow-root",
           "--ServerApp.ip=127.0.0.1", f"--ServerApp.port={port}", "--ServerApp.port_retries=0",
           f"--IdentityProvider.token={token}", f"--ServerApp.root_dir={folder}"]
    with open(log_path, "wb") as log:
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=full_env)
        base = f"http://127.0.0.1:{port}"
        try:
            def ready():
                if proc.poll() is not None:
                    raise RuntimeError(f"jupyter lab exited with {proc.returncode}; see {log_path}")
                return _api_ok(f"{base}/api/status?token={token}")
            until(ready, start_timeout, f"jupyter lab to answer on {base}", 0.5)
            yield base, token
        finally:
            _stop(proc)
            shutil.rmtree(state, ignore_errors=True)


@contextlib.contextmanager
def lab_page(url: str, viewport=(1600, 1000)):
    """A Playwright page in headless Debian Chromium with a fresh profile, opened at `url`."""
    if not os.path.exists(CHROMIUM):
        raise RuntimeError(f"{CHROMIUM} is missing: apt-get install chromium")
    profile = tempfile.mkdtemp(prefix="qmesh-widget-chromium-")
    try:
        with sync_playwright() as p:
            ctx = p.chromium.launch_persistent_context(
                profile, executable_path=CHROMIUM, headless=True, args=CHROMIUM_FLAGS,
                viewport={"width": viewport[0], "height": viewport[1]})
            try:
                page = ctx.new_page()
                page.set_default_timeout(30_000)
                page.goto(url)
                yield page
            finally:
                ctx.close()
    finally:
        shutil.rmtree(profile, ignore_errors=True)


def screenshot(locator) -> np.ndarray:
    """What the browser shows in `locator` right now, as RGB (h, w, 3)."""
    return np.asarray(Image.open(io.BytesIO(locator.screenshot())).convert("RGB"))


def drawn(image: np.ndarray, background=(255, 255, 255), min_colours: int = 8,
          min_fraction: float = 0.02) -> bool:
    """True when an image shows something: enough distinct colours and non-background pixels.

    A view that has lost its GL context is black or blank: one or two colours.
    """
    rgb = np.asarray(image)[..., :3].reshape(-1, 3)
    colours = len(np.unique(rgb, axis=0))
    foreground = np.mean(np.any(np.abs(rgb.astype(int) - background) > 8, axis=1))
    dark = np.mean(rgb.max(axis=1) < 24)
    return colours >= min_colours and foreground >= min_fraction and dark < 0.5


def mean_diff(a: np.ndarray, b: np.ndarray) -> float:
    if a.shape != b.shape:
        return float("inf")
    return float(np.abs(a.astype(int) - b.astype(int)).mean())
