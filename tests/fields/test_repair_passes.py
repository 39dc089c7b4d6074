"""What a repair round looks at and holds (qmesh/fields/repair_state.py, moves.py, the raster's
means): the failing edges are judged again only where a step changed the shares or the twins,
so a certify pass judges every edge once and then only what its rounds changed, however many
rounds it takes and however large the mesh; the movers are picked from the candidates' stars
alone, the same ones a pass over the whole mesh picks; a raster's tries share their far sides,
its means are taken a run of triangles at a time and the polish's tries a run of movers at a
time, each to the same bits as all at once."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh.conductivity import means as _m
from qmesh.fields import flips, moves, repair_state, splits
from qmesh.fields.cache import ElementMeans
from qmesh.fields.certify import certify
from qmesh.fields.repair_state import RepairState
from qmesh.fields.shares import failing
from qmesh.geometry import topology
from tests.fields.test_certify import random_raster, square_mesh
from tests.fields.test_field_mesh import UNIT


def raster_state(seed, n, cells):
    """The repair state of a random mesh of the unit square under a random raster."""
    P, T = square_mesh(seed, n)
    edges, k1, k2, angle = random_raster(seed, cells, 3.0)
    field = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    return RepairState.of(P, T, ElementMeans(field))


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.sampled_from([60, 600, 3000]),
       cells=st.integers(2, 8))
def test_a_round_judges_only_the_edges_its_steps_changed(seed, n, cells):
    """After flips and a split, `fail` judges the half-edges of the triangles they changed and
    the twins across them (at most 6 a triangle, whatever the mesh's size) and finds the
    failing edges, and their q_ij, a whole-mesh pass finds."""
    state = raster_state(seed, n, cells)
    for step in ("flips", "split"):
        if step == "flips":
            t = state.flip(flips.mending_flips(state, state.h))
        elif len(state.h):
            t = splits.split_failing(state, state.h, state.q)
        else:
            continue
        state.refresh(t)
        before = state.examined
        state.fail()
        assert state.examined - before <= 6 * len(np.unique(t))
        h, q, _ = failing(state.s, state.b, state.cut)
        assert np.array_equal(state.h, h) and np.array_equal(state.q, q)


def test_certify_judges_every_edge_once_however_many_rounds(monkeypatch):
    """A certify pass of many rounds on a raster judges the whole mesh's edges once, when its
    state is made; each round after that only the edges its flips, splits and moves changed
    (a whole-mesh pass each round made the rounds' cost grow with the mesh)."""
    passes = []
    whole = repair_state.failing
    monkeypatch.setattr(repair_state, "failing",
                        lambda *a, **k: passes.append(len(a[0])) or whole(*a, **k))
    edges, k1, k2, angle = random_raster(5, 24, 2.0)
    field = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    start = qmesh.mesh(UNIT, qmesh.Anisotropy.constant(np.eye(2)), target_vertices=800)
    mesh, cert = certify(start, field)
    assert cert.remaining == 0 and cert.rounds >= 5
    assert len(passes) == 1


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(20, 400), share=st.floats(0.01, 1.0))
def test_movers_from_the_candidates_stars_are_the_whole_mesh_s(seed, n, share):
    """`moves.movers` looks only at the candidates' stars and their neighbours and picks the
    vertices the rule over the whole mesh picks (random priorities, each the highest within
    two triangles)."""
    P, T = square_mesh(seed, n)
    twin = topology.twins(T)
    rng = np.random.default_rng(seed)
    candidates = np.flatnonzero(rng.random(len(P)) < share)
    picked = moves.movers(T, twin, candidates, np.random.default_rng(seed))
    prio = np.zeros(len(P))                       # the whole mesh's rule, written out
    prio[candidates] = 1.0 + np.random.default_rng(seed).random(len(candidates))
    tri = prio[T].max(axis=1)
    nb = np.where(twin >= 0, twin // 3, np.repeat(np.arange(len(T)), 3)).reshape(-1, 3)
    wide = np.maximum(tri, tri[nb].max(axis=1))
    best = np.zeros(len(P))
    np.maximum.at(best, T.ravel(), np.repeat(wide, 3))
    assert np.array_equal(picked, candidates[best[candidates] == prio[candidates]])


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), K=st.integers(1, 16), m=st.integers(1, 12),
       cells=st.integers(1, 40))
def test_tries_sharing_their_far_sides_have_a_raster_s_means_bit_for_bit(seed, K, m, cells):
    """K tries at moving one corner of each of m triangles, renumbered so that the corners no
    try moves are shared (`moves._far_sides_shared`): the raster's means are those over points
    of their own, bit for bit, and each far side is one segment in all the tries."""
    rng = np.random.default_rng(seed)
    edges, k1, k2, angle = random_raster(seed, cells, 3.0)
    field = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    X = np.repeat(rng.uniform(0.0, 1.0, (1, m, 3, 2)), K, axis=0)
    corner = rng.integers(0, 3, m)
    X[:, np.arange(m), corner] = rng.uniform(0.0, 1.0, (K, m, 2))   # the mover's places
    pts, tri = X.reshape(-1, 2), np.arange(3 * K * m).reshape(-1, 3)
    shared, stri = moves._far_sides_shared(pts, K, corner)
    assert np.array_equal(shared[stri], pts[tri])
    assert np.all(np.diff(stri, axis=1) > 0)      # each triangle's corners in the same order
    assert len(shared) == (K + 2) * m
    Q, e = field.means_with_error(pts, tri)
    Qs, es = field.means_with_error(shared, stri)
    assert np.array_equal(Q, Qs) and np.array_equal(e, es)


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(30, 400), run=st.integers(1, 64))
def test_raster_means_a_run_of_triangles_at_a_time_are_the_whole_mesh_s(seed, n, run):
    """`means.raster_means` takes MEAN_TRIANGLES triangles at a time (its memory that of a run):
    the means and bounds are those of the whole mesh at once, bit for bit, and a flat triangle
    is named by its number in the mesh."""
    P, T = square_mesh(seed, n)
    edges, k1, k2, angle = random_raster(seed, 9, 3.0)
    R = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)._raster
    whole = _m.raster_means(R, P, T)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(_m, "MEAN_TRIANGLES", run)
        runs = _m.raster_means(R, P, T)
        assert all(np.array_equal(a, b) for a, b in zip(whole, runs))
        flat = T.copy()
        k = len(T) - 1
        flat[k] = [flat[k, 0], flat[k, 0], flat[k, 1]]
        with pytest.raises(qmesh.QmeshError, match=f"triangle {k} "):
            _m.raster_means(R, P, flat)


def test_the_polish_judges_its_movers_a_run_at_a_time_to_the_same_moves(monkeypatch):
    """The polish judges POLISH_MOVERS movers' tries at a time (the tries of a million-vertex
    mesh's movers at once held GBs): the same moves as all at once."""
    edges, k1, k2, angle = random_raster(11, 24, 2.0)
    field = qmesh.TensorField.from_raster(edges, edges, k1, k2, angle)
    judged, calls = moves._judged, []
    tries = len(moves.STEPS) + moves.PATTERN * len(moves.REACH)

    def counted(st_, v, D, *a, **k):
        if len(D) == tries:                       # the polish's tries
            calls.append(len(v))
        return judged(st_, v, D, *a, **k)
    monkeypatch.setattr(moves, "_judged", counted)
    whole = qmesh.mesh(UNIT, field, target_vertices=1500)
    most = max(calls)
    monkeypatch.setattr(moves, "POLISH_MOVERS", 3)
    calls.clear()
    runs = qmesh.mesh(UNIT, field, target_vertices=1500)
    assert most > 3 and max(calls) <= 3           # the runs were cut
    assert np.array_equal(whole.points, runs.points)
    assert np.array_equal(whole.triangles, runs.triangles)
