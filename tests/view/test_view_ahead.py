"""Stages meshed ahead while the page is idle (`ahead.Ahead`, `Controller.ahead`, the app's
`_mesh_ahead`): the same Steps, warnings and errors as when meshed on demand, each at its turn."""

import asyncio
import hashlib
import warnings

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import qmesh_view.app as app_module
from qmesh.errors import QmeshWarning
from qmesh_view.ahead import Ahead
from qmesh_view.app import QmeshView
from qmesh_view.controller import Controller


def _hash(step) -> str:
    m = step.mesh
    return hashlib.sha256(m.points.tobytes() + m.triangles.tobytes()).hexdigest()


def _said(source):
    """Each item of `source` with the warnings raised while it was asked for, then the end or
    the error, as a list of (item or error text, [warning texts])."""
    out = []
    while True:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                item = next(source)
            except StopIteration:
                out.append(("end", [str(w.message) for w in caught]))
                return out
            except ValueError as e:
                out.append((f"error {e}", [str(w.message) for w in caught]))
                return out
        out.append((item, [str(w.message) for w in caught]))


def _talkative(n, fail):
    for k in range(n):
        if k % 2:
            warnings.warn(f"stage {k}", QmeshWarning)
        yield k
    if fail:
        raise ValueError("no more")


@given(n=st.integers(0, 6), fail=st.booleans(), early=st.integers(0, 9))
@settings(max_examples=40, deadline=None)
def test_items_warnings_and_errors_come_at_their_turn(n, fail, early):
    wrapped = Ahead(_talkative(n, fail))
    with warnings.catch_warnings(record=True) as during:
        warnings.simplefilter("always")
        for _ in range(early):
            wrapped.ahead()
    assert during == []                                   # nothing said before its turn
    assert wrapped.kept == min(early, n + 1)
    assert _said(wrapped) == _said(_talkative(n, fail))


@pytest.mark.parametrize("params", [dict(), dict(domain="rotating"), dict(domain="layered")])
def test_a_run_meshed_ahead_is_the_run_meshed_on_demand(params):
    plain, early = Controller(**params), Controller(**params)
    while early.ahead():
        pass
    assert early.all_meshed and early.meshed_ahead > 0 and len(early.history) == 1
    plain.finish()
    early.finish()
    assert [(s.stage, _hash(s)) for s in early.history] == \
           [(s.stage, _hash(s)) for s in plain.history]
    assert early.at_end and plain.at_end


def test_the_idle_app_meshes_a_small_run_ahead_and_a_large_one_not(monkeypatch):
    async def idle(app):
        app._mesh_ahead_soon()
        await app._ahead_task
        return app.session.controller

    run = asyncio.run(idle(QmeshView(vb=64, target_vertices=212)))
    assert run.all_meshed and run.meshed_ahead > 2 and len(run.history) == 1
    monkeypatch.setattr(app_module, "AHEAD_UP_TO", 100)
    run = asyncio.run(idle(QmeshView(vb=64, target_vertices=212)))
    assert not run.all_meshed and run.meshed_ahead == 0
