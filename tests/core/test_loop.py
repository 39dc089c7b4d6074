"""Algorithm 2.1 reads as the chapter's lines: the loop calls the stages in the
chapter's order, fits in 30 lines, and the README shows it as it is."""

import ast
import inspect
import re
from pathlib import Path

from qmesh.mesher import loop

README = (Path(__file__).resolve().parents[2] / "README.md").read_text()
SOURCE = inspect.getsource(loop._algorithm_2_1)


def test_the_loop_calls_the_stages_in_the_chapters_order():
    calls = [n.func.id for n in ast.walk(ast.parse(SOURCE))
             if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)]
    stages = [c for c in calls if c in {"initial_triangulation", "adjust_vertices", "add_new_points",
                                        "retriangulate", "converged"}]
    assert stages == ["initial_triangulation", "adjust_vertices", "add_new_points",
                      "retriangulate", "converged"]


def test_the_loop_body_is_under_30_lines():
    body = SOURCE.splitlines()[1:]
    assert 5 < len(body) <= 30


def test_every_stage_names_its_equations():
    from qmesh.mesher import stages
    for fn in (stages.adjust_vertices, stages.add_new_points, stages.retriangulate,
               stages.initial_triangulation):
        assert re.search(r"\(2\.\d+\)", fn.__doc__), fn.__name__


def test_the_readme_shows_the_loop_as_it_is():
    assert f"```text\n{SOURCE}```" in README
