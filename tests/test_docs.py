"""The documentation site (docs/: Sphinx, MyST, the API reference from the docstrings, the
benchmark pages) builds with no warning: `python -m sphinx -W --keep-going -b html docs OUT`."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow(10)
def test_the_docs_build_without_warnings(tmp_path):
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                           "-d", str(tmp_path / "doctrees"), str(ROOT / "docs"), str(tmp_path / "html")],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-5000:]
    html = tmp_path / "html"
    for page in ["index", "guide/getting-started", "guide/algorithm", "api/qmesh", "api/measure",
                 "benchmarks/index"]:
        assert (html / f"{page}.html").stat().st_size > 0, page
    api = (html / "api" / "qmesh.html").read_text()
    assert 'id="qmesh.mesh"' in api and 'id="qmesh.iterate"' in api      # from the docstrings
    assert "(2.94)" in (html / "guide" / "algorithm.html").read_text()    # the chapter's numbers
