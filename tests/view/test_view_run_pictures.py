"""Which stages a Run draws (app.py `_run_stage`): a Run of a small mesh over before
`FIRST_PICTURE` shows its last stage only (an earlier picture would hold the last one back until
it is drawn); a longer Run shows stages on the way, the last one last; a Run with a pause
(`--run-pause`) shows every stage."""

import asyncio

import qmesh_view.app as app_module
from qmesh_view.app import QmeshView


def _drawn_in_a_run(monkeypatch, first_picture, run_pause=0.0):
    monkeypatch.setattr(app_module, "FIRST_PICTURE", first_picture)
    app = QmeshView(vb=64, target_vertices=212, run_pause=run_pause)
    shown, show = [], app._show_stage

    async def recorded(*args, **kwargs):
        shown.append(kwargs.get("index", app.session.index))
        return await show(*args, **kwargs)

    app._show_stage = recorded
    asyncio.run(app._run())
    return app.session, shown


def test_a_short_run_draws_its_last_stage_only(monkeypatch):
    session, shown = _drawn_in_a_run(monkeypatch, 5.0)
    assert session.at_end and len(session.history) > 2
    assert shown == [len(session.history) - 1]


def test_a_run_past_the_first_picture_draws_on_the_way_and_ends_on_its_last_stage(monkeypatch):
    session, shown = _drawn_in_a_run(monkeypatch, 0.0)
    assert session.at_end
    assert len(shown) >= 2 and shown[-1] == len(session.history) - 1
    assert shown == sorted(shown)


def test_a_paused_run_draws_every_stage_from_the_first(monkeypatch):
    session, shown = _drawn_in_a_run(monkeypatch, 5.0, run_pause=0.1)
    assert session.at_end
    assert shown == list(range(1, len(session.history)))
