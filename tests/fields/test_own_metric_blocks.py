"""The polish and relax in each triangle's own means take the shape step over stars of any size:
`shape_step` asks the metric for its triangles block after block (`triangles.chunks`), and each
block is served its own rows (a million-vertex raster's first polish round has stars of more
triangles than one block), giving the moves one block gives."""

import numpy as np
from hypothesis import given, settings, strategies as st

from qmesh.fields import moves
from qmesh.geometry import triangles
from tests.fields.test_try_means import _movers, _state


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(40, 300), block=st.integers(1, 40))
def test_moves_in_own_means_are_the_same_block_by_block(seed, n, block):
    P, T, v = _movers(seed, n)
    want_polish, want_relax = _state(P, T), _state(P, T)
    moves.polish(want_polish, v)
    moves.relax(want_relax, None, v, shape=True)
    saved = triangles.CHUNK
    triangles.CHUNK = block                    # stars of many blocks
    try:
        got_polish, got_relax = _state(P, T), _state(P, T)
        moves.polish(got_polish, v)
        moves.relax(got_relax, None, v, shape=True)
    finally:
        triangles.CHUNK = saved
    assert np.array_equal(got_polish.P, want_polish.P)
    assert np.array_equal(got_relax.P, want_relax.P)
    assert not np.array_equal(got_polish.P, P) or not np.array_equal(got_relax.P, P)
