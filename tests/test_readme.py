"""README.md and the user's guide (docs/guide/*.md) match the code: their snippets run, and the
outputs their comments claim come out.

- Each page's ```python and ```sh blocks run in the order the page gives them, in one temporary
  folder per page (a file one block writes, the next may read), with `examples` linked there so
  that commands run as from the repository's root.
- A ```python block runs as a script. A top-level `print(...)` with a comment is a claim: the
  printed line must match the comment, numbers to the digits the comment gives, words exactly;
  text after the printed part must start with ";" (an explanation). The scripts run with the
  headless rendering variables of HEADLESS.md (the widget's block).
- A ```sh block runs line by line, each `&&` part on its own; a comment after a command lists
  fragments (separated by " … ") that must appear in its output, in order. Skipped for cost,
  with the reason (nothing else is skipped):
    * `python3 -m venv .venv`, `. .venv/bin/activate`: make and enter the virtual environment
      these tests already run in;
    * `pip install -e ".[io,view]"`, `pip install -e ".[test]"`: minutes of downloads; the tests
      run in their result;
    * `python -m pytest -q -n auto --dist worksteal`: this test suite itself.
  `qmesh setup` (and `qmesh setup --test`) runs with `--check` (a test must not install system
  packages; a missing package fails it just the same).
- Claims are deterministic outputs only — vertex counts, tags, names, shares of q_ij ≥ 0 — never
  a time; `.ci/run` holds exactly the README's two Set-up commands, the first installing the
  main job's extras only and the second the test suite's; the mesh files the commands
  write are ignored by git; what the pages and `qmesh mesh --help` say about `target_vertices`
  holds.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import qmesh

ROOT = Path(__file__).resolve().parents[1]
PAGES = ["README.md"] + sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs" / "guide").glob("*.md"))
TEXT = {page: (ROOT / page).read_text() for page in PAGES}
README = TEXT["README.md"]
BIN = Path(sys.executable).parent
SKIPPED_FOR_COST = ("python3 -m venv .venv", ". .venv/bin/activate", 'pip install -e ".[io,view]"',
                    'pip install -e ".[test]"', "python -m pytest -q -n auto --dist worksteal")
HEADLESS = {"PYVISTA_OFF_SCREEN": "true", "VTK_DEFAULT_OPENGL_WINDOW": "vtkEGLRenderWindow"}
NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?")
FENCE = re.compile(r"^```(\S*)\n(.*?)^```", flags=re.S | re.M)


def fenced(page: str) -> list[tuple[str, str]]:
    """(language, code) of every fenced block of a page, in order."""
    return FENCE.findall(TEXT[page])


def blocks(language: str, pages=PAGES) -> list[str]:
    return [code for page in pages for lang, code in fenced(page) if lang == language]


def setup_commands() -> list[str]:
    section = README[README.index("## Set-up"):README.index("## The API")]
    return re.search(r"```sh\n(.*?)```", section, flags=re.S).group(1).strip().splitlines()


def environment(**extra) -> dict:
    return dict(os.environ, PATH=f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}", **extra)


def matches(claim: str, printed: str) -> bool:
    """The printed line equals the claim: numbers rounded to the claim's digits, words exactly;
    the claim may go on after the printed text with '; …' (an explanation)."""
    pos = 0
    for token in re.split(rf"({NUMBER.pattern})", printed.strip()):
        if not token:
            continue
        if NUMBER.fullmatch(token):
            m = NUMBER.match(claim, pos)
            if not m:
                return False
            text = m.group()
            digits = len(text.split(".")[1]) if "." in text and "e" not in text else 0
            if round(float(token), digits) != float(text):
                return False
            pos = m.end()
        else:
            if not claim.startswith(token, pos):
                return False
            pos += len(token)
    rest = claim[pos:].strip()
    return rest == "" or rest.startswith(";")


def test_matches_rounds_to_the_claims_digits():
    assert matches("11.46; also more", "11.4623")
    assert not matches("11.47", "11.4623")
    assert matches("(212, 2) (314, 3) 64", "(212, 2) (314, 3) 64")
    assert not matches("(212, 2) (314, 3) 64", "(212, 2) (316, 3) 64")
    assert not matches("114 0 extra words", "114 0")


def instrument(code: str) -> tuple[str, dict[int, str]]:
    """Tag each claimed print so its output line can be found; return the claims by tag."""
    claims, lines = {}, []
    for i, line in enumerate(code.splitlines()):
        m = re.match(r"^(\s*)print\((.*)\)\s+#\s?(.*)$", line)
        if m:
            assert m.group(1) == "", f"a claim inside a block cannot be checked: {line!r}"
            claims[i] = m.group(3)
            line = f'print("@@{i}@@", {m.group(2)})'
        lines.append(line)
    return "\n".join(lines) + "\n", claims


def shell_lines(code: str):
    """(the line's commands to run, the fragments its comment claims) for each line of a block."""
    for line in code.strip().splitlines():
        command, _, comment = line.partition("   # ")
        parts = [p.strip() for p in command.split(" && ")]
        run = [p + (" --check" if p.startswith("qmesh setup") and "--check" not in p else "")
               for p in parts if p not in SKIPPED_FOR_COST]
        yield line, run, [f.strip() for f in comment.split("…") if f.strip()]


def claims_of(page: str) -> list[str]:
    said = [c for lang, code in fenced(page) if lang == "python" for c in instrument(code)[1].values()]
    said += [" … ".join(f) for lang, code in fenced(page) if lang == "sh" for _, _, f in shell_lines(code)]
    return said


def test_every_fenced_block_is_run_or_plain_text():
    """A ```python or ```sh block is run by the tests below; ```text is shown only; the guide may
    use MyST directives (```{math}, ```{toctree}…). Any other language (bash, console, none…)
    would be neither run nor checked."""
    for page in PAGES:
        languages = {lang for lang, _ in fenced(page)}
        allowed = {"python", "sh", "text"}
        assert {lang for lang in languages if not lang.startswith("{")} <= allowed, (page, languages)
        assert page != "README.md" or all(not lang.startswith("{") for lang in languages)


def test_the_pages_have_the_snippets_this_module_expects():
    assert len(blocks("python", ["README.md"])) >= 4 and len(blocks("sh", ["README.md"])) >= 2
    assert sum(len(instrument(b)[1]) for b in blocks("python", ["README.md"])) >= 5
    assert len(PAGES) >= 8 and sum(len(claims_of(p)) for p in PAGES) >= 25


@pytest.mark.parametrize("page", PAGES)
def test_claims_are_deterministic(page):
    """No timing or other run-to-run number is claimed (those live in the benchmark pages)."""
    for claim in claims_of(page):
        assert not re.search(r"time=|seconds|\d s\b|\bs/it\b|load average", claim), (page, claim)


def test_readme_is_a_users_guide():
    assert len(README.splitlines()) <= 250


def run_python(code: str, folder: Path) -> None:
    script, claims = instrument(code)
    (folder / "snippet.py").write_text(script)
    wasm = folder / "wasm"              # an empty folder: trame-vtklocal downloads nothing
    wasm.mkdir(exist_ok=True)
    done = subprocess.run([sys.executable, "snippet.py"], cwd=folder, capture_output=True, text=True,
                          timeout=300, env=environment(VTK_WASM_DIR_OVERRIDE=str(wasm), **HEADLESS))
    first = code.strip().splitlines()[0]
    assert done.returncode == 0, f"the block starting {first!r} failed:\n{done.stderr[-3000:]}"
    printed = {int(m.group(1)): m.group(2) for m in re.finditer(r"^@@(\d+)@@ (.*)$", done.stdout, flags=re.M)}
    for i, claim in claims.items():
        assert i in printed, f"line {i} of the block starting {first!r} printed nothing"
        assert matches(claim, printed[i]), f"the page claims {claim!r}, the code printed {printed[i]!r}"


def run_shell(code: str, folder: Path) -> None:
    for line, commands, fragments in shell_lines(code):
        output = ""
        for command in commands:
            done = subprocess.run(["bash", "-c", command], cwd=folder, capture_output=True, text=True,
                                  timeout=300, env=environment())
            assert done.returncode == 0, f"{command!r} failed:\n{done.stderr[-3000:]}"
            output += done.stdout + done.stderr
            for out in re.findall(r"-o (\S+)", command) if "||" not in command else []:
                assert (folder / out).stat().st_size > 0, f"{command!r} wrote no {out}"
        pos = 0
        for fragment in fragments:
            found = output.find(fragment, pos)
            assert found >= 0, f"{fragment!r} not in the output of {line!r}:\n{output}"
            pos = found + len(fragment)


@pytest.mark.parametrize("page", [p for p in PAGES if any(lang in ("python", "sh") for lang, _ in fenced(p))])
def test_page_snippets_run_and_print_what_they_claim(page, tmp_path):
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    for lang, code in fenced(page):
        if lang == "python":
            run_python(code, tmp_path)
        elif lang == "sh":
            run_shell(code, tmp_path)


def test_only_the_costly_commands_are_skipped():
    parts = [p.strip() for b in blocks("sh") for line in b.strip().splitlines()
             for p in line.partition("   # ")[0].split(" && ")]
    commands = [c for b in blocks("sh") for _, cs, _ in shell_lines(b) for c in cs]
    assert set(parts) & set(SKIPPED_FOR_COST) == set(SKIPPED_FOR_COST)
    assert len(commands) == len([p for p in parts if p not in SKIPPED_FOR_COST])
    assert "qmesh setup --check" in commands and "qmesh setup --test --check" in commands
    assert "qmesh setup" not in commands and "qmesh setup --test" not in commands


def test_ci_runs_exactly_the_readme_commands():
    """.ci/run may not install anything the README's two commands do not."""
    ci = (ROOT / ".ci" / "run").read_text()
    commands = [ln.strip() for ln in ci.splitlines()
                if ln.strip() and not ln.lstrip().startswith(("#", "set ", "cd ", "status=", "if ",
                                                             "echo", "fi", "exit", "||"))]
    first, second = setup_commands()
    assert commands[0].removesuffix("\\").strip() == first
    assert commands[1].removesuffix("|| status=$?").strip() == second
    assert len(commands) == 2, commands


def extras() -> dict[str, set[str]]:
    """pyproject.toml's extras, each as the set of distribution names it installs, qmesh[...]
    references followed."""
    try:
        import tomllib
    except ImportError:                       # Python < 3.11
        tomllib = pytest.importorskip("tomli")
    table = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]

    def names(extra: str) -> set[str]:
        out = set()
        for requirement in table[extra]:
            name = re.match(r"[A-Za-z0-9_.-]+", requirement).group().lower()
            if name == "qmesh":
                for inner in re.search(r"\[(.*)\]", requirement).group(1).split(","):
                    out |= names(inner.strip())
            else:
                out.add(name)
        return out
    return {extra: names(extra) for extra in table}


def installed_by(command: str) -> set[str]:
    """The distributions a set-up command's `pip install -e ".[...]"` asks for."""
    table = extras()
    asked = re.search(r'pip install -e "\.\[([^\]]*)\]"', command).group(1).split(",")
    return set().union(*(table[extra] for extra in asked))


def test_the_first_command_installs_the_main_job_only():
    """Files and the viewer; no test, docs, peer, FEM or notebook package, no browser driver."""
    first, second = setup_commands()
    light = installed_by(first)
    assert {"meshio", "pyvista", "trame"} <= light
    assert not light & {"pytest", "hypothesis", "mypy", "playwright", "jupyterlab", "ipykernel",
                        "nbclient", "sphinx", "gmsh", "mmgpy", "ngsolve", "scikit-fem", "triangle",
                        "ipywidgets", "dask"}, light
    assert "qmesh setup &&" in first and "--test" not in first


def test_the_second_command_installs_what_the_tests_use():
    """Every extra but DOLFINx's (its wheels need Python >= 3.12), and the test tools."""
    first, second = setup_commands()
    table, full = extras(), installed_by(second)
    assert set().union(*(names for extra, names in table.items() if extra != "fem-dolfinx")) <= full
    assert {"pytest", "playwright", "sphinx", "sphinx-mathjax-offline", "gmsh", "ngsolve"} <= full
    assert "qmesh setup --test &&" in second and second.endswith("python -m pytest -q -n auto --dist worksteal")


@settings(max_examples=12, deadline=None, derandomize=True)
@given(vb=st.sampled_from([8, 16, 32, 64, 128]), extra=st.integers(1, 600),
       k1=st.floats(0.01, 100), k2=st.floats(0.01, 100), angle=st.floats(0, 180))
def test_target_vertices_is_met_or_refused(vb, extra, k1, k2, angle):
    """The guide and `qmesh mesh --help`: N ends on the target or a few percent above; a miss
    by more than 10% is a QmeshError that names the target."""
    import warnings
    target = vb + extra
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        try:
            m = qmesh.mesh(qmesh.Disk(vb), qmesh.Anisotropy.principal(k1, k2, angle),
                           target_vertices=target)
        except qmesh.QmeshError as e:
            assert f"target_vertices = {target}" in str(e)
            return
    assert target <= m.n_vertices <= 1.1 * target
    assert np.all(m.fixed[:vb])


def test_mesh_help_says_what_the_guide_says():
    done = subprocess.run([sys.executable, "-m", "qmesh", "mesh", "--help"], capture_output=True,
                          text=True, env=environment(COLUMNS="200"))
    text = " ".join(done.stdout.split())
    said = "the mesh ends on N, or near it where keeping q_ij >= 0 on the boundary needs more vertices"
    assert f"--target-vertices N aim for N vertices: {said}" in text
    assert said.replace("q_ij >= 0", "`q_ij ≥ 0`") in " ".join(TEXT["docs/guide/cli.md"].split())


def test_files_the_commands_write_are_ignored_by_git():
    """Run from the repository root, the pages' commands leave no mesh file for `git status`."""
    text = "".join(blocks("sh") + blocks("python"))
    outputs = sorted(set(re.findall(r"-o (\S+\.(?:vtu|vtk|msh|xdmf|mesh|obj))\b", text)
                         + re.findall(r'io\.write\("([^"]+)"', text)))
    assert "disk64.vtu" in outputs and "chapter.msh" in outputs
    done = subprocess.run(["git", "check-ignore", *outputs], cwd=ROOT, capture_output=True, text=True)
    assert sorted(done.stdout.split()) == outputs


def _synopsis(page: str, command: str) -> str:
    """The ```text block of `page` that gives `command`'s synopsis."""
    found = [code for lang, code in fenced(page) if lang == "text" and code.startswith(command + " ")]
    assert found, f"{page} has no synopsis of {command}"
    return found[0]


def _named(option: str, text: str) -> bool:
    return re.search(rf"(?<![\w-]){re.escape(option)}(?![\w-])", text) is not None


def _parsers():
    """(command, page, parser) for every subcommand of `qmesh` and for `qmesh-view`."""
    import argparse

    from qmesh.cli import build_parser
    from qmesh_view.cli import parser as view_parser
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return ([(f"qmesh {name}", "docs/guide/cli.md", p) for name, p in sub.choices.items()]
            + [("qmesh-view", "docs/guide/viewer.md", view_parser())])


def test_every_option_of_every_command_is_in_its_synopsis():
    """The guide's synopses are checked against the argparse parsers: every option (one of its
    spellings), its metavar and every positional argument of each command."""
    missing = []
    for command, page, parser in _parsers():
        text = _synopsis(page, command)
        for action in parser._actions:
            if "-h" in action.option_strings:
                continue
            names = action.option_strings or [action.metavar or action.dest]
            if not any(_named(n, text) for n in names):
                missing.append(f"{command} {names[0]}")
            metavar = action.metavar if action.option_strings and action.choices is None else None
            for word in ([metavar] if isinstance(metavar, str) else metavar or []):
                if not _named(word, text):
                    missing.append(f"{command} {names[0]} {word}")
    assert missing == []


def test_the_viewer_page_names_every_domain_preset():
    from qmesh import domains
    from qmesh_view.problem import FIELDS, MEDIA
    page = TEXT["docs/guide/viewer.md"]
    start = page.index("`--domain`")
    text = " ".join(page[start:page.index("\n\n", start)].split())       # the option's paragraph
    presets = [*domains.NAMED, *MEDIA, *FIELDS]
    assert "rotating" in presets and [n for n in presets if f"`{n}`" not in text] == []
