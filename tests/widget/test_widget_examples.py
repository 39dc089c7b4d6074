"""The scripts in examples/ run and give their numbers (each also asserts its own)."""

import json
import os
import runpy
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import qmesh.io

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_api_example_meshes_writes_and_has_only_nonnegative_q(tmp_path, monkeypatch):
    out = tmp_path / "disk64.vtu"
    monkeypatch.setattr(sys, "argv", [str(EXAMPLES / "api_example.py"), str(out)])
    ns = runpy.run_path(str(EXAMPLES / "api_example.py"), run_name="__main__")
    mesh, report = ns["mesh"], ns["report"]
    assert report["q_nonnegative_fraction"] == 1.0
    assert abs(mesh.n_vertices - 212) <= 21
    assert report["kappa2"] < report["kappa2_laplacian"]   # Q-adapted: far better conditioned
    back = qmesh.io.read(out)
    np.testing.assert_allclose(back.points, mesh.points)


def test_varying_s_example_is_adapted_to_its_s():
    ns = runpy.run_path(str(EXAMPLES / "varying_s_example.py"), run_name="__main__")
    s, grad, hessian = ns["s"], ns["grad"], ns["hessian"]
    # the example's derivatives are those of its s (central differences)
    P = np.array([[0.3, -0.2], [-0.7, 0.5]])
    e = 1e-5
    for k in range(2):
        d = np.zeros(2)
        d[k] = e
        np.testing.assert_allclose((s(P + d) - s(P - d)) / (2 * e), grad(P)[:, k], rtol=1e-7)
        np.testing.assert_allclose((grad(P + d) - grad(P - d)) / (2 * e), hessian(P)[:, :, k],
                                   rtol=1e-6, atol=1e-9)
    Q = ns["anisotropy"].Q(np.array([[-0.9, 0.0], [0.9, 0.0]]))
    assert Q[1][1, 1] / Q[0][1, 1] == pytest.approx(np.exp(1.8))   # Q varies across the disk
    adapted, isotropic = ns["adapted"], ns["isotropic"]
    assert adapted["n_vertices"] == pytest.approx(300, rel=0.1)
    assert adapted["min_quality"] > max(0.5, isotropic["min_quality"])


def test_cli_example_writes_and_measures_its_files(tmp_path):
    run = subprocess.run(["sh", str(EXAMPLES / "cli_example.sh"), str(tmp_path)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    report = json.loads((tmp_path / "disk64.json").read_text())
    assert report["q_nonnegative_fraction"] == 1.0
    assert abs(report["n_vertices"] - 212) <= 21
    assert qmesh.io.read(tmp_path / "disk64.vtu").n_vertices == report["n_vertices"]
    rotated = json.loads((tmp_path / "rotated.json").read_text())
    mesh = qmesh.io.read(tmp_path / "rotated.msh")
    assert mesh.n_vertices == rotated["n_vertices"]
    assert abs(rotated["n_vertices"] - 150) <= 15
    assert "q_nonnegative_fraction" in run.stdout


SMALL = {"heterogeneous_fem.py": ["300"], "holed_domain_fem.py": ["300"], "fem_ngsolve.py": ["300"],
         "fem_dolfinx.py": ["300"], "ngsolve_solve.py": ["300"], "dolfinx_solve.py": ["300"],
         "cli_example.sh": ["out"]}
"""Arguments that keep each script's run short (its own checks still run)."""
NEEDS = {"fem_dolfinx.py": "dolfinx", "fem_ngsolve.py": "ngsolve", "modflow6_solve.py": "flopy",
         "dolfinx_solve.py": "dolfinx", "ngsolve_solve.py": "ngsolve"}
"""The optional FEM package a script solves with."""
WRITES = {"cli_example.sh": {"out"}, "modflow6_solve.py": {"modflow6_solve"}}
"""What a script writes into the folder it runs in, as its docstring says."""


@pytest.mark.parametrize("script", sorted(p.name for p in EXAMPLES.iterdir() if p.suffix in (".py", ".sh")))
def test_every_example_runs_from_any_working_directory(script, tmp_path):
    """Each script runs from a folder that is not the repository's (finding its own modules
    beside it, writing only where it is told), and exits 0."""
    if script in NEEDS:
        pytest.importorskip(NEEDS[script])
    if script == "modflow6_solve.py" and shutil.which("mf6") is None:
        pytest.skip("mf6 not on PATH")
    run = [sys.executable] if script.endswith(".py") else ["sh"]
    env = {**os.environ, "PATH": os.pathsep.join([str(Path(sys.executable).parent), os.environ["PATH"]])}
    done = subprocess.run([*run, str(EXAMPLES / script), *SMALL.get(script, [])], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert {p.name for p in tmp_path.iterdir()} <= WRITES.get(script, set())   # nothing else left
