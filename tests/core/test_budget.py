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
    # bench_memory.py measured 557, 531 and 510 B/vertex at N = 4e5, 1e6 and 2e6 (constant Q),
    # 1479 and 1230 at 4e5 and 1e6 (varying s), 101 MB in all at 1e4 (varying s)
    for n, per in ((400_000, 557), (1_000_000, 531), (2_000_000, 510)):
        assert per * n < budget.estimate_bytes(n, varying=False) < 2 * per * n
    for n, per in ((400_000, 1479), (1_000_000, 1230)):
        assert per * n < budget.estimate_bytes(n, varying=True) < 2 * per * n
    assert budget.estimate_bytes(10_000, varying=True) > 101e6
    # 9e6 vertices of the chapter's Q peaked at 4.06 GB for the whole command: 1e7 fits 12 GiB
    assert budget.estimate_bytes(10**7, varying=False) < 12 * 2**30 * budget.DEFAULT_FRACTION * 1.1


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
    assert "about 11 GiB" in text and "8.00 GiB" in text and "memory budget" in text


@pytest.mark.parametrize("varying", [False, True])
def test_a_budget_below_any_run_asks_for_a_larger_budget_not_for_zero_vertices(varying):
    tiny = budget.FIXED_BYTES // 2
    with pytest.raises(qmesh.QmeshError, match="give a larger budget") as e:
        budget.check(1000, varying=varying, budget=tiny)
    assert "at most about" not in str(e.value)
    with pytest.raises(qmesh.QmeshError, match="at most about"):    # a budget that fits some
        budget.check(10**7, varying=varying, budget=2**30)


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


@pytest.mark.parametrize("anisotropy, varying", [
    (lambda: qmesh.Anisotropy.constant([[0.1, 0], [0, 10]]), False),
    (lambda: qmesh.Anisotropy.from_expression("exp(x) + y**2"), True),
])
def test_mesh_and_iterate_refuse_what_exceeds_the_memory_available(monkeypatch, anisotropy, varying):
    """The estimate guards qmesh.mesh itself: with 384 MiB
    available, 200,000 vertices (2e5·600 B + 128 MiB, over half of 384 MiB = 192 MiB) are refused
    before anything of that size is allocated."""
    import tracemalloc
    monkeypatch.setattr(budget, "available_bytes", lambda: 384 * 2**20)
    monkeypatch.setattr(budget, "process_limits", lambda: [])
    tracemalloc.start()
    for run in (qmesh.mesh, qmesh.iterate):
        with pytest.raises(qmesh.QmeshError, match="vertices with a (varying|constant) s need about"):
            run(qmesh.Disk(16), anisotropy(), target_vertices=200_000)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < budget.estimate_bytes(200_000, varying=varying) / 4   # nothing of that size
    kind = "a varying" if varying else "a constant"
    with pytest.raises(qmesh.QmeshError, match=kind):
        qmesh.mesh(qmesh.Disk(16), anisotropy(), target_vertices=200_000)
    m = qmesh.mesh(qmesh.Disk(16), anisotropy(), target_vertices=200)   # a small mesh still fits
    assert abs(m.n_vertices - 200) <= 20


def test_the_command_line_refuses_an_impossible_target_in_one_line(monkeypatch, capsys):
    from qmesh.cli import main
    monkeypatch.setattr(budget, "available_bytes", lambda: 2**30)
    assert main(["mesh", "--disk", "16", "--target-vertices", "50000000", "-o", "x.vtu"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("qmesh: error:") and "GiB" in err[0]
