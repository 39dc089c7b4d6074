"""FVCA5 test 7 at N = 2000: the last face's run split two edges of Ω's top side next to the
corner (1, 1) as its budget ran out, leaving three short boundary edges under one apex (metric
quality 0.524; MMG2D 0.619). Its run's poor fans on Ω's edges are mended (mesher.polish)."""

import warnings

import qmesh
from qmesh import measure
from qmesh.domain import media_cases
from tests.media.cases import check_mesh


def test_the_oblique_barrier_keeps_no_poor_boundary_fan():
    domain, cond, _ = media_cases.fvca7()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(domain, cond, target_vertices=2000)
    check_mesh(domain, cond, m)
    assert measure.quality(m, cond).min() > 0.6                       # 0.524 before
    assert min(measure.q_nonnegative_fractions(m, cond).values()) == 1.0
    assert abs(m.n_vertices - 2000) <= 0.01 * 2000
