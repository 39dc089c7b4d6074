"""`qmesh sweep --scheduler` and `qmesh table --scheduler`: a real `dask scheduler` and two
`dask worker` processes on 127.0.0.1 run a small study, and its rows equal direct `qmesh.mesh`
calls; the chapter's table made there equals the one made in this process. The scheduler picks a
free port itself (port 0) and tells it through its scheduler file; every process is started in
its own session and killed at the end, whatever happens; every wait is bounded."""

import csv
import json
import math
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

import qmesh
from qmesh.cli import main
from qmesh.sweep import read_rows

DASK = str(Path(sys.executable).with_name("dask"))
WAIT = 60   # seconds for the scheduler file and for two workers to join

STUDY = '''domains = ["disk", "L-shape"]
conductivities = [{principal = [1, 100, 30]}, {s = "exp(x) + y**2"}]
target_vertices = [150]
'''


def start(*args, log: Path) -> subprocess.Popen:
    with open(log, "w") as out:
        return subprocess.Popen([DASK, *args], stdout=out, stderr=subprocess.STDOUT, start_new_session=True,
                                cwd=log.parent)


def stop(processes) -> None:
    """Workers first, then the scheduler: SIGTERM, and SIGKILL for any still there after 5 s."""
    for p in reversed(processes):
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
        try:
            p.wait(timeout=5)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait(timeout=10)


def wait_for(condition, what: str, processes) -> None:
    deadline = time.monotonic() + WAIT
    while not condition():
        dead = [p.args for p in processes if p.poll() is not None]
        assert not dead, f"exited while waiting for {what}: {dead}"
        assert time.monotonic() < deadline, f"no {what} after {WAIT} s"
        time.sleep(0.2)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """The scheduler's address, with two single-threaded workers connected (one cluster for the
    module: starting it costs more than the tests)."""
    from dask.distributed import Client   # the sweep extra, part of "all", which CI installs
    tmp_path = tmp_path_factory.mktemp("cluster")
    file = tmp_path / "scheduler.json"
    processes = [start("scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                       "--scheduler-file", str(file), log=tmp_path / "scheduler.log")]
    try:
        wait_for(lambda: file.is_file() and file.stat().st_size > 0, "scheduler file", processes)
        address = json.loads(file.read_text())["address"]
        for i in range(2):
            processes.append(start("worker", address, "--host", "127.0.0.1", "--nthreads", "1", "--no-nanny",
                                   "--no-dashboard", "--name", f"w{i}", log=tmp_path / f"worker{i}.log"))
        with Client(address, timeout="10s") as client:
            wait_for(lambda: len(client.scheduler_info()["workers"]) == 2, "two workers", processes)
            workers = set(client.scheduler_info()["workers"])
        yield address, workers
    finally:
        stop(processes)


def test_sweep_on_a_running_scheduler_equals_direct_calls(tmp_path, cluster, capsys):
    address, workers = cluster
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    code = main(["sweep", str(study), "-o", str(tmp_path / "r.parquet"), "--scheduler", address])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "4 jobs: 4 run, 0 already done, 0 failed" in out
    rows = read_rows(tmp_path / "r.parquet")
    assert len(rows) == 4 and {r["worker"] for r in rows} <= workers
    for r in rows:
        domain = qmesh.domains.NAMED[r["domain"]]()
        kind, _, value = r["conductivity"].partition("=")
        anisotropy = (qmesh.Anisotropy.principal(*json.loads(value)) if kind == "principal"
                      else qmesh.Anisotropy.from_expression(value))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", qmesh.QmeshWarning)
            m = qmesh.mesh(domain, anisotropy, target_vertices=150, seed=0)
        assert r["error"] is None and r["n_vertices"] == m.n_vertices
        assert r["kappa2"] == pytest.approx(qmesh.measure.condition_number(m, anisotropy), rel=1e-9)
        assert qmesh.io.read(r["mesh"]).n_vertices == m.n_vertices


def test_the_chapter_table_on_a_running_scheduler_equals_the_one_made_here(tmp_path, cluster, capsys):
    from qmesh.compare import table
    address, _ = cluster
    vb = [32, 45]
    code = main(["table", "--vb", *map(str, vb), "--out", str(tmp_path), "--scheduler", address])
    out, err = capsys.readouterr()
    assert code == 0, err
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        here, _ = table.build_rows(vb)
    n = {(r["vb"], r["mesher"]): r["n_vertices"] for r in here}
    assert err.splitlines() == [f"VB {v}: isotropic N={n[v, 'isotropic']}, qmesh N={n[v, 'qmesh']}"
                                for v in vb], err             # one progress line per VB
    with open(tmp_path / "table.csv", newline="") as f:
        there = list(csv.DictReader(f))
    assert [(int(r["vb"]), r["mesher"]) for r in there] == [(r["vb"], r["mesher"]) for r in here]
    for a, b in zip(there, here):
        for key in table.MEASURED:
            assert float(a[key]) == pytest.approx(b[key], rel=1e-12), (a["vb"], a["mesher"], key)
    assert f"| 45 | qmesh | {n[45, 'qmesh']} |" in out


def test_a_failed_task_names_its_arguments_and_the_rest_come_back_in_order(cluster):
    from qmesh.sweep.runner import map_ordered
    address, _ = cluster
    assert map_ordered(math.sqrt, [(9.0,), (4.0,), (1.0,)], scheduler=address) == [3.0, 2.0, 1.0]
    with pytest.raises(qmesh.QmeshError, match=r"sqrt\(-1\.0,\) failed on Dask: ValueError: math domain"):
        map_ordered(math.sqrt, [(4.0,), (-1.0,)], scheduler=address)


def test_an_unreachable_scheduler_is_one_error_line(tmp_path, capsys, monkeypatch):
    from qmesh.sweep import runner
    monkeypatch.setattr(runner, "CONNECT_TIMEOUT", "1s")
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    code = main(["sweep", str(study), "-o", str(tmp_path / "r.csv"), "--scheduler", "tcp://127.0.0.1:9",
                 "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("qmesh: error: cannot reach the Dask scheduler at 'tcp://127.0.0.1:9'")
    assert err.count("\n") == 1 and not (tmp_path / "r.csv").exists()
    assert not (tmp_path / "r-meshes").exists()
