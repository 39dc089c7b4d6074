"""Run a study's jobs on Dask distributed and keep the results table up to date.

A `LocalCluster` (one single-threaded worker process per job slot, on 127.0.0.1, no dashboard)
unless a scheduler address is given. Jobs go out with `Client.submit` and come back in the
order they finish (`wait`); the table is rewritten as rows arrive (at most once a
second, and at the end, also when interrupted), so a re-run finds every finished job and skips
it: a job is finished when its row has no error and its mesh file exists. Rows of earlier jobs
that are not in this study are kept; a failed job's old row stays until its new run replaces it.
"""

from __future__ import annotations

import logging
import os
import signal
import socket
import sys
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from qmesh.errors import QmeshError
from qmesh.sweep import results
from qmesh.sweep.job import Job, failed_row, run_job
from qmesh.sweep.progress import Progress

CONNECT_TIMEOUT = "10s"
CONNECT_SECONDS = 10.0   # for the connection and the scheduler's first bytes (Dask's own timeout
                         # covers only the TCP connection: its handshake read then waits forever)
WRITE_EVERY = 1.0   # seconds between rewrites of the table while jobs come in
POLL = 1.0          # seconds between looks at the cluster while no job finishes
NO_WORKER_WAIT = 30.0   # seconds with jobs left and no worker before they are reported lost


@dataclass
class Summary:
    """What a sweep did: jobs in the study, skipped as finished before, run now, failed now."""
    jobs: int
    skipped: int
    ran: int
    failed: int
    seconds: float


def run_sweep(jobs: list[Job], output, *, scheduler: str | None = None, workers: int | None = None,
              progress=None, quiet: bool = False) -> Summary:
    """Run the jobs the table at `output` does not hold yet; write every row to it.

    `scheduler`: the address of a running Dask scheduler (its workers must import qmesh and
    reach the mesh files' folder); otherwise a LocalCluster of `workers` processes (default:
    one per CPU, at most one per job). `progress`: a stream for the bar (default stderr).
    """
    start = time.perf_counter()
    output = results.check_path(output)
    earlier = results.read_rows(output) if output.exists() else []
    finished = {results.row_key(r) for r in earlier
                if r["error"] is None and r["mesh"] and Path(r["mesh"]).is_file()}
    todo = [j for j in jobs if j.key not in finished]
    wanted = {j.key for j in jobs}
    kept = [r for r in earlier if results.row_key(r) in finished or results.row_key(r) not in wanted]
    # a failed row stays in the table until its job's new row replaces it (an interrupted re-run)
    retried = [r for r in earlier if results.row_key(r) in wanted and results.row_key(r) not in finished]
    bar = Progress(len(todo), progress or sys.stderr, skipped=len(jobs) - len(todo), enabled=not quiet)
    new: list[dict] = []

    def save() -> None:
        done = {results.row_key(r) for r in new}
        results.write_rows(output, _ordered(jobs, kept + new + [r for r in retried
                                                                 if results.row_key(r) not in done]))

    try:
        if todo:
            with dask_client(scheduler, min(workers or os.cpu_count() or 1, len(todo))) as client:
                for folder in {Path(j.mesh).parent for j in todo}:
                    folder.mkdir(parents=True, exist_ok=True)
                _collect(client, todo, bar, new, save)
    finally:
        bar.close()
        if new:         # also when interrupted; nothing ran (a scheduler not reached): no file
            save()
    failed = sum(r["error"] is not None for r in new)
    return Summary(len(jobs), len(jobs) - len(todo), len(new), failed, time.perf_counter() - start)


def _collect(client, todo: list[Job], bar: Progress, rows: list[dict], save) -> None:
    """Submit every job and append its row to `rows` as it finishes; `save()` at most every
    WRITE_EVERY seconds. When no worker is left for NO_WORKER_WAIT seconds while jobs remain
    (the only worker killed), the remaining jobs become failed rows saying so, and the sweep ends."""
    from dask.distributed import wait
    futures = {client.submit(run_job, job, pure=False): job for job in todo}
    pending = set(futures)
    last = time.perf_counter()
    alone_since = None
    while pending:
        try:
            done, pending = wait(pending, timeout=POLL, return_when="FIRST_COMPLETED")
        except TimeoutError:    # Dask's wait raises when nothing finished in time
            done = set()
        for future in done:
            try:
                row = future.result()
            except Exception as e:  # noqa: BLE001 — a lost worker, say: this job's row, not the sweep's end
                row = failed_row(futures[future], e)
            rows.append(row)
            bar.update(row)
        if done:
            alone_since = None
        elif not _workers(client):
            alone_since = alone_since or time.perf_counter()
            if time.perf_counter() - alone_since >= NO_WORKER_WAIT:
                lost = QmeshError(f"no Dask worker left for {NO_WORKER_WAIT:.0f} s (killed, or out of memory?); "
                                  "the job did not finish; run the sweep again to retry it")
                for future in pending:
                    rows.append(failed_row(futures[future], lost))
                    bar.update(rows[-1])
                client.cancel(list(pending))
                break
        else:
            alone_since = None
        if time.perf_counter() - last >= WRITE_EVERY:
            save()
            last = time.perf_counter()


def _workers(client) -> int:
    """The number of workers the scheduler has now (asked, not cached)."""
    try:
        return len(client.nthreads())
    except Exception:  # noqa: BLE001 — the scheduler itself gone: none
        return 0


def _ordered(jobs: list[Job], rows: list[dict]) -> list[dict]:
    """The study's rows in its order, then rows of earlier studies as they were."""
    place = {j.key: i for i, j in enumerate(jobs)}
    return sorted(rows, key=lambda r: place.get(results.row_key(r), len(place)))


@contextmanager
def dask_client(scheduler: str | None, workers: int):
    """A dask.distributed Client: to the scheduler at `scheduler`, or to a new LocalCluster of
    `workers` single-threaded processes on 127.0.0.1 (`qmesh sweep`, `qmesh table --workers`)."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as e:
        raise QmeshError(f"Dask is not installed (pip install 'qmesh[sweep]'): {e}") from e
    if scheduler:
        probe(scheduler)
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT)
        except Exception as e:  # noqa: BLE001 — Dask's errors on a bad peer have no common base
            raise QmeshError(f"cannot reach the Dask scheduler at {scheduler!r}: "
                             f"{type(e).__name__}: {str(e)[:200]}") from e
        with client:
            yield client
        return
    # The worker processes start with SIGINT ignored (inherited; Python then installs no
    # KeyboardInterrupt handler): Ctrl-C reaches only this process, which closes the cluster
    # and keeps the rows so far, instead of every worker printing its traceback.
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if _main_thread() else None
    try:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=None, silence_logs=logging.CRITICAL)
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    with cluster, Client(cluster) as client:
        yield client


def probe(address: str, seconds: float | None = None) -> None:
    """QmeshError unless `address` is a tcp:// address where something answers as a Dask
    scheduler does: it speaks first, a message whose first 8 bytes are its length. Dask's
    connect timeout covers only the TCP connection; its handshake read waits forever on a peer
    that never answers, and takes an HTTP server's reply as a frame length (exabytes)."""
    seconds = CONNECT_SECONDS if seconds is None else seconds
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "tcp", address
    if scheme != "tcp":
        raise QmeshError(f"scheduler address {address!r}: qmesh sweep reaches a Dask scheduler over tcp:// "
                         f"only ({scheme}:// needs credentials or libraries it does not pass); "
                         "give tcp://HOST:PORT")
    host, colon, port = rest.rstrip("/").rpartition(":")
    host = host.strip("[]")
    if not colon or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise QmeshError(f"scheduler address {address!r} is not tcp://HOST:PORT")
    try:
        sock = socket.create_connection((host, int(port)), timeout=seconds)
    except OSError as e:
        raise QmeshError(f"cannot reach the Dask scheduler at {address!r}: {e.strerror or e}") from e
    deadline = time.monotonic() + seconds
    first = b""
    try:
        with sock:
            while len(first) < 8:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise socket.timeout
                sock.settimeout(left)
                got = sock.recv(8 - len(first))
                if not got:
                    break
                first += got
    except (socket.timeout, TimeoutError):
        raise QmeshError(f"{address!r} accepts connections but sends nothing within {seconds:g} s: "
                         "not a Dask scheduler, or one too busy to answer") from None
    except OSError as e:
        raise QmeshError(f"cannot reach the Dask scheduler at {address!r}: {e.strerror or e}") from e
    if len(first) < 8 or not 8 <= int.from_bytes(first, "little") < 2**30:
        raise QmeshError(f"{address!r} is not a Dask scheduler: it answered {first!r}")


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def map_ordered(fn, args: list[tuple], *, scheduler: str | None = None, workers: int | None = None,
                done=None) -> list:
    """[fn(*a) for a in args], each call a task on Dask (see `dask_client`), results in the order
    of `args`; `done(result)` as each finishes. A failed task raises QmeshError naming its
    arguments, after the others were cancelled."""
    from dask.distributed import as_completed
    with dask_client(scheduler, min(workers or os.cpu_count() or 1, max(len(args), 1))) as client:
        futures = {client.submit(fn, *a, pure=False): i for i, a in enumerate(args)}
        out: list = [None] * len(args)
        for future in as_completed(futures):
            i = futures[future]
            try:
                out[i] = future.result()
            except Exception as e:  # noqa: BLE001 — any task error ends the map with its arguments
                client.cancel(list(futures))
                raise QmeshError(f"{getattr(fn, '__name__', fn)}{args[i]!r} failed on Dask: "
                                 f"{type(e).__name__}: {e}") from e
            if done:
                done(out[i])
    return out
