"""The first triangulation built in closed form on the lattice (lattice_delaunay.py) is the one
Qhull builds on all the points: same points, same triangles, for every kind of domain and any
constant Q, at sizes past triangulate.EXACT_MAX where the closed form is used; and the twins it
gives with them are the ones a sort of its edges finds."""

import warnings

import numpy as np
import pytest
from hypothesis import given, strategies as st

import qmesh
from qmesh.geometry import topology
from qmesh.geometry.triangles import signed_areas
from qmesh.mesher import lattice_delaunay, seeding, triangulate
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


@given(domain=any_domain(), conductivity=constant_q(),
       n=st.integers(triangulate.EXACT_MAX + 500, 3 * triangulate.EXACT_MAX))
@examples(0.1)
def test_the_closed_form_twins_are_the_sorted_ones(domain, conductivity, n):
    built = []
    real = lattice_delaunay.closed_form

    def kept(*args):
        build = real(*args)
        return lambda hull_of: built.append(build(hull_of)) or built[-1]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(lattice_delaunay, "closed_form", kept)
        _first(domain.build(), conductivity.build(), n)
    for T, twin in (b for b in built if b is not None):
        assert np.array_equal(twin, topology.twins(T))


@pytest.mark.parametrize("mirrored", [False, True])
@pytest.mark.parametrize("table_fill", [lattice_delaunay.TABLE_FILL, 0])
def test_deep_triangles_twins_for_a_mirrored_frame_and_by_a_sort(mirrored, table_fill, monkeypatch):
    """The frame's reversed orientation (a, c, b) and the sorted look-up of a long thin lattice
    give the same triangles' twins as a sort of their edges."""
    monkeypatch.setattr(lattice_delaunay, "TABLE_FILL", table_fill)
    domain = qmesh.Disk(48)
    lat = seeding.metric_lattice(domain, np.array([[2.0, 0.3], [0.3, 1.0]]), 0.08,
                                 np.random.default_rng(1))
    if mirrored:
        flip = np.diag([1.0, -1.0])
        lat = seeding.Lattice(lat.points @ flip, lat.u, lat.row, flip @ lat.frame, lat.lo, lat.h)
    deep = lattice_delaunay.deep_points(domain, lat)
    T, twin = lattice_delaunay._deep_triangles(lat, np.arange(len(lat)), deep)
    assert len(T) > 500 and (signed_areas(lat.points, T) > 0).all()
    assert np.array_equal(twin, topology.twins(T))
