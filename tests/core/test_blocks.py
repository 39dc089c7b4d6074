"""Per-triangle passes run CHUNK triangles at a time (geometry.triangles.chunks) to bound the
mesher's memory; the block size changes no bit of any mesh."""

import numpy as np
import pytest

import qmesh
from qmesh.geometry import triangles


@pytest.mark.parametrize("anisotropy", [qmesh.Anisotropy.constant(qmesh.CHAPTER_Q),
                                        qmesh.Anisotropy.from_expression("exp(x) + y**2")],
                         ids=["constant", "varying"])
def test_the_mesh_does_not_depend_on_the_block_size(anisotropy, monkeypatch):
    domain = qmesh.domains.NAMED["plate with holes"]()
    whole = qmesh.mesh(domain, anisotropy, target_vertices=1500, seed=1)
    monkeypatch.setattr(triangles, "CHUNK", 53)
    blocks = qmesh.mesh(domain, anisotropy, target_vertices=1500, seed=1)
    assert len(triangles.chunks(whole.n_triangles)) > 20
    assert np.array_equal(whole.points, blocks.points)
    assert np.array_equal(whole.triangles, blocks.triangles)


def test_measures_do_not_depend_on_the_block_size(monkeypatch):
    from qmesh import measure
    from qmesh.domain import media_cases as cases
    domain, Q, _ = cases.layered()
    m = qmesh.mesh(domain, Q, target_vertices=600)
    whole = measure.edge_weights(m, Q), measure.quality(m, Q), measure.report(m, Q)
    monkeypatch.setattr(triangles, "CHUNK", 37)
    blocks = measure.edge_weights(m, Q), measure.quality(m, Q), measure.report(m, Q)
    assert all(np.array_equal(a, b) for a, b in zip(whole[0], blocks[0]))
    assert np.array_equal(whole[1], blocks[1])
    assert whole[2] == blocks[2]
