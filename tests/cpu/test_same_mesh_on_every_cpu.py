"""The same mesh on every CPU: NumPy picks SIMD kernels for its transcendental functions, and
OpenBLAS its BLAS/LAPACK kernels, by the CPU it runs on, and their last bits differ between
kernels. The mesher decides only on numbers that do not depend on them (qmesh.geometry.portable),
so the meshes of every kind of input hash the same under each SIMD level NumPy offers on this
machine, under another BLAS kernel, and with every CPU-dependent NumPy result moved by one ulp."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

HERE = Path(__file__).parent
ROOT = HERE.parent.parent


def _hashes(*args: str, **env: str) -> dict:
    environ = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]), **env}
    out = subprocess.run([sys.executable, str(HERE / "meshes.py"), *args], capture_output=True, text=True,
                         env=environ, timeout=240, check=True)
    return json.loads(out.stdout)


@pytest.fixture(scope="module")
def default_hashes():
    return _hashes()


def _levels_above_baseline() -> list[str]:
    return [f for f in __cpu_dispatch__ if __cpu_features__.get(f)]


def test_the_cases_differ_from_each_other(default_hashes):
    assert len(set(default_hashes.values())) == len(default_hashes) == 14


@pytest.mark.parametrize("keep", range(len(_levels_above_baseline())))
def test_same_mesh_at_every_narrower_simd_level(default_hashes, keep):
    """NPY_DISABLE_CPU_FEATURES turns off every dispatch target above the `keep` lowest found:
    keep = 0 runs NumPy's baseline kernels only (an older CPU's)."""
    off = _levels_above_baseline()[keep:]
    assert _hashes(NPY_DISABLE_CPU_FEATURES=" ".join(off)) == default_hashes


@pytest.mark.skipif(not np.__config__.CONFIG["Build Dependencies"]["blas"]["name"].startswith("scipy-openblas"),
                    reason="OPENBLAS_CORETYPE selects kernels of NumPy's bundled OpenBLAS only")
@pytest.mark.parametrize("core", ["Sandybridge", "Haswell"])
def test_same_mesh_with_other_blas_kernels(default_hashes, core):
    """Sandybridge's kernels have no fused multiply-add; Haswell's order some sums otherwise."""
    assert _hashes(OPENBLAS_CORETYPE=core) == default_hashes


def test_same_mesh_when_every_cpu_dependent_result_moves_one_ulp(default_hashes):
    """The harness for any machine: each NumPy function with per-CPU kernels wrapped to return
    its result one unit in the last place higher (meshes.nudge); a mesh that read those bits
    where it decides would change."""
    assert _hashes("--nudge") == default_hashes
