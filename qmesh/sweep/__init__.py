"""`qmesh sweep`: parameter studies (domains × conductivities × N × seeds) on Dask distributed.

A study file (`study`) becomes a list of `Job`s; `run_job` meshes and measures one job into a
row of the results table (`results`), a failed job included; `runner.run_sweep` spreads the jobs
over a Dask cluster and writes the table as rows arrive, skipping jobs an earlier run finished.
Dask is imported only by the runner, and only when a sweep runs: the core stays NumPy + SciPy.
"""

from qmesh.sweep.job import Job, run_job
from qmesh.sweep.results import COLUMNS, read_rows, write_rows
from qmesh.sweep.runner import Summary, run_sweep
from qmesh.sweep.study import read_study, study_jobs

__all__ = ["COLUMNS", "Job", "Summary", "read_rows", "read_study", "run_job", "run_sweep", "study_jobs",
           "write_rows"]
