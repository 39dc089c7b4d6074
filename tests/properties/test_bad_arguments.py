"""Every invalid call of `bad_calls.CALLS` raises a QmeshError (a TypeError and a ValueError)
whose message names the argument. The list is finite and cheap, so it runs
completely rather than by sampling."""

import pytest

import bad_calls


@pytest.mark.parametrize("bad", bad_calls.CALLS, ids=repr)
def test_invalid_call_raises_qmesh_error_naming_the_argument(bad):
    assert bad_calls.outcome(bad) is None, f"{bad.what}: {bad_calls.outcome(bad)}"
