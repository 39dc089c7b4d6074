"""What a sweep refuses or reports instead of spending memory or waiting forever: a study of
more jobs than the limit (counted before any is made), integers past int64, scheduler addresses
that are not tcp:// or whose peer is not a Dask scheduler (silent, HTTP), more worker
processes than jobs, and the only worker killed in the middle of a job. Every server here
listens on 127.0.0.1, every wait is bounded."""

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import tracemalloc
from pathlib import Path

import pytest

import qmesh
from qmesh.cli import main
from qmesh.sweep import runner
from qmesh.sweep.study import INT64_MAX, MAX_JOBS, study_jobs

SMALL = 'domains = ["disk"]\nconductivities = [{principal = [1, 10, 30]}]\ntarget_vertices = [150]\n'


def test_a_study_of_billions_of_jobs_is_refused_from_its_counts(tmp_path):
    """About 100 kB of TOML whose product is 2.7e9 jobs: refused before any entry is checked
    or any job made."""
    doms = ", ".join(f'"d{i}"' for i in range(3000))
    ks = ", ".join(f"{{principal = [1, {i + 2}, 0]}}" for i in range(3000))
    ns = ", ".join(str(100 + i) for i in range(300))
    path = tmp_path / "big.toml"
    path.write_text(f"domains = [{doms}]\nconductivities = [{ks}]\ntarget_vertices = [{ns}]\n")
    assert path.stat().st_size < 150_000
    tracemalloc.start()
    try:
        with pytest.raises(qmesh.QmeshError) as e:
            study_jobs(path, tmp_path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert "make 2700000000 jobs" in str(e.value) and f"limit of {MAX_JOBS}" in str(e.value)
    assert "--max-jobs" in str(e.value)
    assert peak < 64 * 2**20


def test_the_limit_is_the_users_to_raise(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(SMALL.replace("[150]", "[150, 200, 250]"))
    assert len(study_jobs(path, tmp_path, max_jobs=3)) == 3
    code = main(["sweep", str(path), "-o", str(tmp_path / "r.csv"), "--max-jobs", "2"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "make 3 jobs, more than the limit of 2" in err
    assert not (tmp_path / "r.csv").exists()


@pytest.mark.parametrize("key, value", [("target_vertices", 2**63), ("target_vertices", 10**400),
                                        ("seeds", 2**64 + 1)])
def test_an_integer_past_int64_is_refused_up_front(tmp_path, capsys, key, value):
    study = {"domains": ["disk"], "conductivities": [{"principal": [1, 10, 30]}], "target_vertices": [150],
             key: [value]}
    path = tmp_path / "s.json"
    path.write_text(json.dumps(study))
    code = main(["sweep", str(path), "-o", str(tmp_path / "r.parquet")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and f"{key}[0]" in err and str(INT64_MAX) in err
    assert not (tmp_path / "r.parquet").exists()


@pytest.mark.parametrize("address", ["tls://127.0.0.1:8786", "ucx://127.0.0.1:8786", "ws://127.0.0.1:8786",
                                     "inproc://x", "tcp://127.0.0.1", "tcp://127.0.0.1:99999"])
def test_other_schemes_and_bad_addresses_are_one_error_line(tmp_path, capsys, address):
    path = tmp_path / "s.toml"
    path.write_text(SMALL)
    code = main(["sweep", str(path), "-o", str(tmp_path / "r.csv"), "--scheduler", address, "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and err.startswith("qmesh: error: ") and repr(address) in err
    assert "Traceback" not in err


class Server:
    """A TCP server on 127.0.0.1 that accepts connections and answers each with `reply` (None:
    never answers); it stops by itself after `seconds` or when closed."""

    def __init__(self, reply: bytes | None, seconds: float = 30):
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.reply, self.until, self.held = reply, time.monotonic() + seconds, []
        self.thread = threading.Thread(target=self.serve, daemon=True)
        self.thread.start()

    def serve(self):
        while time.monotonic() < self.until and self.sock.fileno() >= 0:
            try:
                conn, _ = self.sock.accept()
            except (socket.timeout, OSError):
                continue
            self.held.append(conn)
            if self.reply is not None:
                try:
                    conn.recv(1024) if self.reply.startswith(b"HTTP") else None
                    conn.sendall(self.reply)
                except OSError:
                    pass

    def close(self):
        self.until = 0
        self.thread.join(timeout=5)
        for c in self.held:
            c.close()
        self.sock.close()


@pytest.mark.timeout(60)
@pytest.mark.parametrize("reply, message", [
    (None, "accepts connections but sends nothing within 1 s"),
    (b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n", "sends nothing within 1 s"),   # waits for a request
    (b"SSH-2.0-OpenSSH_9.2\r\n", "is not a Dask scheduler: it answered b'SSH-2.0-'"),
])
def test_a_peer_that_is_not_a_scheduler_is_refused_in_time(tmp_path, capsys, monkeypatch, reply, message):
    monkeypatch.setattr(runner, "CONNECT_SECONDS", 1.0)
    server = Server(reply)
    try:
        path = tmp_path / "s.toml"
        path.write_text(SMALL)
        address = f"tcp://127.0.0.1:{server.port}"
        code = main(["sweep", str(path), "-o", str(tmp_path / "r.csv"), "--scheduler", address, "--quiet"])
    finally:
        server.close()
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and message in err and repr(address) in err
    assert not (tmp_path / "r.csv").exists()


def test_at_most_one_worker_process_per_job(tmp_path, monkeypatch):
    asked = []

    class Stop(Exception):
        pass

    def client(scheduler, workers):
        asked.append(workers)
        raise Stop

    monkeypatch.setattr(runner, "dask_client", client)
    path = tmp_path / "s.toml"
    path.write_text(SMALL)
    jobs = study_jobs(path, tmp_path / "meshes")
    for workers in (24, None, 1):
        with pytest.raises(Stop):
            runner.run_sweep(jobs, tmp_path / "r.csv", workers=workers, quiet=True)
    assert asked == [1, 1, 1]


DASK = str(Path(sys.executable).with_name("dask"))


def _start(*args, log: Path) -> subprocess.Popen:
    with open(log, "w") as out:
        return subprocess.Popen([DASK, *args], stdout=out, stderr=subprocess.STDOUT, start_new_session=True,
                                cwd=log.parent)


def _wait(condition, seconds=60):
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.2)


@pytest.mark.timeout(240)
def test_the_only_worker_killed_mid_job_is_reported_not_waited_for(tmp_path, monkeypatch):
    """A scheduler and one worker (no nanny) on 127.0.0.1; the worker is killed while it meshes
    the one long job: the sweep ends with that job's row saying no worker is left."""
    monkeypatch.setattr(runner, "NO_WORKER_WAIT", 2.0)
    monkeypatch.setattr(runner, "POLL", 0.2)
    file = tmp_path / "scheduler.json"
    procs = [_start("scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard", "--scheduler-file",
                    str(file), log=tmp_path / "scheduler.log")]
    try:
        _wait(lambda: file.is_file() and file.stat().st_size > 0)
        address = json.loads(file.read_text())["address"]
        procs.append(_start("worker", address, "--host", "127.0.0.1", "--nthreads", "1", "--no-nanny",
                            "--no-dashboard", log=tmp_path / "worker.log"))
        path = tmp_path / "s.toml"
        path.write_text(SMALL.replace("[150]", "[3000000]"))         # minutes of meshing
        jobs = study_jobs(path, tmp_path / "meshes")

        def kill():
            from dask.distributed import Client
            with Client(address, timeout="10s") as c:
                _wait(lambda: c.processing() and any(c.processing().values()))
            time.sleep(1)
            os.killpg(procs[1].pid, signal.SIGKILL)

        killer = threading.Thread(target=kill, daemon=True)
        killer.start()
        summary = runner.run_sweep(jobs, tmp_path / "r.csv", scheduler=address, quiet=True)
        killer.join(timeout=30)
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
            p.wait(timeout=10)
    assert summary.ran == 1 and summary.failed == 1
    from qmesh.sweep import read_rows
    [row] = read_rows(tmp_path / "r.csv")
    assert "no Dask worker left" in row["error"]
