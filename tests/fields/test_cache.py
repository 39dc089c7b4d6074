"""The repair's cache of element means (qmesh/fields/cache.py): a triangle's means are computed
once whatever the order of its corners, within the bound they carry of the field's own, tightened
to the field's own tolerance on demand; rasters keep their exact means."""

import numpy as np
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh.conductivity import means as _m
from qmesh.fields.cache import ElementMeans
from tests.fields.test_certify import random_raster, square_mesh

FIELD = ("1 + x**2 + sin(3*y)", "0.4*x*y", "2 + cos(2*x)")


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(10, 120))
def test_means_within_their_bound_and_each_triangle_computed_once(seed, n):
    P, T = square_mesh(seed, n)
    F = qmesh.TensorField.from_expressions(*FIELD)
    cache = ElementMeans(F)
    Q, e = cache.means_with_error(P, T)
    exact, exact_err = F.means_with_error(P, T)
    assert np.all(np.linalg.norm(Q - exact, axis=(1, 2)) <= e + exact_err + 1e-14)
    assert cache.computed == len(T)
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(T), min(len(T), 20), replace=False)
    turned = np.take_along_axis(T[pick], np.argsort(rng.random((len(pick), 3)), axis=1), axis=1)
    Q2, e2 = cache.means_with_error(P, turned)          # the same triangles, corners reordered
    assert cache.computed == len(T)
    assert np.array_equal(Q2, Q[pick]) and np.array_equal(e2, e[pick])
    Qt, et = cache.tighten(P, T[pick])
    assert np.all(et <= _m.RTOL * np.linalg.norm(Qt, axis=(1, 2)) * (1 + 1e-9) + 1e-300)
    Q3, e3 = cache.means_with_error(P, T[pick])          # kept in place of the looser ones
    assert np.array_equal(Q3, Qt) and np.array_equal(e3, et)
    moved = P.copy()
    moved[T[pick[0], 0]] += 1e-3                        # a moved corner is another triangle
    cache.means_with_error(moved, T[pick[:1]])
    assert cache.computed == len(T) + len(pick) + 1


def test_raster_means_are_the_fields_own():
    P, T = square_mesh(3, 80)
    edges, k1, k2, angle = random_raster(3, 7, 2.0)
    F = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    cache = ElementMeans(F)
    for get in (cache.means_with_error, cache.rough, cache.tighten):
        Q, e = get(P, T)
        exact, exact_err = F.means_with_error(P, T)
        assert np.array_equal(Q, exact) and np.array_equal(e, exact_err)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(10, 120))
def test_a_texts_bounds_proven_on_demand_and_kept_proven(seed, n):
    """A text's cached bounds are the rule's estimates until `prove` replaces them by its
    children's enclosures (which hold the field's means at the rule's tolerance, RTOL), `refine`
    takes them to the tolerance asked, and `tighten` no longer replaces a proven bound."""
    P, T = square_mesh(seed, n)
    F = qmesh.TensorField.from_expressions(*FIELD)
    cache = ElementMeans(F)
    assert cache.provable and not cache.proven(P, T).any()
    Q, e = cache.prove(P, T)
    assert cache.proven(P, T).all()
    reference, ref_err = F.means_with_error(P, T, bound_rtol=None)
    assert np.all(np.linalg.norm(Q - reference, axis=(1, 2)) <= e + ref_err)
    Qt, et = cache.tighten(P, T)
    assert np.array_equal(Qt, Q) and np.array_equal(et, e)
    asked = np.full(len(T), 1e-4)
    Qr, er = cache.refine(P, T, asked)
    assert np.all(er <= np.minimum(e, 1e-4 * np.linalg.norm(Qr, axis=(1, 2))) * (1 + 1e-9))
    assert np.all(np.linalg.norm(Qr - reference, axis=(1, 2)) <= er + ref_err)
    assert np.array_equal(cache.means_with_error(P, T)[1], er)      # kept
