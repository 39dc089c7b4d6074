"""The chapter's data, and the isotropic reproduction with Triangle."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import qmesh
from qmesh import measure
from qmesh.compare import chapter, isotropic, require
from qmesh.geometry.triangles import signed_areas


@pytest.mark.parametrize("vb", [32, 45, 64, 90, 128])
def test_isotropic_reproduces_chapter(vb, chapter_anisotropy):
    """Triangle is deterministic: N within 5% and κ2 within 25% of the chapter's isotropic column."""
    mesh = isotropic.isotropic_mesh(vb)
    ref = chapter.row(vb, "isotropic")
    assert abs(mesh.n_vertices / ref["n_vertices"] - 1) <= 0.05
    kappa = measure.condition_number(mesh, chapter_anisotropy)
    assert abs(kappa / ref["kappa2"] - 1) <= 0.25


def test_isotropic_mesh_keeps_the_vb_gon(chapter_anisotropy):
    """Counter-clockwise triangles, exactly the VB seeds on the boundary, marked fixed and unmoved."""
    vb = 45
    mesh = isotropic.isotropic_mesh(vb)
    assert np.all(signed_areas(mesh.points, mesh.triangles) > 0)
    assert mesh.boundary.sum() == vb
    np.testing.assert_array_equal(np.flatnonzero(mesh.fixed), np.arange(vb))
    np.testing.assert_allclose(mesh.points[:vb], qmesh.Disk(vb).seeds, atol=1e-12)
    area = np.abs(signed_areas(mesh.points, mesh.triangles)).sum()
    assert area == pytest.approx(qmesh.Disk(vb).area, rel=1e-12)


def test_switches_write_the_area_in_plain_decimals():
    s = isotropic.switches(2.5e-05)
    assert "e" not in s.lower().replace("yq", "")
    assert s == "pq30a0.000025YQ"


def test_triangle_area_and_targets_interpolate_between_the_chapter_values():
    assert chapter.triangle_area(64) == 0.007
    assert chapter.adapted_target(128) == 428
    a = chapter.triangle_area(100)
    assert chapter.triangle_area(128) < a < chapter.triangle_area(90)
    n = chapter.adapted_target(100)
    assert 280 < n < 428
    assert chapter.triangle_area(600) < chapter.triangle_area(512)


def test_chapter_tables_are_complete():
    for table in (chapter.ISOTROPIC, chapter.ADAPTED):
        assert set(table) == set(chapter.QUANTITIES)
        assert all(len(v) == len(chapter.VB) for v in table.values())
    assert len(chapter.TRIANGLE_AREA) == len(chapter.VB)
    assert chapter.row(33, "adapted") is None
    with pytest.raises(qmesh.QmeshError):
        chapter.row(32, "other")
    with pytest.raises(qmesh.QmeshError):
        chapter.triangle_area(2)


def test_missing_optional_package_gives_a_clear_error():
    with pytest.raises(qmesh.QmeshError, match="pip install"):
        require("qmesh_no_such_package", "this test")


def test_compare_layer_imports_its_optional_packages_lazily():
    """`import qmesh` never loads qmesh.compare; qmesh.compare loads no optional package at import."""
    code = ("import sys, qmesh; assert not any(m.startswith('qmesh.compare') for m in sys.modules); "
            "import qmesh.compare.table; "
            "bad = [m for m in ('triangle', 'matplotlib', 'gmsh', 'mmgpy') if m in sys.modules]; "
            "assert not bad, bad")
    subprocess.run([sys.executable, "-c", code], check=True)
