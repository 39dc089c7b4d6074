"""One job of a study → one row of the results table.

`run_job` builds the domain and the conductivity, runs `qmesh.mesh`, measures the mesh with
`qmesh.measure.report`, writes the mesh file and returns the row. Any exception becomes the
row's `error` (with what was measured so far): a failed job never loses the sweep. It runs on
a Dask worker, so a Job holds only text and numbers (pickled to the worker) and the row only
plain Python values.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

from qmesh import io, measure
from qmesh import mesh as qmesh_mesh
from qmesh.errors import QmeshError, QmeshWarning
from qmesh.sweep.conductivity import anisotropy_of
from qmesh.sweep.domain import build_domain
from qmesh.sweep.results import COLUMNS

REPORTED = ("n_vertices", "n_triangles", "n_boundary", "kappa2", "q_nonnegative_fraction",
            "q_nonnegative_fraction_boundary", "min_quality", "mean_quality", "l2_error", "h1_error")
"""The entries of `qmesh.measure.report` the table keeps."""


@dataclass(frozen=True)
class Job:
    """One point of the study's product, and where its mesh file goes."""
    domain: str              # a name in qmesh.domains.NAMED, or the polygon file as the study gives it
    domain_file: str | None  # that file's absolute path (None for a named domain)
    conductivity: str        # principal=[…], Q=[[…]] or s=… (qmesh.sweep.conductivity)
    target_vertices: int
    seed: int
    mesh: str                # the mesh file to write (absolute path; its extension is the format)

    @property
    def key(self) -> tuple:
        """What identifies the job in the table (the same key as `results.row_key`)."""
        return (self.domain, self.conductivity, self.target_vertices, self.seed)


def empty_row(job: Job) -> dict:
    """The row of a job before anything is measured: its inputs, every other column None."""
    row = dict.fromkeys(COLUMNS)
    row.update(domain=job.domain, conductivity=job.conductivity, target_vertices=job.target_vertices,
               seed=job.seed)
    return row


def failed_row(job: Job, error: BaseException) -> dict:
    """The row of a job that did not finish (also for a worker lost under it)."""
    return {**empty_row(job), "error": error_text(error)}


def error_text(error: BaseException) -> str:
    """qmesh's own refusals as their message; anything else with its type, which says more."""
    text = str(error).strip()
    if isinstance(error, QmeshError):
        return text
    return f"{type(error).__name__}: {text}" if text else type(error).__name__


def run_job(job: Job) -> dict:
    """Mesh, measure and write one job; its row, with `error` set when any step failed."""
    row = empty_row(job)
    row["worker"] = _worker()
    try:
        domain = build_domain(job.domain, job.domain_file)
        anisotropy = anisotropy_of(job.conductivity)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", QmeshWarning)
            start = time.perf_counter()
            mesh = qmesh_mesh(domain, anisotropy, target_vertices=job.target_vertices, seed=job.seed)
            row["seconds"] = time.perf_counter() - start       # the meshing time, as `qmesh mesh` prints it
        notes = [str(w.message) for w in caught if issubclass(w.category, QmeshWarning)]
        row["warning"] = "; ".join(dict.fromkeys(notes)) or None
        report = measure.report(mesh, anisotropy, laplacian=False)   # its κ2 for Q = I is not kept
        row.update({k: report[k] for k in REPORTED})
        io.write(job.mesh, mesh, anisotropy=anisotropy)
        row["mesh"] = job.mesh
    except Exception as e:  # noqa: BLE001 — any failure is this job's row, never the sweep's end
        row["error"] = error_text(e)
    return row


def _worker() -> str | None:
    """The Dask worker's address when the job runs on one (None when called directly)."""
    try:
        from distributed import get_worker
        return get_worker().address
    except (ImportError, ValueError):
        return None
