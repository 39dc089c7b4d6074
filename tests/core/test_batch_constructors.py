"""The batch constructors other packages call are the one-by-one constructors, faster:
`Anisotropy.principals` (Domain.from_cells' zones) and `Domain.from_checked_rings` (media faces)."""

import numpy as np
from hypothesis import given, settings, strategies as st

import qmesh

positive = st.floats(1e-6, 1e6, allow_nan=False)
angle = st.floats(-720.0, 720.0, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(positive, positive, angle), min_size=1, max_size=12))
def test_principals_are_principal_one_by_one(params):
    for p, made in zip(params, qmesh.Anisotropy.principals(params)):
        one = qmesh.Anisotropy.principal(*p)
        if made is not None:                       # None: principal itself decides
            assert np.array_equal(made.matrix, one.matrix)
            assert np.array_equal(made.H, one.H)


@settings(max_examples=60, deadline=None)
@given(n=st.integers(6, 30), hole=st.booleans(), x0=st.floats(-1e6, 1e6), scale=st.floats(1e-3, 1e3),
       seed=st.integers(0, 2**31 - 1))
def test_checked_rings_store_what_domain_stores(n, hole, x0, scale, seed):
    """On rings Domain accepts (simple, the hole inside), it stores the same."""
    rng = np.random.default_rng(seed)
    t = 2 * np.pi * (np.arange(n) + rng.uniform(0, 0.5, n)) / n     # gaps under 90°: the hole fits
    outer = x0 + scale * np.c_[np.cos(t), np.sin(t)] * rng.uniform(0.8, 1.0, (len(t), 1))
    rings = [outer]
    if hole:
        rings.append(x0 + scale * 0.3 * np.c_[np.cos(-t), np.sin(-t)])
    tags = [np.full(len(R), k + 1) for k, R in enumerate(rings)]
    fast = qmesh.Domain.from_checked_rings(rings, tags)
    slow = qmesh.Domain(rings[0], rings[1:], tags=tags)
    assert fast is not None
    assert all(np.array_equal(a, b) for a, b in zip(fast.rings, slow.rings))
    assert np.array_equal(fast.segment_tags, slow.segment_tags)
    assert fast.area == slow.area
    # a clockwise outline is left to Domain itself
    assert qmesh.Domain.from_checked_rings([outer[::-1]], [tags[0]]) is None
