"""The code, the README and the guide say what is true now, not when or on which ticket it became
so: no date, issue number or load average in `qmesh/`, `app/`, README.md or the docs written by
hand, and no issue number in the tests (history goes to CHANGELOG.md, measured figures to the
generated benchmark pages in docs/benchmarks/)."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

HISTORY = {
    "a date": re.compile(r"\b(?:19|20)\d{2}-\d{2}-\d{2}\b"),
    "an issue number": re.compile(r"\b[Ii]ssues? ?(?:no\.? ?)?#?\d+"),
    "a load average": re.compile(r"\bload ?average|\bload(?:avg)? (?:of )?\d+(?:\.\d+)?\b"),
}
TEXT = {".py", ".md", ".txt", ".json", ".toml", ".cfg", ".ini", ".js", ".css", ".html", ".vue"}


def findings(text: str) -> list[tuple[int, str, str]]:
    """(line number, what, the line) for every line of `text` that matches a pattern."""
    return [(n, what, line.strip()) for n, line in enumerate(text.splitlines(), start=1)
            for what, pattern in HISTORY.items() if pattern.search(line)]


def files(target: str) -> list[Path]:
    path = ROOT / target
    if path.is_file():
        return [path]
    return sorted(p for p in path.rglob("*") if p.is_file() and p.suffix in TEXT
                  and "__pycache__" not in p.parts)


@pytest.mark.parametrize("text, found", [
    ("measured 2026-11-23 on the dev machine", "a date"),
    ("the wait cut (issue 12)", "an issue number"),
    ("see Issue #7", "an issue number"),
    ("median of 5 clicks, load 2.5-4.6 on 2 cores", "a load average"),
    ("with the load average at 3", "a load average"),
])
def test_the_patterns_catch_history(text, found):
    assert [what for _, what, _ in findings(text)] == [found]


@pytest.mark.parametrize("text", [
    "Glickenstein 2007", "(2.94) metric quality", "issue a QmeshWarning", "loads the file",
    "Disk(30000) with Q = I", "read 2 files, load them",
])
def test_the_patterns_let_plain_text_pass(text):
    assert findings(text) == []


@pytest.mark.parametrize("target", ["qmesh", "app", "README.md", "docs/index.md", "docs/guide",
                                    "docs/design"])
def test_no_dates_issue_numbers_or_load_averages(target):
    found = [f"{path.relative_to(ROOT).as_posix()}:{n}: {what}: {line[:100]}"
             for path in files(target) for n, what, line in findings(path.read_text(encoding="utf-8"))]
    assert not found, "history belongs in CHANGELOG.md, figures in the benchmark pages:\n" + "\n".join(found)


def test_no_issue_numbers_in_the_tests():
    """A test says what it checks; which ticket asked for it is history (this file's own
    examples excepted)."""
    found = [f"{path.relative_to(ROOT).as_posix()}:{n}: {line[:100]}"
             for path in files("tests") if path.name != Path(__file__).name
             for n, what, line in findings(path.read_text(encoding="utf-8")) if what == "an issue number"]
    assert not found, "\n".join(found)
