"""mesher.polish: a boundary vertex whose fan is poorly shaped is removed onto its neighbour on
the same straight edge, only where that helps, and every boundary share of q_ij stays ≥ 0."""

import warnings

import numpy as np
import pytest

import qmesh
from qmesh import measure
from qmesh.geometry.triangles import signed_areas
from qmesh.mesher import polish

ISO = qmesh.Anisotropy.constant(np.eye(2))
CASES = [   # (domain, Q, N): each run leaves a boundary fan below polish.POOR
    (qmesh.Domain([(0, 0.425), (1, 0.625), (1, 1), (0, 1)]), ISO, 860),
    (qmesh.domains.NAMED["L-shape"](), qmesh.Anisotropy.constant(qmesh.CHAPTER_Q), 1000),
    (qmesh.domains.NAMED["plate with holes"](), qmesh.Anisotropy.constant(qmesh.CHAPTER_Q), 1000),
    (qmesh.domains.NAMED["annulus"](), qmesh.Anisotropy.principal(100.0, 1.0, 30.0), 1000),
]


def _mesh(domain, A, n):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        return qmesh.mesh(domain, A, target_vertices=n)


@pytest.mark.parametrize("domain, A, n", CASES)
def test_poor_boundary_fans_are_mended_keeping_q_nonnegative(domain, A, n):
    m = _mesh(domain, A, n)
    out = polish.collapse_poor_fans(m, A, np.ones(m.boundary_tags.max() + 1, bool))
    q0, q1 = measure.quality(m, A), measure.quality(out, A)
    assert q0.min() < polish.POOR                    # the case has a poor fan ...
    assert q1.min() > q0.min() + 0.02                # ... which the polish lifts
    assert 0 < m.n_vertices - out.n_vertices <= 0.01 * m.n_vertices
    assert min(measure.q_nonnegative_fractions(out, A).values()) == 1.0
    assert measure.q_nonnegative_fraction_boundary(out, A) == 1.0
    # vertices only removed, never moved; the input points first and kept; tags kept
    kept = np.flatnonzero((m.points[:, None] == out.points[None]).all(axis=2).any(axis=1))
    assert np.array_equal(m.points[kept], out.points)
    assert np.array_equal(out.fixed, m.fixed[kept]) and out.fixed.sum() == m.fixed.sum()
    assert set(out.boundary_tags.tolist()) == set(m.boundary_tags.tolist())
    area = signed_areas(out.points, out.triangles)
    assert area.min() > 0 and area.sum() == pytest.approx(domain.area, rel=1e-12)


def test_edges_that_may_not_lose_vertices_keep_them():
    domain, A, n = CASES[0]
    m = _mesh(domain, A, n)
    assert polish.collapse_poor_fans(m, A, np.zeros(m.boundary_tags.max() + 1, bool)) is m
