"""`qmesh sweep STUDY -o RESULTS [--scheduler ADDRESS | --workers N]`: the subcommand's parser
and handler, registered by `qmesh.cli`. Dask is imported only when a sweep runs."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from qmesh.sweep import results
from qmesh.sweep.study import MAX_JOBS


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return value


def add_dask_options(p, scheduler_note: str, workers_note: str) -> None:
    """--scheduler ADDRESS | --workers N, for every subcommand that runs on Dask."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786 "
                   + scheduler_note)
    g.add_argument("--workers", type=_positive_int, metavar="N",
                   help="worker processes of a local Dask cluster on 127.0.0.1 " + workers_note)


def add_parser(sub) -> None:
    """Register `sweep` on the `qmesh` command's subparsers."""
    p = sub.add_parser(
        "sweep", help="run a parameter study (domains × conductivities × N × seeds) on Dask",
        description="Mesh and measure every domain × conductivity × target_vertices × seed of a study "
        "file (TOML or JSON) on Dask distributed and write one row per job to RESULTS (.csv or "
        ".parquet): inputs, N, κ2, the shares of q_ij ≥ 0, quality, seconds, the mesh file, and the "
        "error of a failed job. Jobs the table already holds without error are skipped, so a "
        "re-run finishes an interrupted sweep. Needs the sweep extra.")
    p.add_argument("study", metavar="STUDY", help="the study file (.toml or .json)")
    p.add_argument("-o", "--output", required=True, metavar="RESULTS", help="the results table (.csv or .parquet)")
    add_dask_options(p, "(its workers need qmesh and the mesh folder); default: a local cluster",
                     "(default: one per CPU, at most one per job)")
    p.add_argument("--meshes", metavar="DIR", help="folder for the mesh files (default: RESULTS' name "
                   "without extension, plus -meshes)")
    p.add_argument("--max-jobs", type=_positive_int, default=MAX_JOBS, metavar="N",
                   help=f"refuse a study of more than N jobs, counted before any is made (default: {MAX_JOBS})")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(handler=cmd_sweep)


def cmd_sweep(args) -> int:
    """Run the study; exit 0, or 1 when some job failed (its row says why)."""
    from qmesh.sweep.runner import run_sweep
    from qmesh.sweep.study import study_jobs
    output = results.check_path(args.output)
    meshes = Path(args.meshes) if args.meshes else output.with_name(output.stem + "-meshes")
    jobs = study_jobs(args.study, meshes, max_jobs=args.max_jobs)
    s = run_sweep(jobs, output, scheduler=args.scheduler, workers=args.workers, quiet=args.quiet)
    print(f"{output}: {s.jobs} jobs: {s.ran} run, {s.skipped} already done, {s.failed} failed; "
          f"{s.seconds:.1f} s")
    if s.failed:
        print(f"qmesh: warning: {s.failed} of {s.ran} jobs failed; the error column says why", file=sys.stderr)
        return 1
    return 0
