"""examples/quickstart.ipynb executed headless with nbclient (an ipykernel kernel, no frontend).

No cell may fail; an extra cell, appended here, moves a slider and presses a button of the
widget the notebook opened and asserts on its state. nbclient's kernel has no Jupyter server
behind it, so the widget's "auto" backend is the static one.

nbformat and nbclient are imported by the tests that use them, not at collection: they load
jsonschema, whose format checker compiles a grammar on import (~2 s of CPU in every worker).
"""

from pathlib import Path

import pytest

NOTEBOOK = Path(__file__).resolve().parents[2] / "examples" / "quickstart.ipynb"

EXTRA_CELL = """\
assert view.backend == "static"
c = view.controller
assert (c.params.k1, c.params.k2, c.params.vb, c.params.target_vertices) == (0.1, 10.0, 64, 212)
picture = view.view_widgets["mesh"].value
view.sliders["angle"].value = 60.0
view.buttons["iterate"].click()
assert c.params.angle == 60.0
assert (c.current.stage, c.current.iteration) == ("triangulate", 1)
assert view.history.value == c.index == len(c.history) - 1
assert view.view_widgets["mesh"].value != picture
assert f"N = {c.current.stats.n_vertices}" in view.status.value
print("widget ok", c.current.stats.n_vertices)
"""


def test_the_notebook_is_stored_without_outputs():
    import nbformat
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code and all(not c.outputs and c.execution_count is None for c in code)


@pytest.mark.slow
def test_the_notebook_runs_headless_and_its_widget_answers(tmp_path):
    import nbclient
    import nbformat
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nb.cells.append(nbformat.v4.new_code_cell(EXTRA_CELL))
    client = nbclient.NotebookClient(nb, kernel_name="python3", timeout=120,
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()                       # raises CellExecutionError if any cell fails
    code = [c for c in nb.cells if c.cell_type == "code"]
    for cell in code:
        assert not [o for o in cell.outputs if o.output_type == "error"], cell.source
    text = "".join(o.get("text", "") for c in code for o in c.outputs if o.output_type == "stream")
    assert "converged: True" in text
    assert "vertices read back" in text
    assert "widget ok" in text
    assert "X server" not in text and "vtkXOpenGLRenderWindow" not in text   # EGL chosen first
    images = [o for c in code for o in c.outputs if "image/png" in o.get("data", {})]
    assert images, "the convergence plot is missing"
    widget_views = [o for o in code[-2].outputs
                    if "application/vnd.jupyter.widget-view+json" in o.get("data", {})]
    assert len(widget_views) == 1, "the last notebook cell should display the widget"
    assert list(tmp_path.iterdir()) == []  # the export went to a temporary folder, now removed
