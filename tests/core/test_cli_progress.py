"""`qmesh mesh`'s progress bar (tqdm) on stderr: shown on a terminal once a run has taken a
second (qmesh.cli.BAR: delay=1, disable=None), one count per Step with its stage and N; silent
when stderr is not a terminal or with --quiet; --progress prints lines instead, a field's last
one counting its evaluations."""

import fcntl
import io
import os
import pty
import struct
import subprocess
import sys
import termios

import pytest

import qmesh.cli
from cli_run import run

ARGS = ("mesh", "--disk", 32, "--target-vertices", 400)


class Terminal(io.StringIO):
    def isatty(self):
        return True


@pytest.fixture
def no_delay(monkeypatch):
    """The bar from the first Step on (a test run takes less than tqdm's one-second delay)."""
    monkeypatch.setitem(qmesh.cli.BAR, "delay", 0.0)


def stages(text):
    """The bar's redraws: the text between carriage returns that shows a count."""
    return [part for part in text.split("\r") if part.startswith("qmesh mesh: ")]


def test_a_terminal_shows_the_bar_counting_stages_with_stage_and_n(tmp_path, capsys, monkeypatch, no_delay):
    monkeypatch.setitem(qmesh.cli.BAR, "mininterval", 0.0)        # every Step redrawn
    tty = Terminal()
    monkeypatch.setattr(sys, "stderr", tty)
    code, out, _ = run(capsys, *ARGS, "-o", tmp_path / "m.vtu")
    assert code == 0 and out.startswith(str(tmp_path / "m.vtu"))
    steps = list(qmesh.iterate(qmesh.Disk(32), qmesh.Anisotropy.constant(qmesh.CHAPTER_Q), target_vertices=400))
    drawn = stages(tty.getvalue())
    assert drawn[0].startswith("qmesh mesh: 0 stages")
    assert [part.split()[2] for part in drawn[1:]] == [str(k) for k in range(1, len(steps) + 1)]
    assert [part.rstrip().rsplit(", ", 1)[1] for part in drawn[1:]] == [
        f"iteration {s.iteration} {s.stage} N={s.stats.n_vertices}]" for s in steps]
    assert tty.getvalue().endswith("\r")                  # leave=False: the line is cleared at the end


def test_not_a_terminal_quiet_or_lines_get_no_bar(tmp_path, capsys, no_delay):
    code, _, err = run(capsys, *ARGS, "-o", tmp_path / "m.vtu")      # capsys' stderr: not a terminal
    assert code == 0 and err == ""
    code, _, err = run(capsys, *ARGS, "--progress", "-o", tmp_path / "m.vtu")
    assert code == 0 and "qmesh mesh:" not in err and err.splitlines()[0].split()[2] == "triangulate"


def test_quiet_on_a_terminal_draws_nothing(tmp_path, capsys, monkeypatch, no_delay):
    tty = Terminal()
    monkeypatch.setattr(sys, "stderr", tty)
    code, _, _ = run(capsys, *ARGS, "--quiet", "-o", tmp_path / "m.vtu")
    assert code == 0 and tty.getvalue() == ""


def test_the_installed_command_draws_the_bar_on_a_pty(tmp_path):
    """The real check tqdm makes (stderr.isatty()) on a pseudo-terminal, in a process of its own."""
    code = ("import sys, qmesh.cli as c; c.BAR.update(delay=0.0, mininterval=0.0); "
            f"sys.exit(c.main({[str(a) for a in ARGS] + ['-o', str(tmp_path / 'm.vtu')]!r}))")
    leader, follower = pty.openpty()
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))   # 24 rows, 100 columns
    done = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=follower)
    os.close(follower)
    err = b""
    while True:
        try:
            chunk = os.read(leader, 65536)
        except OSError:                                   # EIO: the child closed the terminal
            break
        if not chunk:
            break
        err += chunk
    os.close(leader)
    out = done.communicate(timeout=60)[0].decode()
    assert done.wait() == 0 and out.startswith(str(tmp_path / "m.vtu"))
    drawn = stages(err.decode())
    assert drawn and drawn[0].startswith("qmesh mesh: 0 stages") and " N=" in drawn[-1]


def test_progress_says_how_often_a_field_was_evaluated(tmp_path, capsys):
    """The certified line counts the field's evaluations: the points, the calls and the points
    asked for, those of the same run through the API."""
    field = ("--field-Q", "1 + x*x", "0.2*x*y", "1")
    code, _, err = run(capsys, "mesh", *field, "--disk", 24, "--target-vertices", 200,
                       "--progress", "-o", tmp_path / "m.vtu")
    assert code == 0
    last = err.splitlines()[-1]
    assert last.split()[2] == "certified"
    F = qmesh.TensorField.from_expressions(*field[1:])
    qmesh.mesh(qmesh.Disk(24), F, target_vertices=200)
    e = F.evaluations
    assert e.points > 0 and e.calls > 0
    assert last.endswith(f"Q(x) at {e.points} points in {e.calls} calls ({e.asked} asked)")
