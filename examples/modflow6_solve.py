"""The guide's two problems ("From conductivity to solution") solved by MODFLOW 6 on the mesh
scikit-fem solves them on, and the heads compared with scikit-fem's P1 solution.

`qmesh.io.to_modflow6` writes the mesh (a DISU grid, conductances q_ij); CHD holds u on every
boundary cell, WEL puts b_i = ∫ f φ_i into every other cell (MODFLOW's balance
Σ_j C_ij (h_j − h_i) + b_i = 0 is the P1 equation K u = b at a thickness of 1), and mf6 runs.
Writes into ./modflow6_solve/. Run: python examples/modflow6_solve.py [TARGET_VERTICES]
(needs qmesh[fem,modflow] and the mf6 program on PATH).
"""

from __future__ import annotations

import sys
from pathlib import Path

import flopy
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import solve_problems  # noqa: E402

import qmesh  # noqa: E402
import qmesh.io  # noqa: E402


def modflow_heads(mesh: qmesh.Mesh, problem: solve_problems.Problem, load: np.ndarray, folder: Path) -> np.ndarray:
    sim = qmesh.io.to_modflow6(mesh, folder)                  # the mesh's element means
    gwf = sim.get_model("qmesh")
    rim = qmesh.io.modflow_cells(mesh, tags=["bottom", "right", "top", "left"])
    inside = np.setdiff1d(np.arange(mesh.n_vertices), rim)
    u_rim = problem.u(*mesh.points[rim].T)
    flopy.mf6.ModflowGwfchd(gwf, stress_period_data=[[(k,), h] for k, h in zip(rim.tolist(), u_rim.tolist())])
    if np.any(load[inside] != 0):
        flopy.mf6.ModflowGwfwel(gwf, stress_period_data=[[(k,), b] for k, b in zip(inside.tolist(),
                                                                                     load[inside].tolist())])
    sim.write_simulation(silent=True)
    ok, log = sim.run_simulation(silent=True)
    if not ok:
        raise RuntimeError("mf6 failed:\n" + "\n".join(log[-20:]))
    return gwf.output.head().get_data().ravel()


def main(target_vertices: int = 1500) -> list[dict]:
    results = []
    Path("modflow6_solve").mkdir(exist_ok=True)
    for name, problem, mesh in solve_problems.meshed(target_vertices):
        fem = solve_problems.skfem_solve(mesh, problem)
        h = modflow_heads(mesh, problem, fem.load, Path("modflow6_solve") / name)
        result = {"problem": name, "n_vertices": mesh.n_vertices, "positive_off_diagonals": fem.positive,
                  "skfem_l2": solve_problems.l2_error(mesh, problem, fem.u),
                  "modflow_l2": solve_problems.l2_error(mesh, problem, h),
                  "heads_minus_p1": float(np.abs(h - fem.u).max() / np.ptp(fem.u))}
        print(f"{name}: N={result['n_vertices']} L2 error scikit-fem {result['skfem_l2']:.4g} "
              f"MODFLOW 6 {result['modflow_l2']:.4g}; max |h - u_h| / range {result['heads_minus_p1']:.1e}; "
              f"{result['positive_off_diagonals']} positive off-diagonals")
        results.append(result)
    return results


if __name__ == "__main__":
    results = main(*(int(a) for a in sys.argv[1:]))
