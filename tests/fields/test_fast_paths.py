"""The field's hot paths are only faster, never different: a text evaluated straight from its
lambdified function gives the values of `expression.parse_function` to the bit, and the metric's
interpolation those of the bilinear mix of its grid written out row by row."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh
from qmesh.conductivity.expression import parse_function
from qmesh.conductivity.anisotropy import shape_metric
from qmesh.fields.metric import field_metric, smoothed

TEXTS = ("1e-4 + (1 - 1e-4)*(4*(y - 0.5))**2/((2*(x - 0.5))**2 + (4*(y - 0.5))**2)",
         "-(1 - 1e-4)*(2*(x - 0.5))*(4*(y - 0.5))/((2*(x - 0.5))**2 + (4*(y - 0.5))**2)",
         "1e-4 + (1 - 1e-4)*(2*(x - 0.5))**2/((2*(x - 0.5))**2 + (4*(y - 0.5))**2)")


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 300))
def test_texts_evaluate_as_parse_function_does(seed, n):
    P = np.random.default_rng(seed).uniform(-1, 2, (n, 2))
    f = qmesh.TensorField.from_expressions(*TEXTS)
    q = f._evaluate(P)
    for c, text in enumerate(TEXTS):
        assert np.array_equal(q[:, c], parse_function(text, "q")(P))
    g = qmesh.TensorField.principal("1 + x*x", "0.01*exp(y)", "40*sin(2*x + y)")
    a, b, t = (parse_function(s, "k")(P) for s in ("1 + x*x", "0.01*exp(y)", "40*sin(2*x + y)"))
    c, s = np.cos(np.deg2rad(t)), np.sin(np.deg2rad(t))
    assert np.array_equal(g._evaluate(P), np.stack([a * c * c + b * s * s, (a - b) * c * s,
                                                    a * s * s + b * c * c], axis=-1))


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), width=st.sampled_from([0.3, 0.05, 0.011]))
def test_metric_is_the_bilinear_mix_of_its_grid(seed, width):
    """At points inside and outside the box (clamped to it), H is the bilinear mix of the four
    grid nodes around, computed as (1 − fu)((1 − fv) a0 + fv a1) + fu((1 − fv) a2 + fv a3)."""
    lo, hi = np.array([0.0, -1.0]), np.array([2.0, 0.5])
    f = qmesh.TensorField.from_expressions("1 + x*x", "0.3*sin(x*y)", "2 + cos(3*y)")
    H = field_metric(f, width, (lo, hi)).hessian
    rng = np.random.default_rng(seed)
    P = np.concatenate([rng.uniform(lo - 0.2, hi + 0.2, (200, 2)), [lo, hi, [lo[0], hi[1]]]])
    got = H(P)
    n = np.clip(np.ceil((hi - lo) * 2 / width).astype(int) + 1, 2, 2048)
    gx, gy = np.linspace(lo[0], hi[0], n[0]), np.linspace(lo[1], hi[1], n[1])
    nodes = np.column_stack([np.repeat(gx, n[1]), np.tile(gy, n[0])])
    table = shape_metric(smoothed(f, nodes, width, (lo, hi))).reshape(-1, 4)[:, [0, 1, 3]]
    u = np.clip((P[:, 0] - lo[0]) / (gx[1] - gx[0]), 0.0, n[0] - 1.0)
    v = np.clip((P[:, 1] - lo[1]) / (gy[1] - gy[0]), 0.0, n[1] - 1.0)
    i, j = np.minimum(u.astype(int), n[0] - 2), np.minimum(v.astype(int), n[1] - 2)
    fu, fv = (u - i)[:, None], (v - j)[:, None]
    k = i * n[1] + j
    at = [table[k + c] for c in (0, 1, n[1], n[1] + 1)]
    h = (1 - fu) * ((1 - fv) * at[0] + fv * at[1]) + fu * ((1 - fv) * at[2] + fv * at[3])
    assert np.array_equal(got, h[:, [0, 1, 1, 2]].reshape(-1, 2, 2))
