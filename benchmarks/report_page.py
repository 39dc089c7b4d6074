"""Write one benchmark's Markdown page into docs/benchmarks/.

Every script of benchmarks/ ends its run with `write_page`: the page holds what the script
measures, the exact command that made it, the machine it ran on (CPU, cores, memory, OS, Python,
NumPy, SciPy, qmesh's commit), the date and length of the run, its tables and its figures. The
pages are MyST Markdown for the Sphinx site: one top-level heading, GitHub-style tables, images
referenced by a path relative to the page (the figure files live next to it), no raw HTML.

    from report_page import Table, write_page
    write_page(__file__, sys.argv, "Title", "What is measured.",
               tables=[Table(["N", "κ2"], [[212, 14.1]])], figures=[path_to_png])

Scripts import this module before they start measuring: the run's start time is taken then.
"""

from __future__ import annotations

import contextlib
import datetime
import os
import platform
import re
import shlex
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

REPO = Path(__file__).resolve().parent.parent
DOCS = REPO / "docs" / "benchmarks"
"""Where the pages and their figures go (docs/benchmarks/)."""

_STARTED = (time.time(), time.perf_counter(), os.getloadavg()[0] if hasattr(os, "getloadavg") else None)


@dataclass
class Table:
    """A Markdown table: header cells, rows of cells (anything str() can show), an optional
    caption printed in bold above it."""
    headers: Sequence[str]
    rows: Sequence[Sequence[object]] = field(default_factory=list)
    caption: str = ""


@dataclass
class Figure:
    """An image file (PNG/SVG) the script drew, and its caption (the image's alt text)."""
    path: Path | str
    caption: str = ""


def page_path(script: str | Path, out_dir: Path | str | None = None, suffix: str = "") -> Path:
    """docs/benchmarks/<script stem>[-suffix].md (or the same name in out_dir)."""
    stem = Path(script).stem + (f"-{suffix}" if suffix else "")
    return Path(out_dir if out_dir is not None else DOCS) / f"{stem}.md"


def figure_path(script: str | Path, name: str, out_dir: Path | str | None = None) -> Path:
    """Where a script saves a figure so the page can show it: <stem>-<name> next to the page."""
    directory = Path(out_dir if out_dir is not None else DOCS)
    directory.mkdir(parents=True, exist_ok=True)
    return directory / f"{Path(script).stem}-{name}"


# ---------------------------------------------------------------------------------------- text

_CODE_SPAN = re.compile(r"(`[^`]*`)")


def escape_cell(value: object) -> str:
    """One table cell: no line breaks; `|` escaped everywhere (GitHub tables split on it before
    code spans are read); outside code spans `<` (so nothing reads as raw HTML) and `$` (so
    nothing reads as MyST's dollar math) escaped."""
    text = " ".join(str(value).split())
    parts = _CODE_SPAN.split(text)
    out = []
    for i, part in enumerate(parts):
        if i % 2 == 0:
            part = re.sub(r"(?<!\\)([<$])", r"\\\1", part)
        out.append(re.sub(r"(?<!\\)\|", r"\\|", part))
    return "".join(out)


def markdown_table(headers: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A GitHub-style Markdown table; every row padded or cut to the header's width."""
    width = len(headers)
    lines = ["| " + " | ".join(escape_cell(h) for h in headers) + " |",
             "|" + "---|" * width]
    for row in rows:
        cells = [escape_cell(c) for c in list(row)[:width]]
        cells += [""] * (width - len(cells))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _fence(text: str, info: str = "text") -> str:
    """A fenced code block that no backtick run inside `text` can close early."""
    longest = max((len(m) for m in re.findall(r"`+", text)), default=0)
    ticks = "`" * max(3, longest + 1)
    return f"{ticks}{info}\n{text.rstrip()}\n{ticks}"


def command_line(argv: Sequence[str]) -> str:
    """`python <script> <args>` as typed, the script's path relative to the repository when it
    lies inside it (so the command can be pasted from the repository's root)."""
    argv = [str(a) for a in argv]
    if not argv:
        return "python"
    script = Path(argv[0])
    try:
        script = script.resolve().relative_to(REPO)
    except (ValueError, OSError):
        pass
    return "python " + shlex.join([script.as_posix(), *argv[1:]])


# ------------------------------------------------------------------------------------- machine

def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key.strip() in ("model name", "Model", "Hardware", "cpu model"):
                    return value.strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def _memory() -> str:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    return f"{int(line.split()[1]) / 1024 ** 2:.1f} GiB"
    except OSError:
        pass
    return "unknown"


def _os() -> str:
    try:
        with open("/etc/os-release") as f:
            info = dict(line.rstrip("\n").split("=", 1) for line in f if "=" in line)
        name = info.get("PRETTY_NAME", "").strip('"')
    except OSError:
        name = ""
    kernel = f"{platform.system()} {platform.release()}"
    return f"{name}, {kernel}" if name else kernel


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(["git", "-C", str(REPO), *args], capture_output=True, text=True,
                             timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def _commit() -> str:
    head = _git("rev-parse", "--short=10", "HEAD")
    if not head:
        return "unknown (not a git checkout)"
    dirty = _git("status", "--porcelain", "--", "qmesh", "app")
    return head + (" (with uncommitted changes in qmesh/ or app/)" if dirty else "")


def _version(module: str) -> str:
    try:
        return __import__(module).__version__
    except Exception:                                          # noqa: BLE001 — any import failure
        return "not installed"


def machine() -> dict[str, str]:
    """The machine and software a run used, as label → text."""
    cores = os.cpu_count() or 0
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else cores
    return {
        "CPU": _cpu_model(),
        "Cores": f"{cores} logical" + (f" ({usable} usable by this process)" if usable != cores else ""),
        "Memory": _memory(),
        "OS": _os(),
        "Python": f"{platform.python_implementation()} {platform.python_version()}",
        "NumPy": _version("numpy"),
        "SciPy": _version("scipy"),
        "qmesh": f"{_version('qmesh')}, commit {_commit()}",
    }


def run_info(now: float | None = None) -> dict[str, str]:
    """The run's date (UTC), its wall time since this module was imported, the load average."""
    start, t0, load = _STARTED
    info = {"Date": datetime.datetime.fromtimestamp(start, datetime.timezone.utc)
            .strftime("%Y-%m-%d %H:%M UTC"),
            "Wall time": f"{(time.perf_counter() if now is None else now) - t0:.0f} s"}
    if load is not None:
        info["Load average"] = f"{load:.2f} (1 min, at the start; other processes share the cores)"
    return info


# ---------------------------------------------------------------------------------------- page

def write_page(script: str | Path, argv: Sequence[str], title: str, description: str,
               tables: Sequence[Table] = (), figures: Sequence[Figure | Path | str] = (),
               notes: Sequence[str] = (), output: str = "", out_dir: Path | str | None = None,
               suffix: str = "") -> Path:
    """Write the page of one run and return its path.

    script: the benchmark's file (its stem names the page); argv: the exact command line
    (sys.argv); title: the page's only top-level heading; description: what is measured
    (Markdown); tables: the results; figures: image files, copied next to the page unless they
    are there already; notes: short Markdown paragraphs after the tables (summaries); output:
    console text shown verbatim; suffix: a second page for another mode of the same script.
    """
    path = page_path(script, out_dir, suffix)
    path.parent.mkdir(parents=True, exist_ok=True)
    title = " ".join(title.split())
    parts = [f"# {title}", description.strip(),
             "**Command** (from the repository's root)", _fence(command_line(argv), "text"),
             "**Run**", markdown_table(["", ""], list(run_info().items())),
             "**Machine**", markdown_table(["", ""], list(machine().items()))]
    for table in tables:
        if table.caption:
            parts.append(f"**{' '.join(table.caption.split())}**")
        parts.append(markdown_table(table.headers, table.rows))
    parts += [n.strip() for n in notes if n.strip()]
    if output.strip():
        parts += ["**Console output**", _fence(output)]
    for fig in figures:
        fig = fig if isinstance(fig, Figure) else Figure(fig)
        src = Path(fig.path)
        if not src.is_file():
            raise FileNotFoundError(f"figure {src} was not written")
        dst = src if src.resolve().parent == path.parent.resolve() else \
            path.parent / f"{Path(script).stem}-{src.name}"
        if dst != src:
            shutil.copyfile(src, dst)
        alt = " ".join((fig.caption or dst.stem).replace("[", "(").replace("]", ")").split())
        parts.append(f"![{alt}]({dst.name})")
    path.write_text("\n\n".join(p for p in parts if p) + "\n", encoding="utf-8")
    print(f"page: {path.relative_to(REPO) if path.is_relative_to(REPO) else path}", file=sys.stderr)
    return path


class _Tee:
    def __init__(self, stream):
        self.stream, self.parts = stream, []

    def write(self, text):
        self.parts.append(text)
        return self.stream.write(text)

    def flush(self):
        self.stream.flush()

    def __getattr__(self, name):
        return getattr(self.stream, name)


@contextlib.contextmanager
def capture():
    """Within the block, what the script prints still goes to the console and is also kept:
    `with capture() as out: ...; out()` is the text printed so far."""
    tee, saved = _Tee(sys.stdout), sys.stdout
    sys.stdout = tee
    try:
        yield lambda: "".join(tee.parts)
    finally:
        sys.stdout = saved


def add_option(parser) -> None:
    """--no-page on a script's argparse parser."""
    parser.add_argument("--no-page", action="store_true",
                        help="print only; do not write docs/benchmarks/<script>.md")
