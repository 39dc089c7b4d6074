"""A field's adjust stage takes the shape step once a round: without s every interior vertex
takes it, the two rings next to the boundary included, and a vertex's step reads only its own
star, so the layer's second step (which a varying s takes instead of its vertex step) would give
the same numbers again."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

import qmesh
from qmesh.mesher import adjust, stages, triangulate

SQUARE = qmesh.Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])
FIELD = qmesh.TensorField.principal(1, 1e-2, "30*sin(pi*x)")
METRIC_ONLY = qmesh.Anisotropy.metric_only(
    lambda X: np.stack([np.stack([1.0 + 4.0 * X[:, 0] ** 2, X[:, 0] * X[:, 1]], -1),
                        np.stack([X[:, 0] * X[:, 1], 2.0 + X[:, 1]], -1)], -2))


def _calls_per_adjust(monkeypatch, domain, anisotropy, **options):
    """The shape steps each adjust stage of one run took."""
    calls = []
    monkeypatch.setattr(stages, "shape_step",
                        lambda *a, **k: calls.append(1) or adjust.shape_step(*a, **k))
    per_stage = []
    for step in qmesh.iterate(domain, anisotropy, **options):
        if step.stage == "adjust":
            per_stage.append(len(calls))
            calls.clear()
        elif step.stage == "insert":
            calls.clear()
    return per_stage


def test_a_field_takes_one_shape_step_a_round(monkeypatch):
    per_stage = _calls_per_adjust(monkeypatch, SQUARE, FIELD, target_vertices=400)
    assert len(per_stage) >= 2 and set(per_stage) == {1}


def test_a_varying_s_still_takes_the_layers_shape_step(monkeypatch):
    s = qmesh.Anisotropy.from_expression("exp(x) + y**2")
    per_stage = _calls_per_adjust(monkeypatch, SQUARE, s, target_vertices=400)
    assert per_stage and set(per_stage) == {1}    # the layer's; the others take Newton's step


@settings(max_examples=25, deadline=None)
@given(n=st.integers(12, 80), seed=st.integers(0, 10**6), rings=st.integers(1, 3))
def test_a_vertex_step_reads_only_its_own_star(n, seed, rings):
    """The step of the layer's vertices is the same, bit for bit, whether every interior vertex
    moves or the layer alone: what lets a field skip the layer's second step."""
    rng = np.random.default_rng(seed)
    P = rng.random((n, 2))
    T = triangulate.orient_ccw(P, Delaunay(P).simplices)
    on_boundary = np.zeros(n, bool)
    on_boundary[np.unique(Delaunay(P).convex_hull)] = True
    layer = adjust.boundary_layer(T, on_boundary, rings)
    every = adjust.shape_step(P, T, METRIC_ONLY, ~on_boundary, on_boundary)
    alone = adjust.shape_step(P, T, METRIC_ONLY, layer, on_boundary)
    assert every[layer].tobytes() == alone[layer].tobytes()
