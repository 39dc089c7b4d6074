"""qmesh_view.controller: the app's logic without a browser."""

import threading

import numpy as np
import pytest

from qmesh import measure
from qmesh.errors import QmeshError
from qmesh_view.controller import Controller, q_matrix, reconcile, status_text

STAGES = ("triangulate", "adjust", "insert")


def test_starts_on_the_chapters_case():
    c = Controller()
    assert c.readout == {"q11": 0.1, "q12": 0.0, "q22": 10.0}
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


def test_a_q_change_restarts_from_the_start():
    c = Controller()
    c.iterate()
    before = c.current
    assert c.set_params(k2=5.0)
    assert len(c.history) == 1 and c.index == 0
    assert (c.current.stage, c.current.iteration) == ("triangulate", 0)
    assert c.readout == {"q11": 0.1, "q12": 0.0, "q22": 5.0}
    np.testing.assert_allclose(c.anisotropy.H, [[5.0, 0.0], [0.0, 0.1]])
    assert c.current is not before
    c.iterate()
    assert c.current.mesh.n_vertices != before.mesh.n_vertices or not np.array_equal(
        c.current.mesh.points, before.mesh.points)


def test_rotating_q_changes_the_readout_and_restarts():
    c = Controller()
    c.step()
    assert c.set_params(angle=45.0)
    r = c.readout
    assert r["q11"] == pytest.approx(5.05) and r["q22"] == pytest.approx(5.05)
    assert r["q12"] == pytest.approx((0.1 - 10.0) / 2)
    assert len(c.history) == 1


def test_unchanged_or_bad_parameters_keep_the_run():
    c = Controller()
    c.iterate()
    n, params = len(c.history), c.params
    assert not c.set_params(k1=0.1, vb=64)
    assert len(c.history) == n
    for bad in ({"k1": -1.0}, {"k2": 0.0}, {"vb": 2}, {"alpha": 0.0}, {"alpha": 1.5},
                {"target_vertices": 3}, {"vb": 100, "target_vertices": 90}, {"vb": 64.5}, {"colour": 1}, {"k1": float("nan")}):
        with pytest.raises(QmeshError):
            c.set_params(**bad)
        assert c.params == params and len(c.history) == n


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


def test_stop_ends_a_run_in_another_thread():
    c = Controller()
    stop_after = 4
    seen = []

    def on_step(step):
        seen.append(step.stage)
        if len(seen) == stop_after:
            c.stop()

    t = threading.Thread(target=lambda: seen.append(c.run(on_step=on_step)))
    t.start()
    t.join(timeout=60)
    assert not t.is_alive()
    assert seen[-1] == stop_after                         # run() returned the stages shown
    assert c.index == stop_after and not c.at_end


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


def test_vb_and_the_target_move_together_the_one_changed_wins():
    c = Controller()
    c.iterate()
    assert c.set_params(vb=250)                   # above the target 212: the target follows
    assert (c.params.vb, c.params.target_vertices) == (250, 251)
    assert c.current.mesh.fixed.sum() == 250 and len(c.history) == 1
    assert c.set_params(target_vertices=100)      # below VB 250: VB follows
    assert (c.params.vb, c.params.target_vertices) == (99, 100)
    assert c.current.mesh.fixed.sum() == 99
    assert reconcile(c.params, {"k1": 2.0}) == {"k1": 2.0}
    assert reconcile(c.params, {"vb": 50}) == {"vb": 50}          # already below the target
    assert reconcile(c.params, {"target_vertices": 3}) == {"target_vertices": 3}   # VB ≥ 3


def test_a_pair_that_cannot_be_reconciled_is_refused_and_keeps_the_run():
    c = Controller()
    c.iterate()
    before = (c.params, list(c.history), c.index)
    for bad in ({"vb": 250, "target_vertices": 212}, {"target_vertices": 3}):
        with pytest.raises(QmeshError, match="must exceed VB"):
            c.set_params(**bad)
        assert (c.params, c.history, c.index) == before


def test_a_domain_choice_restarts_on_that_domain_and_vb_is_the_disks():
    c = Controller()
    c.iterate()
    assert c.set_params(domain="annulus")
    assert len(c.history) == 1 and len(c.domain.rings) == 2
    assert c.current.mesh.fixed.sum() == len(c.domain.seeds) == 96
    assert reconcile(c.params, {"vb": 300}) == {"vb": 300}      # VB only moves the disk's N
    with pytest.raises(QmeshError, match="96 seed points"):
        c.set_params(target_vertices=90)
    with pytest.raises(QmeshError, match="domain must be one of"):
        c.set_params(domain="torus")
    assert c.params.domain == "annulus" and c.params.target_vertices == 212


def test_an_uploaded_file_is_read_offered_and_a_bad_one_changes_nothing():
    c = Controller()
    geojson = ('{"type": "Polygon", "coordinates": [[[0,0],[3,0],[3,1],[0,1],[0,0]],'
               ' [[1,0.3],[1,0.7],[2,0.7],[2,0.3],[1,0.3]]]}')
    assert c.add_upload("plate.geojson", geojson) == "file: plate.geojson"
    assert c.params.domain == "file: plate.geojson" and "plate.geojson" in c.uploads
    assert c.domain.area == pytest.approx(3.0 - 0.4)
    history = list(c.history)
    with pytest.raises(QmeshError, match="bad.csv"):
        c.add_upload("bad.csv", "1,2\n3,4\n")
    assert "bad.csv" not in c.uploads and c.history == history
    assert c.params.domain == "file: plate.geojson"


def test_sh_share_counts_the_edges_where_the_lifted_facets_meet_convexly():
    import qmesh
    from qmesh_view.controller import sh_nonnegative_fraction
    A = qmesh.Anisotropy.from_expression("x**2 + y**2")          # lower hull = Delaunay
    P = np.array([[-1.0, 0.0], [1.0, 0.0], [0.0, 0.5], [0.0, -0.5]])
    not_delaunay = qmesh.Mesh(P, np.array([[0, 1, 2], [1, 0, 3]]))   # across AB: a ridge
    delaunay = qmesh.Mesh(P, np.array([[0, 3, 2], [3, 1, 2]]))       # across CD: a valley
    assert sh_nonnegative_fraction(not_delaunay, A) == 0.0
    assert sh_nonnegative_fraction(delaunay, A) == 1.0
    # a constant Q: the share for s_h is the share of q_ij ≥ 0 (the same cotangent formula)
    c = Controller()
    c.run()
    frac = sh_nonnegative_fraction(c.current.mesh, c.anisotropy)
    assert frac == measure.q_nonnegative_fraction(c.current.mesh, c.anisotropy) == 1.0


def test_s_as_text_restarts_and_a_bad_text_keeps_the_run():
    c = Controller()
    assert c.set_params(q_mode="expression", s_text="cosh(3*x) + 0.02*y**2")
    assert c.anisotropy.expression == "cosh(3*x) + 0.02*y**2" and not c.anisotropy.is_constant
    c.run()
    status = c.status()
    assert status["q_nonnegative_sh"] == 1.0                   # the construction's guarantee
    assert "for s_h: 100.0%" in status_text(status)
    history = list(c.history)
    for bad, match in (("__import__('os')", "__import__"), ("x**2 - y**2", "convex"),
                       ("", "empty"), ("open('f')", "open")):
        with pytest.raises(QmeshError, match=match):
            c.set_params(s_text=bad)
        assert c.params.s_text == "cosh(3*x) + 0.02*y**2" and c.history == history
    assert c.set_params(q_mode="constant")                     # back to k1, k2, angle
    assert c.anisotropy.is_constant and "for s_h" not in status_text(c.status())
