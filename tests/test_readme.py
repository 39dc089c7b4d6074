"""README.md matches the code: its snippets run, and the numbers its comments claim come out.

- Every ```python block runs as a script in a temporary folder. A top-level `print(...)` with a
  comment is a claim: the printed line must match the comment, numbers to the digits the comment
  gives, words exactly; text after the printed part must start with ";" (an explanation).
  The widget block runs with the headless rendering variables of HEADLESS.md.
- Every ```sh block is run line by line, each `&&` part on its own, in a temporary folder; a
  comment after a command lists fragments (separated by " … ") that must appear in its output, in
  order. Skipped for cost, with the reason (nothing else is skipped):
    * `python3 -m venv .venv`, `. .venv/bin/activate`: make and enter the virtual environment
      these tests already run in;
    * `pip install -e ".[all,peers,test]"`: minutes of downloads; the tests run in its result;
    * `python -m pytest -q -n auto --maxschedchunk 2`: this test suite itself.
  `qmesh setup` runs as `qmesh setup --check` (a test must not install system packages; a
  missing package fails it just the same).
- `.ci/run` holds exactly the README's two Set-up commands; the files the commands write are
  ignored by git; what the README and `qmesh mesh --help` say about `target_vertices` holds.
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
README = (ROOT / "README.md").read_text()
BIN = Path(sys.executable).parent
SKIPPED_FOR_COST = ("python3 -m venv .venv", ". .venv/bin/activate", 'pip install -e ".[all,peers,test]"',
                    "python -m pytest -q -n auto --maxschedchunk 2")
HEADLESS = {"PYVISTA_OFF_SCREEN": "true", "VTK_DEFAULT_OPENGL_WINDOW": "vtkEGLRenderWindow"}
NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def blocks(language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", README, flags=re.S | re.M)


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


PYTHON_BLOCKS = blocks("python")


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


def test_every_fenced_block_is_run_or_plain_text():
    """A ```python or ```sh block is run by the tests below; ```text is shown only. Any other
    language (bash, console, none…) would be neither run nor checked."""
    languages = re.findall(r"^```(\S*)\n.*?^```", README, flags=re.S | re.M)
    assert set(languages) <= {"python", "sh", "text"}, languages


def test_readme_has_the_snippets_this_module_expects():
    assert len(PYTHON_BLOCKS) >= 3 and len(blocks("sh")) >= 2
    assert sum(len(instrument(b)[1]) for b in PYTHON_BLOCKS) >= 4


@pytest.mark.parametrize("index", range(len(PYTHON_BLOCKS)))
def test_python_snippet_runs_and_prints_what_it_claims(index, tmp_path):
    code, claims = instrument(PYTHON_BLOCKS[index])
    script = tmp_path / "snippet.py"
    script.write_text(code)
    wasm = tmp_path / "wasm"            # an empty folder: trame-vtklocal downloads nothing
    wasm.mkdir()
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300,
                          env=environment(VTK_WASM_DIR_OVERRIDE=str(wasm), **HEADLESS))
    assert done.returncode == 0, done.stderr[-3000:]
    printed = {int(m.group(1)): m.group(2)
               for m in re.finditer(r"^@@(\d+)@@ (.*)$", done.stdout, flags=re.M)}
    for i, claim in claims.items():
        assert i in printed, f"line {i} printed nothing"
        assert matches(claim, printed[i]), f"README claims {claim!r}, the code printed {printed[i]!r}"


def shell_commands():
    for block in blocks("sh"):
        for line in block.strip().splitlines():
            command, _, comment = line.partition("   # ")
            for part in command.split(" && "):
                part = part.strip()
                if part not in SKIPPED_FOR_COST:
                    yield part + (" --check" if part == "qmesh setup" else ""), comment.strip()


SHELL_COMMANDS = list(shell_commands())


def test_every_readme_command_is_run_or_skipped_for_a_stated_cost():
    every = {p.strip() for b in blocks("sh") for line in b.strip().splitlines()
             for p in line.partition("   # ")[0].split(" && ")}
    assert every - set(SKIPPED_FOR_COST) == {c.removesuffix(" --check") for c, _ in SHELL_COMMANDS}
    assert "qmesh setup --check" in {c for c, _ in SHELL_COMMANDS}


@pytest.mark.parametrize("command, claim", SHELL_COMMANDS, ids=[c for c, _ in SHELL_COMMANDS])
def test_shell_command_runs_and_prints_what_it_claims(command, claim, tmp_path):
    done = subprocess.run(["bash", "-c", command], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300, env=environment())
    assert done.returncode == 0, done.stderr[-3000:]
    output, pos = done.stdout + done.stderr, 0
    for fragment in filter(None, (f.strip() for f in claim.split("…"))):
        found = output.find(fragment, pos)
        assert found >= 0, f"{fragment!r} not in the output of {command!r}:\n{output}"
        pos = found + len(fragment)
    for out in re.findall(r"-o (\S+)", command):
        assert (tmp_path / out).stat().st_size > 0


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


@settings(max_examples=12, deadline=None, derandomize=True)
@given(vb=st.sampled_from([8, 16, 32, 64, 128]), extra=st.integers(1, 600),
       k1=st.floats(0.01, 100), k2=st.floats(0.01, 100), angle=st.floats(0, 180))
def test_target_vertices_is_met_or_refused(vb, extra, k1, k2, angle):
    """README and `qmesh mesh --help`: N ends on the target or a few percent above; a miss by
    more than 10% is a QmeshError that names the target."""
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


def test_mesh_help_says_what_the_readme_says():
    done = subprocess.run([sys.executable, "-m", "qmesh", "mesh", "--help"], capture_output=True,
                          text=True, env=environment(COLUMNS="200"))
    text = " ".join(done.stdout.split())
    said = "the mesh ends on N, or near it where keeping q_ij >= 0 on the boundary needs more vertices"
    assert f"--target-vertices N aim for N vertices: {said}" in text
    assert said.replace("q_ij >= 0", "`q_ij ≥ 0`") in " ".join(README.split())


def test_files_the_readme_commands_write_are_ignored_by_git():
    """Run from the repository root, the README's commands leave nothing for `git status`."""
    text = "".join(blocks("sh") + blocks("python"))
    outputs = sorted(set(re.findall(r"-o (\S+)", text) + re.findall(r'io\.write\("([^"]+)"', text)))
    assert "disk64.vtu" in outputs and "needle.vtu" in outputs
    done = subprocess.run(["git", "check-ignore", *outputs], cwd=ROOT, capture_output=True, text=True)
    assert sorted(done.stdout.split()) == outputs
