"""qmesh_view.session: every change outcome, last-value-wins coalescing, recovery after an
exception, the memory budget, warnings and the one run loop — without any UI toolkit."""

import asyncio
import sys

import numpy as np
import pytest

import qmesh
import qmesh_view.controller
from qmesh.errors import QmeshError
from qmesh_view.session import Session


def frozen_state(s):
    return (s.params, s.controller, list(s.history), s.index)


def test_the_session_imports_no_ui_toolkit():
    import subprocess
    code = ("import sys, qmesh_view.session; "
            "print([m for m in ('trame', 'ipywidgets') if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_applied_restarts_with_the_new_q():
    s = Session()
    s.iterate()
    before = s.current
    out = s.change("angle", 45)
    assert (out.kind, out.message) == ("applied", "")
    assert s.params.angle == 45.0 and len(s.history) == 1 and s.current is not before
    assert s.readout["q12"] == pytest.approx((0.1 - 10.0) / 2)
    assert s.change("angle", 45.0).kind == "unchanged"


def test_adjusted_moves_vb_and_the_target_together_and_says_so():
    s = Session()
    out = s.change("vb", 250)
    assert out.kind == "adjusted" and "target vertices set to 251" in out.message
    assert (s.params.vb, s.params.target_vertices) == (250, 251)
    assert s.current.mesh.fixed.sum() == 250
    out = s.change("target_vertices", 100)
    assert out.kind == "adjusted" and "VB set to 99" in out.message
    assert (s.params.vb, s.params.target_vertices) == (99, 100)
    assert out.message in s.messages


@pytest.mark.parametrize("name, value, match", [
    ("k1", -1.0, "k1 must be > 0"), ("k2", "abc", "k2 must be a number"),
    ("vb", 2, "at least 3"), ("alpha", 1.5, "alpha"), ("target_vertices", 3, "must exceed"),
    ("vb", 64.5, "integer"), ("k1", float("nan"), "finite"), ("domain", "torus", "domain must be"),
    ("colour", 1, "unknown parameter"), ("q_mode", "magic", "q_mode"),
    ("target_vertices", 2_000_000_000, "GiB"), ("target_vertices", "2e9", "GiB"),
    ("target_vertices", "2.125e2", "integer"), ("seed", True, "integer")])
def test_refused_keeps_everything_and_says_why(name, value, match):
    s = Session()
    s.iterate()
    kept = frozen_state(s)
    out = s.change(name, value)
    assert out.kind == "refused" and match in out.message, out.message
    assert frozen_state(s) == kept
    assert s.messages[0] == out.message
    assert s.step().kind == "applied"                     # and the session still works


def test_a_batch_applies_in_order_the_later_value_winning():
    s = Session()
    out = s.change(angle=10, k1=2.0, vb=300)
    assert out.kind == "adjusted"
    assert (s.params.angle, s.params.k1, s.params.vb, s.params.target_vertices) == (
        10.0, 2.0, 300, 301)
    out = s.change(k1=-1, k2=3.0)                          # one refused, the other applied
    assert out.kind == "adjusted" and "k1 must be > 0" in out.message
    assert (s.params.k1, s.params.k2) == (2.0, 3.0)


def test_last_value_wins_when_a_burst_is_coalesced():
    s = Session()
    for angle in (5, 10, 15, 20, 25, 30, 35, 40, 45):       # ArrowRight ×9 while busy
        s.submit("angle", angle)
    s.submit("k1", 3.0)
    s.submit("angle", 45)                                  # the angle moved last
    assert list(s.take_pending()) == ["k1", "angle"]
    for angle in (5, 50, 45):
        s.submit("angle", angle)
    assert s.has_pending("angle") and not s.has_pending("k1")
    out = s.apply_pending()
    assert out.kind == "applied" and s.params.angle == 45.0 and len(s.history) == 1
    assert s.apply_pending() is None


def test_any_exception_in_an_action_keeps_the_previous_mesh_and_history(monkeypatch):
    s = Session()
    s.iterate()
    kept = frozen_state(s)
    real = qmesh_view.controller.qmesh.iterate

    def fails(domain, anisotropy, **options):
        if anisotropy.H[0, 0] == 5.0:                      # H = adj Q = diag(k2, k1)
            raise MemoryError("no room")
        yield from real(domain, anisotropy, **options)
    monkeypatch.setattr(qmesh_view.controller.qmesh, "iterate", fails)
    out = s.change("k2", 5.0)
    assert out.kind == "refused" and out.message == "MemoryError: no room"
    assert frozen_state(s) == kept
    assert s.step().kind == "applied" and s.index == kept[3] + 1


def test_an_exception_while_stepping_keeps_the_history_and_reset_starts_again(monkeypatch):
    s = Session()
    s.step()
    run = s.controller

    def boom():
        raise RecursionError("too deep")
        yield                                              # a generator
    run._gen = boom()
    history = list(s.history)
    out = s.step()
    assert out.kind == "refused" and "RecursionError: too deep" in out.message
    assert s.history == history and s.index == 1
    assert s.reset().kind == "applied" and len(s.history) == 1


def test_uploads_and_s_text_are_outcomes_too():
    s = Session()
    geojson = ('{"type": "Polygon", "coordinates": [[[0,0],[3,0],[3,1],[0,1],[0,0]],'
               ' [[1,0.3],[1,0.7],[2,0.7],[2,0.3],[1,0.3]]]}')
    assert s.upload("plate.geojson", geojson).kind == "applied"
    assert s.params.domain == "file: plate.geojson" and "file: plate.geojson" in s.domain_names()
    assert s.domain.area == pytest.approx(3.0 - 0.4)
    kept = frozen_state(s)
    for name, content in (("bad.csv", "1,2\n3,4\n"), ("x.csv", OverflowError("big")),
                          (None, "0,0\n1,0\n0,1\n")):
        out = s.upload(name, content)
        assert out.kind == "refused" and out.message and frozen_state(s) == kept
    assert "bad.csv" not in s.uploads
    assert s.apply_s("__import__('os')").kind == "refused" and frozen_state(s) == kept
    assert s.change("domain", "disk").kind == "applied"
    out = s.apply_s("cosh(3*x) + 0.02*y**2")
    assert out.kind == "applied" and not s.anisotropy.is_constant
    run = s.controller
    assert s.apply_s("cosh(3*x) + 0.02*y**2").kind == "applied" and s.controller is not run


def test_the_memory_budget_refuses_before_meshing():
    from qmesh_view import memory
    allowed = memory.held_bytes() + 200 * 2**20          # the budget counts what is held too
    s = Session(memory_budget=allowed)
    out = s.change("target_vertices", 200_000)
    assert out.kind == "refused" and f"memory budget ({memory.gib(allowed)})" in out.message
    assert s.change("target_vertices", 300).kind == "applied"
    out = s.apply_s("exp(x) + y**2")                        # 300 vertices of varying s: fits
    assert out.kind == "applied"
    with pytest.raises(QmeshError, match="GiB"):
        Session(target_vertices=10**9)


def test_warnings_reach_the_messages():
    s = Session(vb=512, target_vertices=513)
    notes = s.status()["notes"]
    assert any("no interior vertex" in n for n in notes) and notes == s.messages
    assert s.status(quick=True)["notes"] == []

    def warns():
        import warnings
        warnings.warn("a thin domain", qmesh.QmeshWarning)
        return s.controller.step()
    out = s._move(warns)
    assert out.kind == "applied" and "warning: a thin domain" in s.messages


def test_the_one_run_loop_animates_and_stops_on_a_submitted_change():
    s = Session()
    seen = []

    async def on_step(outcome):
        seen.append(s.index)
        if len(seen) == 3:
            s.submit("k1", 2.0)                            # the next change cancels the run
    out = asyncio.run(s.run(on_step, pause=0))
    assert out.kind == "applied" and seen == [1, 2, 3] and not s.running
    assert s.params.k1 == 0.1 and s.has_pending("k1")
    assert s.apply_pending().kind == "applied" and s.params.k1 == 2.0

    async def in_thread(fn):
        return await asyncio.get_running_loop().run_in_executor(None, fn)
    out = asyncio.run(s.run(work=in_thread, pause=0))
    assert s.at_end and out.kind in ("applied", "unchanged")
    assert np.isfinite(s.status()["energy"])
