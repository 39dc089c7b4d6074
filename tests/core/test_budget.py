"""qmesh.mesher.budget: the memory estimate and the refusal before anything is allocated."""

import pytest
from hypothesis import given, settings, strategies as st

import qmesh
from qmesh.mesher import budget


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10**9), st.integers(0, 10**9), st.booleans())
def test_the_estimate_grows_with_n_and_varying_s_costs_more(a, b, varying):
    lo, hi = sorted((a, b))
    assert budget.estimate_bytes(lo, varying=varying) <= budget.estimate_bytes(hi, varying=varying)
    assert budget.estimate_bytes(hi, varying=False) <= budget.estimate_bytes(hi, varying=True)


def test_the_estimate_is_the_measured_bytes_per_vertex():
    # bench_memory.py measured 1258 B/vertex at N = 4e5 (constant Q): the estimate covers it
    need = budget.estimate_bytes(400_000, varying=False)
    assert 1258 * 400_000 < need < 2 * 1258 * 400_000
    assert budget.estimate_bytes(10**7, varying=True) > 5962 * 10**7


@settings(max_examples=30, deadline=None)
@given(st.integers(1, 10**8), st.booleans(), st.integers(2**26, 2**40))
def test_check_refuses_exactly_what_exceeds_the_budget(n, varying, limit):
    need = budget.estimate_bytes(n, varying=varying)
    if need > limit:
        with pytest.raises(qmesh.QmeshError, match="GiB") as e:
            budget.check(n, varying=varying, budget=limit)
        assert f"{float(n):.3g} vertices" in str(e.value)
        assert budget.max_vertices(limit, varying=varying) < n
    else:
        assert budget.check(n, varying=varying, budget=limit) == need
        assert budget.max_vertices(limit, varying=varying) >= n


def test_a_2e7_target_is_refused_naming_the_estimate_and_the_budget():
    with pytest.raises(qmesh.QmeshError) as e:
        budget.check(2e7, varying=False, budget=8 * 2**30)
    text = str(e.value)
    assert "about 24 GiB" in text and "8.00 GiB" in text and "memory budget" in text


def test_available_memory_is_read_and_the_default_budget_is_half_of_it():
    avail = budget.available_bytes()
    assert 2**20 < avail < 2**50
    assert budget.default_budget() <= avail
    assert budget.check(1000, varying=False) > 0          # a small mesh always fits


@pytest.mark.parametrize("bad", [-1, float("nan"), float("inf"), "many", None])
def test_bad_counts_and_budgets_are_refused(bad):
    with pytest.raises(qmesh.QmeshError):
        budget.estimate_bytes(bad, varying=False)
    if bad is not None:
        with pytest.raises(qmesh.QmeshError):
            budget.check(1000, varying=False, budget=bad if bad != -1 else 0)
