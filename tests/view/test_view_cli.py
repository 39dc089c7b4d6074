"""qmesh-view's command line, and the split between the trame app and the reusable parts."""

import json
import shutil
import subprocess
import sys

import pytest

from qmesh_view.cli import parser


def test_defaults_bind_localhost_and_open_a_browser():
    args = parser().parse_args([])
    assert (args.host, args.port, args.server) == ("127.0.0.1", 8080, False)
    args = parser().parse_args(["--server", "--port", "0", "--host", "0.0.0.0"])
    assert (args.host, args.port, args.server) == ("0.0.0.0", 0, True)


def test_console_script_is_installed_and_answers_help():
    exe = shutil.which("qmesh-view")
    assert exe, "the qmesh-view console script is not installed (pip install -e '.[view]')"
    out = subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0
    for option in ("--host", "--port", "--server"):
        assert option in out.stdout


def test_scene_draw_controller_and_session_do_not_import_trame():
    """The Jupyter widget reuses these modules, so they must not pull in the web server."""
    code = ("import sys, qmesh_view.scene, qmesh_view.draw, qmesh_view.controller, "
            "qmesh_view.session; "
            "bad = sorted(m for m in sys.modules if m.split('.')[0] in ('trame', 'wslink')); "
            "print(bad); sys.exit(1 if bad else 0)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr


def test_views_default_to_remote_and_parameters_can_be_given():
    args = parser().parse_args([])
    assert (args.views, args.vb, args.target_vertices) == ("remote", 64, None)  # the domain's
    args = parser().parse_args(["--views", "local", "--vb", "128", "--target-vertices", "1000"])
    assert (args.views, args.vb, args.target_vertices) == ("local", 128, 1000)


def test_memory_budget_option_reads_sizes_and_refuses_nonsense():
    import pytest
    from qmesh_view.cli import memory_size
    assert parser().parse_args([]).memory_budget is None
    assert parser().parse_args(["--memory-budget", "4G"]).memory_budget == 4 * 2**30
    assert memory_size("512M") == memory_size("512MiB") == 512 * 2**20
    assert memory_size("1.5g") == int(1.5 * 2**30) and memory_size("1000") == 1000
    for bad in ("-1G", "0", "lots", "infG"):
        with pytest.raises(SystemExit):
            parser().parse_args([f"--memory-budget={bad}"])


def test_run_pause_reads_seconds_and_refuses_nonsense():
    assert parser().parse_args([]).run_pause == 0.0
    assert parser().parse_args(["--run-pause", "0.5"]).run_pause == 0.5
    for bad in ("-1", "nan", "61", "slow", "inf"):
        with pytest.raises(SystemExit):
            parser().parse_args([f"--run-pause={bad}"])


def test_domain_and_s_options():
    args = parser().parse_args(["--domain", "L-shape", "--s", "exp(x) + y**2"])
    assert (args.domain, args.s_text) == ("L-shape", "exp(x) + y**2")
    assert parser().parse_args([]).s_text is None


BAD = ((["--vb", "2"], "3"), (["--domain", "torus"], "torus"),
       (["--s", "__import__('os')"], "__import__"),
       (["--target-vertices", "1000", "--memory-budget", "10M"], "budget"))

REFUSE_ALL = """
import contextlib, io, json, sys
from qmesh_view.cli import main
out = []
for bad in json.loads(sys.argv[1]):
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["--server", "--port", "0", *bad])
    out.append([code, err.getvalue()])
loaded = sorted({m.split(".")[0] for m in sys.modules} & {"vtkmodules", "pyvista", "trame"})
from qmesh.errors import QmeshError
from qmesh_view.app import QmeshView
from qmesh_view.session import Session
try:
    QmeshView(session=Session(), vb=12)                  # a session or its parameters, not both
    both = "accepted"
except QmeshError as e:
    both = str(e)
print(json.dumps([out, loaded, both]))
"""


def test_bad_parameters_give_one_error_line_and_exit_2_before_vtk_or_trame_load():
    """The console script exits 2 with one line; every bad kind is refused by the session's
    checks before the viewer imports VTK and trame (so in well under a second)."""
    out = subprocess.run([shutil.which("qmesh-view"), "--server", "--port", "0", *BAD[0][0]],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and out.stderr.startswith("qmesh-view: error: "), out.stderr
    run = subprocess.run([sys.executable, "-c", REFUSE_ALL, json.dumps([b for b, _ in BAD])],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    results, loaded, both = json.loads(run.stdout)
    for (bad, named), (code, err) in zip(BAD, results):
        lines = err.strip().splitlines()
        assert code == 2 and len(lines) == 1, (bad, err)
        assert lines[0].startswith("qmesh-view: error: ") and named in lines[0], lines[0]
    assert loaded == [], f"refusing bad arguments imported {loaded}"
    assert "either a session or the parameters" in both
