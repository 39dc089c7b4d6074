"""MODFLOW 6 itself runs what `qmesh.io.to_modflow6` writes: with heads 1 on the left side and
0 on the right (CHD) and no flow elsewhere, its heads are qmesh's P1 Dirichlet solution
(`qmesh.compare.solve.dirichlet`) on the same mesh to 1e-6 of the head range, for a constant
Q, a raster field and a layered medium; and the guide's example runs as printed. Needs the
mf6 program on PATH (the guide's "From conductivity to solution" says how to build it)."""

import runpy
import shutil
import sys
from pathlib import Path

import flopy
import numpy as np
import pytest
from modflow_cases import CASES

from qmesh import io
from qmesh.compare import solve

pytestmark = pytest.mark.skipif(shutil.which("mf6") is None, reason="mf6 not on PATH")
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def heads_and_p1(case, folder):
    mesh = case.mesh
    sim = io.to_modflow6(mesh, folder, case.conductivity)
    gwf = sim.get_model("qmesh")
    left, right = io.modflow_cells(mesh, tags="left"), io.modflow_cells(mesh, tags="right")
    flopy.mf6.ModflowGwfchd(gwf, stress_period_data=[[(k,), 1.0] for k in left.tolist()]
                            + [[(k,), 0.0] for k in right.tolist()])
    sim.write_simulation(silent=True)
    ok, log = sim.run_simulation(silent=True)
    assert ok, "\n".join(log[-20:])
    h = gwf.output.head().get_data().ravel()
    u = solve.dirichlet(mesh, case.conductivity, np.concatenate([left, right]),
                        np.concatenate([np.ones(len(left)), np.zeros(len(right))]))
    return h, u


@pytest.mark.parametrize("name", sorted(CASES))
def test_heads_are_the_p1_solution(name, tmp_path):
    h, u = heads_and_p1(CASES[name](), tmp_path / "sim")
    assert np.max(np.abs(h - u)) <= 1e-6 * (u.max() - u.min())
    assert -1e-12 <= u.min() and u.max() <= 1 + 1e-12        # the M-matrix's maximum principle


def test_the_guide_example_runs(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", [str(EXAMPLES / "modflow6_solve.py")])
    ns = runpy.run_path(str(EXAMPLES / "modflow6_solve.py"), run_name="__main__")
    out = capsys.readouterr().out
    for result in ns["results"]:
        assert result["heads_minus_p1"] <= 1e-6 and result["positive_off_diagonals"] == 0
    assert "0 positive off-diagonals" in out
