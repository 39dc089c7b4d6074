"""qmesh_view.controller: one run and its history (the session's changes: test_view_session.py)."""

import numpy as np
import pytest

from qmesh import measure
from qmesh_view.controller import Controller, q_matrix, status_text

STAGES = ("triangulate", "adjust", "insert")


def test_starts_on_the_chapters_case():
    c = Controller()
    assert c.readout == {"q11": 0.1, "q12": 0.0, "q22": 10.0, "regions_text": ""}   # one Q
    np.testing.assert_array_equal(c.anisotropy.H, [[10.0, 0.0], [0.0, 0.1]])   # s = 5x² + 0.05y²
    assert c.params.vb == 64 and c.params.target_vertices == 212
    assert len(c.history) == 1 and c.index == 0
    assert (c.current.stage, c.current.iteration) == ("triangulate", 0)
    assert c.current.mesh.fixed.sum() == 64


def test_q_matrix_is_the_rotated_principal_conductivities():
    Q = q_matrix(10.0, 0.1, 90.0)
    np.testing.assert_allclose(Q, [[0.1, 0.0], [0.0, 10.0]], atol=1e-14)
    Q = q_matrix(4.0, 1.0, 30.0)
    np.testing.assert_allclose(np.linalg.eigvalsh(Q), [1.0, 4.0])
    t = np.deg2rad(30.0)
    np.testing.assert_allclose(Q @ [np.cos(t), np.sin(t)], 4.0 * np.array([np.cos(t), np.sin(t)]))


def test_step_advances_one_stage_in_the_algorithms_order():
    c = Controller()
    seen = [c.current.stage]
    for k in range(1, 7):
        assert c.step()
        assert c.index == k and len(c.history) == k + 1
        seen.append(c.current.stage)
    assert seen == ["triangulate", "adjust", "insert", "triangulate", "adjust", "insert",
                    "triangulate"]
    assert [s.iteration for s in c.history] == [0, 1, 1, 1, 2, 2, 2]


def test_iterate_goes_to_the_next_triangulation():
    c = Controller()
    assert c.iterate()
    assert (c.current.stage, c.current.iteration, c.index) == ("triangulate", 1, 3)
    c.step()                                   # into iteration 2
    assert c.iterate()
    assert (c.current.stage, c.current.iteration) == ("triangulate", 2)


def test_scrubbing_back_shows_the_earlier_mesh_and_step_replays_history():
    c = Controller()
    c.iterate()
    c.iterate()
    n = len(c.history)
    first, later = c.history[0], c.current
    assert later.mesh.n_vertices > first.mesh.n_vertices         # points were inserted
    shown = c.scrub(0)
    assert shown is first and c.current.mesh is first.mesh
    assert c.current.mesh.n_vertices == first.mesh.n_vertices
    assert c.step() and c.current is c.history[1]
    assert len(c.history) == n                                   # replayed, not recomputed
    assert c.scrub(10_000) is c.history[-1]                      # clamped
    assert c.scrub(-5) is c.history[0]


def test_run_goes_to_convergence_and_then_stops_advancing(chapter_run):
    c = chapter_run
    assert c.at_end
    assert c.history[-1].stage == "triangulate"
    assert c.done or c.history[-1].converged
    n = len(c.history)
    last = c.index
    c.scrub(last)
    assert not c.step() and not c.iterate()
    assert len(c.history) == n and c.index == last


def test_status_holds_the_status_line_numbers():
    c = Controller()
    c.iterate()
    s = c.status()
    st = c.current.stats
    assert (s["iteration"], s["stage"]) == (1, "triangulate")
    assert s["n_vertices"] == st.n_vertices == c.current.mesh.n_vertices
    assert s["energy"] == st.energy and s["min_quality"] == st.min_quality
    assert s["q_nonnegative"] == 1.0                      # Q-Delaunay after triangulate
    assert s["kappa2"] == pytest.approx(measure.condition_number(c.current.mesh, c.anisotropy))
    assert s["history_length"] == 4
    line = status_text(s)
    for part in ("iteration 1", "triangulate", f"N = {st.n_vertices}", "E = ", "κ2 = ",
                 "q_ij ≥ 0: 100.0%"):
        assert part in line


def test_quick_status_needs_no_stiffness_matrix_until_measured():
    c = Controller()
    c.step()
    quick = c.status(quick=True)
    assert quick["kappa2"] is None and quick["q_nonnegative"] is None
    assert quick["n_vertices"] == c.current.mesh.n_vertices and quick["stage"] == "adjust"
    assert "κ2 = –" in status_text(quick)
    full = c.status()
    assert full["kappa2"] > 1 and 0 < full["q_nonnegative"] <= 1
    assert c.status(quick=True) == full                  # measured once, cached


def test_convergence_series_has_one_point_per_iteration(chapter_run):
    series = chapter_run.convergence()
    its = series["iteration"]
    n_tri = sum(s.stage == "triangulate" for s in chapter_run.history)
    assert its == list(range(n_tri))
    assert len(series["energy"]) == len(series["kappa2"]) == len(series["n_vertices"]) == n_tri
    assert series["energy"][-1] < series["energy"][0]           # the vertex step lowers E
    assert series["n_vertices"][-1] == chapter_run.history[-1].mesh.n_vertices
    assert all(k > 1 for k in series["kappa2"])
