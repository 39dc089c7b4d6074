"""The command line keeps freed memory for reuse (`qmesh.allocator`): checked by the page faults
of a loop that allocates and frees a 64 MB array, in fresh processes with and without it."""

import os
import platform
import subprocess
import sys

import pytest

from qmesh.allocator import keep_freed_memory

LOOP = """
import resource, sys
import numpy as np
from qmesh.allocator import keep_freed_memory
tuned = keep_freed_memory() if sys.argv[1] == "tuned" else False
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(20):
    a = np.ones(8_000_000)          # 64 MB, written: every page touched
    del a
print(tuned, resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _faults(mode: str, env: dict | None = None) -> tuple[bool, int]:
    out = subprocess.run([sys.executable, "-c", LOOP, mode], capture_output=True, text=True,
                         check=True, env=env).stdout.split()
    return out[0] == "True", int(out[1])


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="glibc's malloc only")
def test_freed_arrays_are_reused_without_new_page_faults():
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    tuned, tuned_faults = _faults("tuned", env)
    _, plain_faults = _faults("plain", env)
    assert tuned
    # 20 × 64 MB of fresh pages (fewer faults where the kernel gives 2 MiB pages); reused,
    # about one array's worth
    assert plain_faults > 2_000 and tuned_faults < plain_faults / 5


def test_the_users_own_malloc_settings_are_kept():
    env = dict(os.environ, MALLOC_ARENA_MAX="2")
    tuned, _ = _faults("tuned", env)
    assert not tuned


def test_off_glibc_nothing_changes(monkeypatch):
    monkeypatch.setattr(platform, "libc_ver", lambda: ("", ""))
    assert keep_freed_memory() is False


def test_called_with_arguments_the_cli_leaves_the_allocator_alone(monkeypatch):
    import qmesh.cli
    calls = []
    monkeypatch.setattr(qmesh.cli, "keep_freed_memory", lambda: calls.append(1))
    assert qmesh.cli.main(["--version"]) == 0
    assert calls == []
    monkeypatch.setattr(sys, "argv", ["qmesh", "--version"])
    assert qmesh.cli.main() == 0
    assert calls == [1]
