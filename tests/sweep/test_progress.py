"""The sweep's progress (qmesh.sweep.progress, drawn by tqdm) reports how many jobs are done and
failed: a line per job when stderr is a log, a bar redrawn in place on a terminal, nothing when
quiet."""

import io

from qmesh.sweep.progress import Progress


class Terminal(io.StringIO):
    def isatty(self):
        return True


def rows():
    ok = {"domain": "disk", "conductivity": "principal=[1, 100, 30]", "target_vertices": 200,
          "n_vertices": 203, "seconds": 0.25, "error": None}
    return [{**ok, "seed": 0}, {**ok, "seed": 1, "error": "target_vertices = 10 must exceed 64"},
            {**ok, "seed": 2}]


def test_a_log_gets_one_line_per_job_with_the_counts():
    log = io.StringIO()
    bar = Progress(3, log, skipped=2)
    for row in rows():
        bar.update(row)
    bar.close()
    skipped, *lines = log.getvalue().splitlines()
    assert skipped == "sweep: 2 jobs already in the table, skipped"
    assert len(lines) == 3 and "\r" not in log.getvalue()
    assert "1/3" in lines[0] and "failed" not in lines[0] and lines[0].endswith("seed=0: N=203 in 0.25 s")
    assert "2/3" in lines[1] and "1 failed" in lines[1] and "seed=1: failed: target_vertices = 10" in lines[1]
    assert "3/3" in lines[2] and "1 failed" in lines[2] and "100%" in lines[2]
    assert (bar.done, bar.failed) == (3, 1)


def test_a_terminal_gets_tqdms_bar_redrawn_in_place():
    tty = Terminal()
    bar = Progress(3, tty)
    for row in rows():
        bar.update(row)
    bar.close()
    text = tty.getvalue()
    assert text.count("\n") == 1 and "\r" in text                  # one line, redrawn
    last = text.rstrip("\n").split("\r")[-1]
    assert last.startswith("sweep: 100%") and "3/3" in last and "1 failed" in last and "seed=2" in last


def test_quiet_prints_nothing_but_still_counts():
    for stream in (io.StringIO(), Terminal()):
        bar = Progress(3, stream, skipped=1, enabled=False)
        for row in rows():
            bar.update(row)
        bar.close()
        assert stream.getvalue() == "" and (bar.done, bar.failed) == (3, 1)
