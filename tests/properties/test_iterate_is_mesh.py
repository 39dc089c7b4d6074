"""`iterate`'s last Step is the mesh `mesh` returns, bit for bit, and both refuse alike.

The viewer steps through `iterate`, the command line calls `mesh`: the same inputs must give
the same mesh through both, and a target they cannot meet the same QmeshError.
"""

import warnings

import numpy as np
from hypothesis import given

import qmesh
from strategies import any_domain, cases, examples, holed_domains


def _outcome(run):
    """(points, triangles, boundary tags) of the mesh `run` makes, or the QmeshError's text."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        try:
            m = run()
        except qmesh.QmeshError as e:
            return str(e)
    return m.points, m.triangles, m.boundary_tags


def _last(steps):
    last = None
    for last in steps:
        pass
    return last.mesh


def _check(case):
    d, a, o = case.domain.build, case.conductivity.build, case.options
    by_mesh = _outcome(lambda: qmesh.mesh(d(), a(), **o))
    by_iterate = _outcome(lambda: _last(qmesh.iterate(d(), a(), **o)))
    assert type(by_mesh) is type(by_iterate), f"{by_mesh!r:.200} / {by_iterate!r:.200}\n{case}"
    if isinstance(by_mesh, str):
        assert by_mesh == by_iterate, case
    else:
        for x, y in zip(by_mesh, by_iterate):
            assert np.array_equal(x, y), case
        n, target = len(by_mesh[0]), o["target_vertices"]
        assert abs(n - target) <= 0.1 * target, f"N = {n} for a target of {target}: {case}"


@examples(0.3)
@given(cases(any_domain(), conductivity="any", max_target=1500))
def test_iterate_ends_on_the_mesh_of_mesh(case):
    _check(case)


@examples(0.15)
@given(cases(holed_domains(), conductivity="constant", max_target=1500))
def test_iterate_ends_on_the_mesh_of_mesh_with_holes(case):
    _check(case)
