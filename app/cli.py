"""`qmesh-view [--host 127.0.0.1] [--port 8080] [--server]`: start the web GUI.

Binds 127.0.0.1 unless told otherwise and opens the system browser unless `--server`.
Sets the off-screen rendering environment of HEADLESS.md before VTK is imported, so the
server-side views render without a display.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile


def headless_environment() -> None:
    """Off-screen EGL rendering, and no attempt to download VTK's WebAssembly build."""
    os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    if "VTK_WASM_DIR_OVERRIDE" not in os.environ:
        os.environ["VTK_WASM_DIR_OVERRIDE"] = tempfile.mkdtemp(prefix="qmesh-view-wasm-")


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="qmesh-view", description=__doc__.splitlines()[0])
    p.add_argument("--host", default="127.0.0.1",
                   help="address to bind (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=int, default=8080, help="port (default 8080; 0 = any free)")
    p.add_argument("--server", action="store_true",
                   help="do not open a browser, only serve")
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    headless_environment()
    from .app import QmeshView          # after the environment: imports VTK

    view = QmeshView()
    # trame re-reads sys.argv for its own options; give it only ours
    sys.argv = [sys.argv[0], "--host", args.host, "--port", str(args.port)] + (
        ["--server"] if args.server else [])
    try:
        view.server.start(host=args.host, port=args.port, open_browser=not args.server,
                          timeout=0)
    finally:
        view.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
