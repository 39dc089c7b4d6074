"""The first triangulation built in closed form on the lattice (lattice_delaunay.py) is the one
Qhull builds on all the points: same points, same triangles, for every kind of domain and any
constant Q, at sizes past triangulate.EXACT_MAX where the closed form is used."""

import warnings

import numpy as np
import pytest
from hypothesis import given, strategies as st

import qmesh
from qmesh.mesher import lattice_delaunay, triangulate
from strategies import any_domain, constant_q, examples

pytestmark = pytest.mark.properties


def _first(domain, anisotropy, n):
    """The first triangulation's mesh, or the QmeshError's text."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", qmesh.QmeshWarning)
        try:
            return next(qmesh.iterate(domain, anisotropy, target_vertices=n, seed=0)).mesh
        except qmesh.QmeshError as e:
            return str(e)


@given(domain=any_domain(), conductivity=constant_q(),
       n=st.integers(triangulate.EXACT_MAX + 500, 3 * triangulate.EXACT_MAX))
@examples(0.1)
def test_closed_form_equals_qhull_on_all_the_points(domain, conductivity, n):
    d, a = domain.build(), conductivity.build()
    fast = _first(d, a, n)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(lattice_delaunay, "closed_form", lambda *_: (lambda hull_of: None))
        slow = _first(d, a, n)
    if isinstance(slow, str) or isinstance(fast, str):
        assert fast == slow
        return
    assert np.array_equal(fast.points, slow.points)
    assert np.array_equal(fast.triangles, slow.triangles)


def test_the_closed_form_is_used_and_leaves_qhull_only_the_boundary_layer(monkeypatch):
    sizes = []
    real = lattice_delaunay.closed_form

    def measured(*args):
        build = real(*args)

        def run(hull_of):
            def sized(among):
                sizes.append((int(among.sum()), len(among)))
                return hull_of(among)
            return build(sized)
        return run
    monkeypatch.setattr(lattice_delaunay, "closed_form", measured)
    m = _first(qmesh.Disk(512), qmesh.Anisotropy.constant(qmesh.CHAPTER_Q), 100_000)
    assert sizes, "the closed form was not tried"
    among, n = sizes[-1]
    assert n == m.n_vertices and among < 0.15 * n, sizes      # Qhull saw the boundary layer only
