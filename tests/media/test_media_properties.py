"""Property tests of heterogeneous media: random domains, random interfaces, random SPD Q per
region (anisotropy up to 1e3, contrasts up to 1e4)."""

import warnings

from hypothesis import HealthCheck, given, settings

import qmesh
from tests.media.cases import check_mesh, media


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(media())
def test_every_edge_keeps_q_nonnegative_and_the_regions(case):
    domain, cond = case
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        m = qmesh.mesh(domain, cond, target_vertices=300)
    check_mesh(domain, cond, m)
