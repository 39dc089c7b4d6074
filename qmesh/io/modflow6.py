"""A qmesh `Mesh` as a MODFLOW 6 groundwater-flow model on a DISU grid, written with flopy.

A mesh whose every q_ij ≥ 0 is a two-point-flux grid whose heads are the P1 solution: cell k
is vertex k, one horizontal connection per edge with q_ij > 0, and MODFLOW's conductance
between cells i and j is q_ij × thickness. Nothing is reassembled here: q_ij comes from
`qmesh.measure.edge_q`, the assembly that certified the mesh.

How MODFLOW 6 computes that conductance (src/Model/GroundWaterFlow/gwf-npf.f90,
`calc_condsat` and `hy_eff`; src/Model/ModelUtilities/GwfConductanceUtils.f90, `hcond` →
`condmean`, harmonic mean, the default): for a horizontal connection n–m,

    C = HWVA · T_n T_m / (T_n · CL2 + T_m · CL1),   T = K_eff · (TOP − BOT),

with K_eff = K (NPF's K11: `hy_eff` turns to `hyeff` only when K22 is given) and the
saturation 1 for a confined cell (ICELLTYPE 0). Written here: K = 1 and ICELLTYPE = 0 in every
cell, no K22, K33 or XT3D (they would recompute the conductance from a tensor); HWVA = w_ij,
the width of the edge's median-dual face; CL1 = CL2 = w_ij / (2 q_ij). Then
C = w_ij (TOP − BOT) / (w_ij / q_ij) = q_ij (TOP − BOT).

ANGLDEGX is the direction of the face's normal from n to m (the chord of the dual face turned a
quarter, `qmesh.geometry.median_dual.dual_faces`), so that MODFLOW's specific discharge, which
divides each connection's flow by HWVA × thickness and reads it as the velocity along that
normal, sees a face of the right width and direction.
"""

from __future__ import annotations

import os
import re
import shutil
import uuid
from collections.abc import Iterable
from os import PathLike
from pathlib import Path
from typing import Any, Union

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from qmesh import checks, measure
from qmesh.errors import QmeshError
from qmesh.geometry.median_dual import dual_faces, median_dual
from qmesh.geometry.portable import arctan2
from qmesh.io import boundary
from qmesh.io.adapters import _check, _import
from qmesh.triangle_mesh import Mesh

NEGATIVE_RTOL = 1e-9
"""A q_ij ≥ −NEGATIVE_RTOL · max|q| counts as 0 (no connection), as `qmesh.measure.report`
counts it as non-negative; a smaller one is a negative conductance and is refused."""

_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,15}")


def to_modflow6(mesh: Mesh, workspace: Union[str, PathLike[str]], anisotropy: measure.Given = None, *,
                name: str = "qmesh", exe_name: str = "mf6", top: float = 1.0, bottom: float = 0.0) -> Any:
    """Write `mesh` as a MODFLOW 6 simulation in the folder `workspace` and return it as a
    `flopy.mf6.MFSimulation` (typed Any: flopy is optional, the `modflow` extra).

    One GWF model `name` on a DISU grid: cell k is vertex k, its median-dual cell (below) as
    VERTICES/CELL2D with its area as AREA, TOP = `top`, BOT = `bottom`; one horizontal connection
    per edge with q_ij > 0 whose conductance is q_ij × (top − bottom) (the NPF K / CL12 / HWVA /
    ANGLDEGX convention is in this module's docstring); TDIS one steady period; IMS conjugate
    gradients to 1e-12; NPF; IC; OC
    saving heads to `<name>.hds` and the budget to `<name>.cbc`. Add CHD, WEL, RCH (or STO) with
    flopy, cell id = vertex index (`modflow_cells`), then `sim.write_simulation()` and
    `sim.run_simulation()` (`exe_name` is the mf6 program).

    q_ij comes from `qmesh.measure.edge_q(mesh, anisotropy)`: the mesh's element means when
    `anisotropy` is None (`mesh.conductivity`), else the Anisotropy, {region tag: Anisotropy},
    TensorField or one Q per triangle given; a mesh that carries no means needs it. A q_ij below
    −1e-9 · max|q| (a negative conductance) is refused, naming the edge.

    The cells are the median dual (each triangle cut into three by its medians), not the
    Q-Voronoi dual: a median-dual cell is a polygon about its vertex inside the mesh for any
    mesh and conductivity, its area is the P1 lumped mass Σ_T |T|/3 (so STO and RCH act as the
    mass-lumped P1 scheme), and the areas sum to the mesh's. The Q-Voronoi cells are made of
    the circumcentres of the triangles, each in its triangle's own metric: the circumcentre of a
    triangle obtuse in its metric (which q_ij ≥ 0 allows) lies outside it, and cells can
    overlap. The heads do not depend on the choice: the conductances are q_ij either way.

    Everything is checked before the folder is touched, and the files are written to a
    temporary folder beside it and then moved in: an error leaves nothing half-written.
    """
    _check(mesh)
    folder = _workspace(workspace)
    name = _name(name)
    exe_name = checks.text(exe_name, "exe_name")
    top = checks.real(top, "top")
    bottom = checks.real(bottom, "bottom", high=top, high_open=True)
    if anisotropy is None and mesh.conductivity is None:
        raise QmeshError("anisotropy must be given (an Anisotropy, {region tag: Anisotropy}, a TensorField "
                         "or one Q per triangle): the mesh carries no element means (mesh.conductivity is None)")
    unused = np.setdiff1d(np.arange(mesh.n_vertices), mesh.triangles.ravel())
    if len(unused):
        raise QmeshError(f"mesh: vertex {unused[0]} belongs to no triangle ({len(unused)} such); "
                         "its cell would have no area")
    edges, q, _ = measure.edge_q(mesh, anisotropy)
    _refuse_negative(mesh, edges, q)
    flopy = _import("flopy", "modflow")

    grid = _disu(mesh, edges, q)
    tmp = folder.with_name(f".{folder.name}.{uuid.uuid4().hex[:12]}.part")
    try:
        sim = _simulation(flopy, grid, tmp, name, exe_name, top, bottom, mesh.n_vertices)
        sim.write_simulation(silent=True)
        _move_into(tmp, folder)
    except Exception as e:
        if isinstance(e, QmeshError):
            raise
        raise QmeshError(f"cannot write the MODFLOW 6 simulation to {str(folder)!r}: {e}") from e
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    sim.set_sim_path(str(folder))
    return sim


def modflow_cells(mesh: Mesh, *, tags: Union[int, str, Iterable[Union[int, str]], None] = None,
                  points: ArrayLike | None = None) -> NDArray[np.int64]:
    """Cell ids of a `to_modflow6` grid (cell id = vertex index, 0-based as flopy takes them):
    with `tags` (a boundary tag, a tag's name, or a list of them) every vertex on a boundary
    edge of those tags, sorted; with `points` (k, 2) the vertex nearest each point, in order
    (not always the cell that holds the point: a dual face runs between two vertices).
    For CHD, each id as flopy's cellid `(k,)`."""
    checks.mesh(mesh)
    if (tags is None) == (points is None):
        raise QmeshError("give exactly one of tags= and points=")
    if points is not None:
        X = checks.real_array(points, "points", (None, 2))
        return cKDTree(mesh.points).query(X)[1].astype(np.int64)
    wanted = [tags] if isinstance(tags, (int, str, np.integer)) else list(tags)  # type: ignore[arg-type]
    by_name = {v: k for k, v in mesh.tag_names.items()}
    present = set(np.unique(mesh.boundary_tags).tolist())
    ids: list[int] = []
    for t in wanted:
        tag = by_name.get(t, -1) if isinstance(t, str) else checks.integer(t, "tags")
        if tag not in present:
            raise QmeshError(f"tags: {t!r} is no boundary tag of the mesh (tags {sorted(present)}, "
                             f"names {mesh.tag_names})")
        ids.append(tag)
    return np.unique(mesh.boundary_edges[np.isin(mesh.boundary_tags, ids)]).astype(np.int64)


# --------------------------------------------------------------------------- checks

def _workspace(workspace: object) -> Path:
    if not isinstance(workspace, (str, PathLike)) or not str(workspace):
        raise QmeshError(f"workspace must be a folder's path, got {checks.describe(workspace)}")
    folder = Path(workspace).absolute()
    if folder.exists() and not folder.is_dir():
        raise QmeshError(f"workspace {str(workspace)!r} is an existing file, not a folder")
    if not folder.parent.is_dir():
        raise QmeshError(f"workspace {str(workspace)!r}: folder {str(folder.parent)!r} does not exist")
    return folder


def _name(name: object) -> str:
    text = checks.text(name, "name")
    if not _NAME.fullmatch(text):
        raise QmeshError(f"name must be 1 to 16 letters, digits, '_', '.' or '-' (a MODFLOW model name), "
                         f"got {text!r}")
    return text


def _refuse_negative(mesh: Mesh, edges: NDArray[np.int64], q: NDArray[np.float64]) -> None:
    scale = float(np.abs(q).max()) if len(q) else 0.0
    bad = np.flatnonzero(q < -NEGATIVE_RTOL * scale)
    if len(bad):
        k = bad[np.argmin(q[bad])]
        i, j = edges[k].tolist()
        raise QmeshError(f"mesh: edge ({i}, {j}) from {mesh.points[i].tolist()} to {mesh.points[j].tolist()} "
                         f"has q_ij = {q[k]:.6g} < 0 ({len(bad)} negative in {len(q)} edges): a negative "
                         "conductance; mesh it with qmesh for this conductivity")


# --------------------------------------------------------------------------- the grid

def _disu(mesh: Mesh, edges: NDArray[np.int64], q: NDArray[np.float64]) -> dict[str, Any]:
    """The DISU arrays (0-based as flopy takes them): each cell's row is itself, then its
    neighbours in increasing order."""
    P, T, n = mesh.points, mesh.triangles, mesh.n_vertices
    oriented = boundary.boundary_of(mesh)[0]
    dual = median_dual(P, T, edges, oriented)
    width, normal = dual_faces(P, T, edges)
    keep = q > 0
    e, qk, w, nrm = edges[keep], q[keep], width[keep], normal[keep]
    angle = np.degrees(arctan2(nrm[:, 1], nrm[:, 0])) % 360.0               # from i to j (i < j)
    k = len(e)
    # n–m and m–n entries, then the diagonal, each row sorted with itself first
    row = np.concatenate([e[:, 0], e[:, 1], np.arange(n)])
    col = np.concatenate([e[:, 1], e[:, 0], np.arange(n)])
    first = np.concatenate([np.zeros(2 * k, bool), np.ones(n, bool)])
    order = np.lexsort((col, ~first, row))
    cl = w / (2.0 * qk)                                          # CL1 + CL2 = w / q
    per = {"ihc": np.concatenate([np.ones(2 * k, np.int64), np.ones(n, np.int64)]),
           "cl12": np.concatenate([cl, cl, np.zeros(n)]),
           "hwva": np.concatenate([w, w, np.zeros(n)]),
           "angldegx": np.concatenate([angle, (angle + 180.0) % 360.0, np.zeros(n)])}
    vertices = [[iv, x, y] for iv, (x, y) in enumerate(dual.points.tolist())]
    # flopy takes CELL2D as one list per cell (clockwise in MODFLOW: the corners reversed)
    rings = np.split(dual.corners, dual.offsets[1:-1])
    cell2d = [[c, x, y, len(r), *r[::-1].tolist()] for c, ((x, y), r) in enumerate(zip(P.tolist(), rings))]
    return {"nodes": n, "nja": len(row), "nvert": len(vertices), "area": dual.areas,
            "iac": np.bincount(row, minlength=n), "ja": col[order],
            **{key: v[order] for key, v in per.items()}, "vertices": vertices, "cell2d": cell2d}


def _simulation(flopy: Any, grid: dict[str, Any], folder: Path, name: str, exe_name: str, top: float,
                bottom: float, n: int) -> Any:
    mf6 = flopy.mf6
    sim = mf6.MFSimulation(sim_name=name, sim_ws=str(folder), exe_name=exe_name, verbosity_level=0)
    # every real as 17 significant digits (flopy's default, 9, would round q_ij at 1e-9): a double
    # read back is the double written, also in what the user adds and writes later
    sim.simulation_data.float_precision = 16
    sim.simulation_data.float_characters = 24
    sim.simulation_data.set_sci_note_lower_thres(np.inf)
    mf6.ModflowTdis(sim, nper=1, perioddata=[(1.0, 1, 1.0)], filename=f"{name}.tdis")
    mf6.ModflowIms(sim, complexity="simple", outer_dvclose=1e-12, outer_maximum=50, inner_maximum=5000,
                   inner_dvclose=1e-12, rcloserecord=[1e-12, "strict"], linear_acceleration="cg",
                   preconditioner_levels=7, preconditioner_drop_tolerance=1e-6, filename=f"{name}.ims")
    gwf = mf6.ModflowGwf(sim, modelname=name, save_flows=True)
    mf6.ModflowGwfdisu(gwf, top=np.full(n, top), bot=np.full(n, bottom), filename=f"{name}.disu", **grid)
    mf6.ModflowGwfnpf(gwf, icelltype=0, k=1.0, save_specific_discharge=True, filename=f"{name}.npf")
    mf6.ModflowGwfic(gwf, strt=top, filename=f"{name}.ic")
    mf6.ModflowGwfoc(gwf, head_filerecord=f"{name}.hds", budget_filerecord=f"{name}.cbc",
                     saverecord=[("HEAD", "ALL"), ("BUDGET", "ALL")], filename=f"{name}.oc")
    return sim


def _move_into(tmp: Path, folder: Path) -> None:
    """The written files from `tmp` into `folder` (made when missing), each by a rename."""
    if not folder.exists():
        os.replace(tmp, folder)
        return
    for f in sorted(tmp.iterdir()):
        os.replace(f, folder / f.name)
