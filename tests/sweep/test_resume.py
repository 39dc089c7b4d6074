"""Re-running a sweep runs only what the table does not hold as finished: a row without error
whose mesh file exists is kept as it is; a failed row, or one whose mesh file is gone, runs again;
rows of jobs outside the study stay. Failed jobs are rows, and `qmesh sweep` exits 1 for them."""

from pathlib import Path

from qmesh.cli import main
from qmesh.sweep import read_rows, run_job, study_jobs, write_rows

STUDY = '''domains = ["disk"]
conductivities = [{principal = [1, 100, 30]}]
target_vertices = [10, 200]
seeds = [0, 1]
'''


def test_rerun_skips_finished_jobs_and_retries_the_rest(tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    table, meshes = tmp_path / "r.csv", tmp_path / "meshes"
    jobs = {j.key[2:]: j for j in study_jobs(study, meshes)}          # (N, seed) → job
    assert len(jobs) == 4
    meshes.mkdir()
    # an earlier run, in this process (worker None): one finished, one failed, one whose file is gone,
    # and a row of another study
    done, failed, gone = run_job(jobs[200, 0]), run_job(jobs[10, 0]), run_job(jobs[200, 1])
    Path(gone["mesh"]).unlink()
    other = {**done, "domain": "L-shape", "mesh": "/elsewhere/l.vtu"}
    assert done["error"] is None and failed["error"] is not None
    write_rows(table, [other, failed, done, gone])

    code = main(["sweep", str(study), "-o", str(table), "--meshes", str(meshes), "--workers", "1"])
    out, err = capsys.readouterr()
    assert code == 1, err
    assert "4 jobs: 3 run, 1 already done, 2 failed" in out
    assert "1 job already in the table, skipped" in err and "2 of 3 jobs failed" in err
    progress = [line for line in err.splitlines() if line.startswith("sweep: ") and "/3 [" in line]
    assert len(progress) == 3 and "3/3" in progress[-1] and "2 failed" in progress[-1]   # a line per job
    rows = read_rows(table)
    # the study's order, then the other study's row
    assert [(r["domain"], r["target_vertices"], r["seed"]) for r in rows] == [
        ("disk", 10, 0), ("disk", 10, 1), ("disk", 200, 0), ("disk", 200, 1), ("L-shape", 200, 0)]
    assert rows[2] == done and rows[4] == other                       # kept as they were
    for r in (rows[0], rows[1], rows[3]):                             # ran again, on a Dask worker
        assert r["worker"].startswith("tcp://127.0.0.1:")
    assert "must exceed the 64 input points" in rows[0]["error"] and rows[1]["error"] == rows[0]["error"]
    assert rows[3]["error"] is None and Path(rows[3]["mesh"]).is_file()
    assert rows[3]["n_vertices"] == gone["n_vertices"] and rows[3]["kappa2"] == gone["kappa2"]

    # nothing left but the failures: a run with only the finished jobs starts no cluster at all
    study.write_text(STUDY.replace("[10, 200]", "[200]"))
    code = main(["sweep", str(study), "-o", str(table), "--meshes", str(meshes), "--workers", "1"])
    out, err = capsys.readouterr()
    assert code == 0 and "2 jobs: 0 run, 2 already done, 0 failed" in out
    again = read_rows(table)
    assert [r for r in again if r["target_vertices"] == 200] == [rows[2], rows[3], rows[4]]
    assert sorted(map(str, again)) == sorted(map(str, rows))           # the failed rows stay too


def test_an_interrupted_sweep_keeps_its_rows_and_the_old_failures(tmp_path, monkeypatch):
    """Ctrl-C after one new row: the table holds it, the finished rows, and the failed rows whose
    jobs had not run again yet (the cluster is replaced by an in-process stand-in)."""
    from contextlib import contextmanager

    from qmesh.sweep import run_sweep, runner

    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    table, meshes = tmp_path / "r.csv", tmp_path / "meshes"
    meshes.mkdir()
    jobs = study_jobs(study, meshes)
    by_key = {j.key[2:]: j for j in jobs}
    old = [run_job(by_key[200, 0]), run_job(by_key[10, 0]), run_job(by_key[10, 1])]   # one done, two failed
    write_rows(table, old)

    def one_then_interrupt(client, todo, bar, rows, save):
        rows.append(run_job(todo[-1]))              # (200, 1) finishes, then the user presses Ctrl-C
        raise KeyboardInterrupt

    @contextmanager
    def no_cluster(scheduler, workers):
        yield None

    monkeypatch.setattr(runner, "dask_client", no_cluster)
    monkeypatch.setattr(runner, "_collect", one_then_interrupt)
    try:
        run_sweep(jobs, table, quiet=True)
    except KeyboardInterrupt:
        pass
    else:
        raise AssertionError("the interrupt was swallowed")
    rows = read_rows(table)
    assert [(r["target_vertices"], r["seed"], r["error"] is None) for r in rows] == [
        (10, 0, False), (10, 1, False), (200, 0, True), (200, 1, True)]
    assert rows[0] == old[1] and rows[2] == old[0]
