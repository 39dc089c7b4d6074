"""What `import qmesh` gives: the documented names, `qmesh.io` without meshio, a real `mesh` signature."""

import inspect
import subprocess
import sys

import qmesh


def test_import_qmesh_makes_io_available_without_loading_meshio():
    code = ("import sys, qmesh; assert callable(qmesh.io.write) and callable(qmesh.io.read); "
            "print('meshio' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_mesh_signature_mirrors_iterate():
    """help(qmesh.mesh) shows every option with its default, the same as iterate's."""
    mesh_params = inspect.signature(qmesh.mesh).parameters
    iterate_params = inspect.signature(qmesh.iterate).parameters
    options = [p for p in mesh_params.values() if p.kind is p.KEYWORD_ONLY]
    assert {"target_vertices", "size", "alpha", "seed"} <= {p.name for p in options}
    assert all(p.default is not p.empty for p in options)
    # mesh() takes iterate's options, and a progress callback of its own
    assert [(p.name, p.kind, p.default) for p in mesh_params.values() if p.name != "progress"] == \
        [(p.name, p.kind, p.default) for p in iterate_params.values()]
    assert mesh_params["progress"].default is None


def test_warning_is_a_user_warning_and_exported():
    assert issubclass(qmesh.QmeshWarning, UserWarning)
    assert {"QmeshError", "QmeshWarning", "io", "measure", "mesh", "iterate"} <= set(qmesh.__all__)
