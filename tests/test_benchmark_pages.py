"""The benchmark pages: `benchmarks/report_page.py` writes a page with the command, the machine and
the tables; every benchmark script writes one; the committed pages in docs/benchmarks/ are whole
(one top-level heading, every image they show next to them)."""

import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "benchmarks"
PAGES = ROOT / "docs" / "benchmarks"
sys.path.insert(0, str(BENCHMARKS))

import report_page  # noqa: E402


def _outside_fences(text: str) -> list[str]:
    """The page's lines that are not inside a fenced code block."""
    lines, fence = [], None
    for line in text.splitlines():
        m = re.match(r"^(`{3,}|~{3,})", line)
        if fence is None and m:
            fence = m.group(1)
        elif fence is not None and line.startswith(fence) and not line.strip(fence[0]).strip():
            fence = None
        elif fence is None:
            lines.append(line)
    return lines


def _check_page(path: Path) -> str:
    text = path.read_text(encoding="utf-8")
    lines = _outside_fences(text)
    assert [ln for ln in lines if ln.startswith("# ")] == [lines[0]], "one top-level heading, first"
    for target in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text):
        assert "/" not in target and (path.parent / target).is_file(), target
    assert not re.search(r"<[A-Za-z/!]", "".join(re.sub(r"`[^`]*`|\\<", "", ln) for ln in lines)), \
        "raw HTML"
    return text


def test_report_page_writes_command_machine_and_tables(tmp_path):
    figure = tmp_path / "drawn" / "curve.png"
    figure.parent.mkdir()
    figure.write_bytes(b"\x89PNG\r\n\x1a\n")              # the page only needs the file to exist
    argv = [str(BENCHMARKS / "bench_tiny.py"), "--n", "300", "--label", "a b"]
    path = report_page.write_page(
        BENCHMARKS / "bench_tiny.py", argv, "A tiny benchmark", "What is measured: nothing real.",
        tables=[report_page.Table(["case", "N", "|e|_h1"], [["disk", 301, 0.25], ["L | shape", 298]],
                                  "made-up rows")],
        figures=[report_page.Figure(figure, "a made-up curve")], notes=["A note."],
        output="line one\n```\nline two", out_dir=tmp_path / "pages")
    assert path == tmp_path / "pages" / "bench_tiny.md"
    text = _check_page(path)
    assert text.startswith("# A tiny benchmark\n")
    assert "python benchmarks/bench_tiny.py --n 300 --label 'a b'" in text
    for label in ("CPU", "Cores", "Memory", "OS", "Python", "NumPy", "SciPy", "qmesh", "Date"):
        assert re.search(rf"^\| {label} \| \S", text, re.M), label
    assert "| case | N | \\|e\\|_h1 |" in text
    assert "| disk | 301 | 0.25 |" in text
    assert "| L \\| shape | 298 |  |" in text                  # short rows padded, pipes escaped
    assert "**made-up rows**" in text and "A note." in text
    assert "![a made-up curve](bench_tiny-curve.png)" in text
    assert (tmp_path / "pages" / "bench_tiny-curve.png").read_bytes() == figure.read_bytes()
    assert "````text\nline one\n```\nline two\n````" in text     # the fence outlasts the output's


def test_missing_figure_is_an_error(tmp_path):
    with pytest.raises(FileNotFoundError):
        report_page.write_page("bench_tiny.py", ["bench_tiny.py"], "T", "D",
                               figures=[tmp_path / "absent.png"], out_dir=tmp_path)


MODULES = {"report_page.py", "corners.py"}       # what the scripts import, not benchmarks
SCRIPTS = sorted(p for p in BENCHMARKS.glob("*.py") if p.name not in MODULES)


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_every_benchmark_writes_its_page(script):
    text = script.read_text(encoding="utf-8")
    assert "report_page.write_page(" in text, f"{script.name} writes no docs/benchmarks page"
    assert "report_page.add_option(" in text, f"{script.name} has no --no-page option"
    doc = text.split('"""')[1]
    assert not re.search(r"\bissue \d+|\b20\d\d-\d\d-\d\d\b", doc), "issue numbers or dates"


@pytest.mark.parametrize("page", sorted(p for p in PAGES.glob("*.md") if p.name != "index.md"),
                         ids=lambda p: p.name)
def test_committed_pages_are_whole(page):
    text = _check_page(page)
    assert "**Command**" in text and "| CPU |" in text
    stem = page.stem.split("-")[0]
    assert (BENCHMARKS / f"{stem}.py").is_file(), f"{page.name}: no script {stem}.py"
