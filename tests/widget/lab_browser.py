"""Start JupyterLab on a copy of a notebook and drive it with Debian's Chromium (HEADLESS.md).

`jupyter_lab(folder)` runs `python -m jupyterlab` on 127.0.0.1, a free port and a random token,
with no browser, its own settings and workspace folders and no network look-ups, and always
stops it (its PID only). `lab_page(url)` opens a Playwright page in /usr/bin/chromium with a
fresh profile. Every wait is bounded. Never `playwright install`.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import shutil
import subprocess
import sys
import tempfile
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
from headless_browser import chromium_page, drawn, free_port, screenshot, stop_process, until  # noqa: F401

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"

LAB_SETTINGS = {
    # open the notebook with its kernel, no "Select Kernel" dialog
    ("@jupyterlab/notebook-extension", "tracker"): {"autoStartDefaultKernel": True},
    # no news toast (and no request for it)
    ("@jupyterlab/apputils-extension", "notification"): {"fetchNews": "false"},
    # Lab 4.6's default, spelled out: widget messages arrive on a kernel subshell thread,
    # the case that turned views black (HEADLESS.md)
    ("@jupyterlab/apputils-extension", "kernels-settings"): {"commsOverSubshells": "perCommTarget"},
}


def _api_ok(url: str) -> bool:
    try:
        with urllib.request.urlopen(url, timeout=2) as r:
            json.load(r)
            return True
    except (urllib.error.URLError, ConnectionError, OSError, ValueError):
        return False


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
            stop_process(proc, interrupts=2, timeout=5)  # SIGINT twice: Jupyter's clean shutdown
            shutil.rmtree(state, ignore_errors=True)


lab_page = chromium_page


def mean_diff(a: np.ndarray, b: np.ndarray) -> float:
    if a.shape != b.shape:
        return float("inf")
    return float(np.abs(a.astype(int) - b.astype(int)).mean())
