"""A user's callable asked for each point once (qmesh/conductivity/point_cache.py): the values
come back bit for bit what the callable gives, each distinct point (by its bits: −0.0 is not 0.0)
reaches the callable once while the cache holds it, the memory stays within its generations,
the calls and points are counted, and a mesh is the same with and without the cache."""

import hashlib

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh.conductivity import point_cache
from qmesh.conductivity.point_cache import PointCache


class Recorder:
    """f(X, Y) → (n, 3) of a point alone, keeping every point it was given."""

    def __init__(self):
        self.given = []

    def __call__(self, X, Y):
        self.given.append(np.column_stack([X, Y]))
        return np.column_stack([np.sin(3 * X) + Y, X * Y, np.cos(X - 2 * Y)])

    def bits(self):
        """Every point given, as one (n, 2) array of bits."""
        return np.concatenate(self.given).view(np.uint64)


def repeats(bits):
    """How many of the points (n, 2) of bits came before."""
    return len(bits) - len(np.unique(bits, axis=0))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), pool=st.integers(1, 400), capacity=st.integers(1, 600),
       batches=st.integers(1, 25))
def test_each_point_once_while_kept_and_the_values_bit_for_bit(seed, pool, capacity, batches):
    rng = np.random.default_rng(seed)
    points = rng.uniform(-1, 1, (pool, 2))
    points[rng.random(pool) < 0.1] = 0.0
    points[rng.random(pool) < 0.1] *= -1.0          # −0.0 beside 0.0: another point
    f = Recorder()
    cache = PointCache(f, capacity=capacity)
    asked = []
    for _ in range(batches):
        pick = rng.integers(0, pool, rng.integers(1, 300))
        X, Y = points[pick, 0].copy(), points[pick, 1].copy()
        got = cache(X, Y)
        want = Recorder()(X, Y)
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64))
        asked.append(points[pick])
        assert cache._new.n <= capacity and cache._old.n <= capacity
    given_bits = f.bits()
    asked_bits = np.concatenate(asked).view(np.uint64)
    counted = point_cache.Evaluations(len(f.given), len(given_bits), len(asked_bits))
    assert cache.evaluations == counted
    for call in f.given:                              # never one point twice in a call
        assert repeats(call.view(np.uint64)) == 0
    if capacity >= pool:                              # all kept: each distinct point once
        assert len(given_bits) == len(np.unique(asked_bits, axis=0))


def test_nothing_kept_only_counts():
    f = Recorder()
    cache = PointCache(f, capacity=0)
    X = np.array([0.5, 0.5, 0.25])
    for _ in range(3):
        cache(X, X)
    assert cache.evaluations == point_cache.Evaluations(3, 9, 9)


def islands(x, y):
    """Magnetic islands (an O-point and an X-point), Q = εI + (1 − ε) b bᵀ/|b|², as a user writes
    them."""
    bx, by = y - 0.5, 0.1 * np.pi * np.cos(2 * np.pi * x)
    b2 = bx * bx + by * by
    e = 1e-3
    q11, q12, q22 = e + (1 - e) * bx * bx / b2, (1 - e) * bx * by / b2, e + (1 - e) * by * by / b2
    return np.stack([np.stack([q11, q12], -1), np.stack([q12, q22], -1)], -2)


@pytest.mark.filterwarnings("ignore::qmesh.QmeshWarning")      # the repair's added vertices
def test_a_mesh_asks_a_callable_for_each_point_once_and_is_the_same_without_the_cache(monkeypatch):
    monkeypatch.setattr(point_cache, "CAPACITY", 1 << 22)     # the whole run's points kept
    runs = {}
    for cache in (True, False):
        given = []

        def f(x, y):
            given.append(np.column_stack([x, y]))
            return islands(x, y)
        field = qmesh.TensorField(f, cache=cache)
        m = qmesh.mesh(qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]), field, target_vertices=300)
        bits = np.concatenate(given).view(np.uint64)
        digest = hashlib.sha256(m.points.tobytes() + m.triangles.tobytes()).hexdigest()
        runs[cache] = digest, bits, field.evaluations
    (kept, bits, ev), (plain, plain_bits, plain_ev) = runs[True], runs[False]
    assert kept == plain                              # not a bit of the mesh changed
    assert repeats(bits) == 0                         # each point once
    assert repeats(plain_bits) > 0                    # which the mesher does ask for again
    assert ev.asked == plain_ev.asked == plain_ev.points
    assert ev.points == len(bits) == len(np.unique(plain_bits, axis=0)) < plain_ev.points
    assert 0 < ev.calls <= plain_ev.calls


def test_formulas_and_rasters_count_their_evaluations():
    F = qmesh.TensorField.from_expressions("1 + x**2", "0.1*x*y", "2")
    P = np.array([[0.1, 0.2], [0.3, 0.4]])
    F(P)
    F(P)
    assert F.evaluations == point_cache.Evaluations(2, 4, 4)      # counted, not kept
    edges = np.linspace(0, 1, 3)
    R = qmesh.TensorField.from_raster(edges, edges, 1.0, 2.0)
    R(P)
    assert R.evaluations == point_cache.Evaluations()
