"""κ2 and "converged" as the viewer shows them: a stage whose Dirichlet matrix has no κ2 (a
medium's face meshed alone, touching no boundary) shows "κ2 = —" with the reason in the message
row, never a number; only a Step that says so is called converged, and only the end of a run
earns the note on how far N ended from the target."""

import math

import pytest

from qmesh_view.controller import status_text
from qmesh_view.session import Session


@pytest.fixture(scope="module")
def inclusion():
    s = Session()
    assert s.change("domain", "inclusion").ok
    s.controller.finish()               # a medium opens on its first face: every face's run
    return s


def test_every_stage_of_a_medium_shows_a_kappa2_of_at_least_one_or_a_dash_and_why(inclusion):
    history = inclusion.history
    assert len(history) > 2 and inclusion.index == len(history) - 1
    undefined = 0
    for i, step in enumerate(history):
        status = inclusion.status(i)
        text = status_text(status)
        if status["kappa2"] is None:
            undefined += 1
            assert "κ2 = —" in text
            assert any(n.startswith("κ2 is undefined: ") and "touch no boundary vertex" in n
                       for n in status["notes"]), status["notes"]
        else:
            assert math.isfinite(status["kappa2"]) and status["kappa2"] >= 1.0
            assert status["kappa2_reason"] is None and "κ2 = —" not in text
            assert not any(n.startswith("κ2 is undefined") for n in status["notes"])
        last = i == len(history) - 1
        assert step.converged == last
        assert ("· converged" in text) == last
        if not last:
            assert not any("the run ended with" in n for n in status["notes"])
    assert undefined          # the inclusions are meshed before the background that grounds them


def test_the_convergence_chart_leaves_out_stages_without_kappa2(inclusion):
    series = inclusion.convergence()
    assert all(k is None or (math.isfinite(k) and k >= 1.0) for k in series["kappa2"])
