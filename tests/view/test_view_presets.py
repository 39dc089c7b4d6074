"""Every domain the viewer offers opens steppable and meshes to its end at its default target
without a warning: media from their first face's first triangulation, fields and shapes alike."""

import warnings

import pytest

from qmesh.errors import QmeshWarning
from qmesh_view.problem import CHAPTER_TARGET, PRESET_TARGETS, default_target, domain_names
from qmesh_view.session import Session


@pytest.mark.parametrize("name", domain_names())
def test_each_preset_steps_and_runs_at_its_default_without_a_warning(name):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        s = Session(domain=name)
        assert s.params.target_vertices == default_target(name)
        assert s.messages == [], s.messages
        assert len(s.history) == 1 and s.index == 0 and not s.at_end   # Step and Run enabled
        said = []
        while not s.at_end:
            outcome = s.step()
            assert outcome.kind == "applied", outcome
            said += s.action_messages
        final = s.status()
    assert said == [] and final["notes"] == [], said + final["notes"]
    assert not [w for w in caught if issubclass(w.category, QmeshWarning)]
    n, target = final["n_vertices"], s.params.target_vertices
    assert abs(n - target) <= 0.1 * target, (name, n, target)


def test_a_preset_brings_its_target_and_a_chosen_target_stays():
    s = Session()
    assert s.params.target_vertices == CHAPTER_TARGET
    assert s.change("domain", "layered").ok
    assert s.params.target_vertices == PRESET_TARGETS["layered"] and s.messages == []
    assert s.change("domain", "inclusion").ok                 # one preset's default to another's
    assert s.params.target_vertices == PRESET_TARGETS["inclusion"]
    assert s.change("domain", "disk").ok
    assert s.params.target_vertices == CHAPTER_TARGET
    assert s.change("target_vertices", 300).ok
    assert s.change("domain", "layered").ok
    assert s.params.target_vertices == 300                     # the user's choice is kept


def test_the_presets_that_need_more_than_the_chapters_target_are_presets():
    assert set(PRESET_TARGETS) <= set(domain_names())
    assert all(t > CHAPTER_TARGET for t in PRESET_TARGETS.values())
