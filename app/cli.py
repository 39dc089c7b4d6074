"""`qmesh-view [--host 127.0.0.1] [--port 8080] [--server] [--domain NAME] [--s TEXT] [--memory-budget 4G]`: the web GUI.

NAME is any preset of the domain list: a named shape, a medium (layered, inclusion) or a
conductivity field (rotating, raster).

Binds 127.0.0.1 unless told otherwise and opens the system browser unless `--server`.
Sets the off-screen rendering environment of HEADLESS.md before VTK is imported, so the
server-side views render without a display.
"""

from __future__ import annotations

import argparse
import sys

from qmesh.errors import QmeshError

from .system import headless_environment, require_rendering


UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}


def memory_size(text: str) -> int:
    """"4G", "512M", "1.5G" or a number of bytes → bytes (argparse type)."""
    t = str(text).strip().upper().removesuffix("B").removesuffix("I")
    unit = t[-1:] if t[-1:] in UNITS else ""
    try:
        value = float(t[:len(t) - len(unit)]) * UNITS[unit]
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a memory size: {text!r} (e.g. 4G, 512M)") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"the memory budget must be > 0, got {text!r}")
    return int(value)


def vertex_count(text: str) -> int:
    """An integer, also with an exponent when integral ("2e7") (argparse type)."""
    from .controller import _integer
    try:
        return _integer("the target", text)
    except QmeshError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def run_pause(text: str) -> float:
    """Seconds from 0 to 60 (argparse type)."""
    from .session import check_run_pause
    try:
        return check_run_pause(text)
    except QmeshError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def domain_help() -> str:
    """--domain's help: every preset the viewer offers, by kind, from `problem` itself (the
    named shapes, the media, the fields), so none is left out."""
    from qmesh import domains

    from .problem import DISK, FIELDS, MEDIA

    def quoted(name):
        return f"'{name}'" if " " in name else name
    shapes = ", ".join(quoted(n) + (" (default, with --vb)" if n == DISK else "")
                       for n in domains.NAMED)
    media = ", ".join(quoted(n) for n in MEDIA)
    fields = "; ".join(f"{quoted(n)} ({what})" for n, (_, what) in FIELDS.items())
    return (f"a named domain: {shapes}; a medium (a conductivity per region): {media}; "
            f"a conductivity field Q(x) on the unit square: {fields}")


def target_help() -> str:
    """--target-vertices' help: the chapter's default and the presets' own, from `problem`."""
    from .problem import CHAPTER_TARGET, PRESET_TARGETS
    own = ", ".join(f"{n} {t}" for n, t in PRESET_TARGETS.items())
    return (f"target vertex count N (default {CHAPTER_TARGET}, the chapter's case; the presets "
            f"that need more open with their own: {own})")


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="qmesh-view", description=__doc__.splitlines()[0])
    p.add_argument("--host", default="127.0.0.1",
                   help="address to bind (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=int, default=8080, help="port (default 8080; 0 = any free)")
    p.add_argument("--server", action="store_true",
                   help="do not open a browser, only serve")
    p.add_argument("--views", choices=("remote", "local"), default="remote",
                   help="remote (default): the server renders and sends images; local: the "
                        "browser renders with vtk.js (measured slower: benchmarks/bench_view.py)")
    p.add_argument("--vb", type=int, default=64, help="seed points on the disk (default 64)")
    p.add_argument("--target-vertices", type=vertex_count, default=None, metavar="N",
                   help=target_help())
    p.add_argument("--domain", default="disk", metavar="NAME", help=domain_help())
    p.add_argument("--s", dest="s_text", default=None, metavar="TEXT",
                   help="start with s(x, y) given as text, e.g. 'exp(x) + y**2' "
                        "(default: the constant Q = diag(0.1, 10))")
    p.add_argument("--memory-budget", type=memory_size, default=None, metavar="SIZE",
                   help="memory the server may hold (e.g. 4G, 512M): a request whose whole "
                        "estimated cost (mesher, kept stages, measures, views) would not fit "
                        "beside what the server holds is refused, naming the largest target that "
                        "fits (default: half the memory available when the request is made)")
    p.add_argument("--run-pause", type=run_pause, default=0.0, metavar="SECONDS",
                   help="hold each stage of Run on screen this long, to watch the algorithm "
                        "step by step (default 0: as fast as the mesher goes)")
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    headless_environment()
    try:
        require_rendering()                 # one clear line, not a segfault inside VTK
        from .session import Session        # no VTK, no trame: a bad argument is refused fast
        extra = {} if args.s_text is None else {"q_mode": "expression", "s_text": args.s_text}
        session = Session(vb=args.vb, target_vertices=args.target_vertices, domain=args.domain,
                          memory_budget=args.memory_budget, **extra)
        from .app import QmeshView          # after the environment: imports VTK
        view = QmeshView(view_mode=args.views, session=session, run_pause=args.run_pause)
    except QmeshError as e:
        print(f"qmesh-view: error: {e}", file=sys.stderr)
        return 2
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
