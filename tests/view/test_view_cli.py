"""qmesh-view's command line, and the split between the trame app and the reusable parts."""

import shutil
import subprocess
import sys

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


def test_scene_draw_and_controller_do_not_import_trame():
    """The Jupyter widget reuses these modules, so they must not pull in the web server."""
    code = ("import sys, qmesh_view.scene, qmesh_view.draw, qmesh_view.controller; "
            "bad = sorted(m for m in sys.modules if m.split('.')[0] in ('trame', 'wslink')); "
            "print(bad); sys.exit(1 if bad else 0)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
