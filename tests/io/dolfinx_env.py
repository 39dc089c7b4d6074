"""A venv where DOLFINx runs, for the tests that read qmesh's files in DOLFINx.

DOLFINx's PyPI wheels (`dolfinx-solver-real`) need Python >= 3.12. `python()` finds one that
runs: pyenv's installed versions (`$(pyenv root)/versions/3.*/bin/python3`, which need no
PYENV_VERSION), then python3.12/3.13/3.14 on the PATH. `venv()` builds, once, a venv with that
Python holding qmesh's dependencies, its `io` extra and DOLFINx's wheel (the requirements read
from pyproject.toml); qmesh itself is not installed there: the scripts run with the working
tree on PYTHONPATH. The venv lives under the user's cache folder ($QMESH_TEST_CACHE, else
$XDG_CACHE_HOME/qmesh-tests or ~/.cache/qmesh-tests), keyed by a hash of those requirements
and the Python's version, so a fresh clone on the same machine finds it built; a file lock
keeps parallel test workers from building it twice, and a marker written last tells a
finished venv from one whose build was cut short.
"""

from __future__ import annotations

import fcntl
import glob
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - the suite's Python is 3.11+
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[2]
BUILD_TIMEOUT = 1800
_DONE = "qmesh-venv-complete.json"


def _version(python: str) -> tuple[int, ...] | None:
    """(major, minor, micro) of an interpreter that runs and has venv and ensurepip, else None."""
    try:
        out = subprocess.run([python, "-c", "import sys, venv, ensurepip; print(*sys.version_info[:3])"],
                             capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return None
    if out.returncode != 0:
        return None
    try:
        return tuple(int(v) for v in out.stdout.split())
    except ValueError:
        return None


def _pyenv_root() -> Path | None:
    root = os.environ.get("PYENV_ROOT")
    if not root and shutil.which("pyenv"):
        try:
            root = subprocess.run(["pyenv", "root"], capture_output=True, text=True, timeout=30).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            root = None
    root = root or str(Path.home() / ".pyenv")
    return Path(root) if Path(root).is_dir() else None


def python() -> tuple[str | None, str]:
    """(a Python >= 3.12 that runs, how it was found), or (None, what was looked at)."""
    candidates = []
    root = _pyenv_root()
    if root is not None:
        found = glob.glob(str(root / "versions" / "3.*" / "bin" / "python3"))
        candidates += sorted(found, key=lambda p: [int(x) for x in re.findall(r"\d+", Path(p).parts[-3])])
    candidates += [p for p in (shutil.which(f"python3.{m}") for m in (12, 13, 14)) if p]
    for path in candidates:
        version = _version(path)
        if version is not None and version >= (3, 12):
            return path, ".".join(map(str, version))
    where = f"pyenv's versions under {root}" if root else "no pyenv root"
    return None, f"no Python >= 3.12 that runs was found ({where}; python3.12/3.13/3.14 on the PATH)"


def requirements() -> list[str]:
    """qmesh's dependencies, its io extra and DOLFINx's wheel, as pyproject.toml lists them."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    extras = project["optional-dependencies"]
    wanted = list(project["dependencies"]) + list(extras["io"]) + list(extras["fem-dolfinx"])
    return sorted({r for r in wanted if not r.replace(" ", "").startswith("qmesh[")})


def cache_folder() -> Path:
    if os.environ.get("QMESH_TEST_CACHE"):
        return Path(os.environ["QMESH_TEST_CACHE"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "qmesh-tests"


def venv() -> tuple[Path | None, str]:
    """(the venv's python, a note: how long its build took), or (None, why there is none)."""
    base, found = python()
    if base is None:
        return None, found
    reqs = requirements()
    key = hashlib.sha256(json.dumps([found, reqs]).encode()).hexdigest()[:16]
    folder = cache_folder() / f"dolfinx-{key}"
    folder.parent.mkdir(parents=True, exist_ok=True)
    bin_python = folder / "bin" / "python"
    with open(folder.parent / f"dolfinx-{key}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        done = folder / _DONE
        if done.is_file():
            return bin_python, json.loads(done.read_text())["note"]
        shutil.rmtree(folder, ignore_errors=True)
        start = time.monotonic()
        try:
            subprocess.run([base, "-m", "venv", str(folder)], check=True, capture_output=True, timeout=300)
            out = subprocess.run([str(bin_python), "-m", "pip", "install", "--disable-pip-version-check", "-q",
                                  *reqs], capture_output=True, text=True, timeout=BUILD_TIMEOUT)
        except (OSError, subprocess.SubprocessError) as e:
            shutil.rmtree(folder, ignore_errors=True)
            return None, f"building a venv with Python {found} failed: {e}"
        if out.returncode != 0:
            shutil.rmtree(folder, ignore_errors=True)
            tail = (out.stderr or out.stdout).strip().splitlines()[-3:]
            return None, f"pip could not install {' '.join(reqs)} with Python {found}: {' / '.join(tail)}"
        check = run(bin_python, ["-c", "import dolfinx_solver, dolfinx; print(dolfinx.__version__)"], timeout=300)
        if check.returncode != 0:
            shutil.rmtree(folder, ignore_errors=True)
            return None, f"DOLFINx installed with Python {found} but does not import: {check.stderr.strip()[-300:]}"
        note = (f"DOLFINx {check.stdout.strip()} with Python {found}, venv built in "
                f"{time.monotonic() - start:.0f} s at {folder}")
        done.write_text(json.dumps({"note": note, "requirements": reqs}))
        return bin_python, note


def run(bin_python: Path, args: list[str], timeout: float = 600) -> subprocess.CompletedProcess:
    """Run the venv's Python with the working tree's qmesh (and tests/io) importable."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(Path(__file__).parent)])}
    env.pop("PYTHONHOME", None)
    env.pop("VIRTUAL_ENV", None)
    return subprocess.run([str(bin_python), *args], capture_output=True, text=True, timeout=timeout, env=env,
                          cwd=str(ROOT))
