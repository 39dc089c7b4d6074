"""The public API's type hints hold: mypy, as configured in pyproject.toml's [tool.mypy], reports
no error on the files listed there, and every module that defines a name of `qmesh.__all__` is
listed (`qmesh/py.typed` tells users' type checkers to read these hints)."""

import inspect
import subprocess
import sys
from pathlib import Path

import pytest

import qmesh

try:
    import tomllib
except ModuleNotFoundError:      # Python 3.10
    tomllib = pytest.importorskip("tomli")

ROOT = Path(__file__).resolve().parents[1]

PENDING: dict[str, str] = {}
"""Public modules not type-checked yet (a folder ends with /): each leaves this list when it
joins [tool.mypy] files."""


def mypy_config() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]


def _file_of(obj: object) -> str | None:
    source = inspect.getsourcefile(obj) if inspect.ismodule(obj) or inspect.isclass(obj) \
        or inspect.isfunction(obj) else None
    if source is None or not Path(source).is_relative_to(ROOT):
        return None
    return Path(source).relative_to(ROOT).as_posix()


def public_files() -> set[str]:
    """The source files of everything in qmesh.__all__: the modules it names, the modules their
    own __all__ draws on, and where each class and function is defined."""
    found = {"qmesh/__init__.py"}
    for name in qmesh.__all__:
        obj = getattr(qmesh, name)
        found.add(_file_of(obj))
        if inspect.ismodule(obj):
            found |= {_file_of(getattr(obj, sub)) for sub in getattr(obj, "__all__", ())}
    return found - {None}


def pending(path: str) -> bool:
    return any(path == p or (p.endswith("/") and path.startswith(p)) for p in PENDING)


def test_every_public_module_is_type_checked():
    listed = set(mypy_config()["files"])
    missing = sorted(p for p in public_files() - listed if not pending(p))
    assert not missing, f"add to [tool.mypy] files in pyproject.toml (with type hints): {missing}"
    done = sorted(p for p in PENDING if any(pending(f) and f.startswith(p) for f in listed))
    assert not done, f"{done} are type-checked now: take them out of PENDING"
    assert all((ROOT / f).is_file() for f in listed), "a file in [tool.mypy] files does not exist"


def test_the_typed_marker_ships():
    assert (ROOT / "qmesh" / "py.typed").is_file()
    package_data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    assert "py.typed" in package_data["qmesh"]


def test_mypy_reports_no_errors(tmp_path):
    out = subprocess.run([sys.executable, "-m", "mypy", "--cache-dir", str(tmp_path / "mypy_cache")],
                         cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, f"mypy reports:\n{out.stdout}{out.stderr}"
    assert out.stdout.startswith("Success: no issues found"), out.stdout
